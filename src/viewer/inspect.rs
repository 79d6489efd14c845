//! The pixel inspector: the pixel under a position on the image, what a snapshot knows of
//! it (linear RGB mean, luminance, samples, relative standard error of the mean), and
//! probes pinned to image positions whose values follow the image as it converges.
//!
//! Luminance is ITU-R BT.709's Y of the linear mean; the relative error is
//! `Snapshot::pixel_relative_error` (the standard error of the luminance over its value).

use crate::math::luminance;
use crate::render::Snapshot;
use glam::{UVec2, Vec2, Vec3};

/// The pixel of a `width` x `height` image under image position `uv` ([0, 1]^2, top-left
/// origin); None outside the image.
pub fn pixel_at(uv: Vec2, width: u32, height: u32) -> Option<UVec2> {
    let inside = (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y);
    (inside && width > 0 && height > 0).then(|| {
        let p = uv * Vec2::new(width as f32, height as f32);
        UVec2::new((p.x as u32).min(width - 1), (p.y as u32).min(height - 1))
    })
}

/// What the inspector shows of one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelValues {
    /// Pixel coordinates (top-left origin).
    pub pixel: UVec2,
    /// Linear mean radiance.
    pub rgb: Vec3,
    /// Luminance of the mean (BT.709).
    pub luminance: f32,
    /// Samples accumulated in the pixel.
    pub samples: u32,
    /// Relative standard error of the luminance (None while unlit or before two samples).
    pub relative_error: Option<f64>,
}

/// The values of `pixel` in `snap` (None outside it).
pub fn pixel_values(snap: &Snapshot, pixel: UVec2) -> Option<PixelValues> {
    if pixel.x >= snap.width || pixel.y >= snap.height {
        return None;
    }
    let i = (pixel.y * snap.width + pixel.x) as usize;
    let rgb = *snap.mean.get(i)?;
    Some(PixelValues {
        pixel,
        rgb,
        luminance: luminance(rgb),
        // Every pixel of a pass gets the same samples; per-pixel counts would go here.
        samples: snap.spp,
        relative_error: if snap.spp >= 2 { snap.pixel_relative_error(i) } else { None },
    })
}

/// Probes pinned to image positions, kept as positions in [0, 1]^2 so that they stay on
/// the same spot when the image is resized or shown at the preview's lower resolution.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Probes {
    positions: Vec<Vec2>,
}

impl Probes {
    /// Pins a probe at the centre of the pixel under `uv` in a `width` x `height` image;
    /// false (nothing added) outside the image or where a probe already marks that pixel.
    pub fn add(&mut self, uv: Vec2, width: u32, height: u32) -> bool {
        let Some(pixel) = pixel_at(uv, width, height) else { return false };
        if self.positions.iter().any(|&p| pixel_at(p, width, height) == Some(pixel)) {
            return false;
        }
        let size = Vec2::new(width as f32, height as f32);
        self.positions.push((pixel.as_vec2() + 0.5) / size);
        true
    }

    /// Removes probe `index` (nothing if there is none).
    pub fn remove(&mut self, index: usize) {
        if index < self.positions.len() {
            self.positions.remove(index);
        }
    }

    /// Removes every probe.
    pub fn clear(&mut self) {
        self.positions.clear();
    }

    /// The probes' positions in [0, 1]^2, in the order they were pinned.
    pub fn positions(&self) -> &[Vec2] {
        &self.positions
    }

    /// Each probe's values in `snap`, in order.
    pub fn values(&self, snap: &Snapshot) -> Vec<Option<PixelValues>> {
        self.positions
            .iter()
            .map(|&uv| pixel_at(uv, snap.width, snap.height).and_then(|p| pixel_values(snap, p)))
            .collect()
    }
}

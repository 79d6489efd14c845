//! Contributions that land on any pixel: bidirectional path tracing's light-tracing
//! strategy (t = 1) finds the pixel a connection passes through, wherever its sample was
//! taken. They are summed per pixel in 64-bit fixed point by atomic adds, which are exact,
//! so the sums (and the image) are the same whatever the thread count and the order.

use super::accum::FRACTION_BITS as FILM_FRACTION_BITS;
use crate::spectrum::Spectrum;
use glam::Vec2;
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};

/// Fractional bits of the fixed-point sums: 2^-24 resolution, sums up to 5.5e11.
const FRACTION_BITS: u32 = 24;

/// Largest magnitude one contribution may add (larger ones are clamped), so that 2^16 of
/// them at the largest cannot overflow a sum.
const MAX_VALUE: f64 = (1u64 << 22) as f64;

/// Per-pixel sums of splatted radiance over a `width` x `height` frame.
#[derive(Debug)]
pub struct Splats {
    width: u32,
    height: u32,
    sums: Vec<[AtomicI64; 3]>,
    rejected: AtomicU64,
}

impl Splats {
    /// Empty sums for a `width` x `height` frame.
    pub fn new(width: u32, height: u32) -> Self {
        let sums = (0..width as usize * height as usize).map(|_| Default::default()).collect();
        Self { width, height, sums, rejected: AtomicU64::new(0) }
    }

    /// Adds `value` to the pixel containing film position `at` (pixels); positions off the
    /// frame add nothing, and NaN or infinite values are counted and dropped.
    pub fn add(&self, at: Vec2, value: Spectrum) {
        let rgb = value.to_rgb();
        if !rgb.is_finite() {
            self.rejected.fetch_add(1, Ordering::Relaxed);
            return;
        }
        let (x, y) = (at.x.floor(), at.y.floor());
        if !(x >= 0.0 && y >= 0.0 && x < self.width as f32 && y < self.height as f32) {
            return;
        }
        let pixel = &self.sums[y as usize * self.width as usize + x as usize];
        for (sum, v) in pixel.iter().zip(rgb.to_array()) {
            let fixed = ((v as f64).clamp(-MAX_VALUE, MAX_VALUE) * (1u64 << FRACTION_BITS) as f64).round() as i64;
            if fixed != 0 {
                sum.fetch_add(fixed, Ordering::Relaxed);
            }
        }
    }

    /// Pixel `i`'s sums (row-major) in the film's fixed point (`accum::FRACTION_BITS`),
    /// exactly: a splat is one sample's share of the pixel, added to its samples' sum.
    pub fn film_sums(&self, i: usize) -> [i128; 3] {
        self.sums[i].each_ref().map(|s| (s.load(Ordering::Relaxed) as i128) << (FILM_FRACTION_BITS - FRACTION_BITS))
    }

    /// Contributions dropped for being NaN or infinite.
    pub fn rejected(&self) -> u64 {
        self.rejected.load(Ordering::Relaxed)
    }

    /// The memory the sums of a `width` x `height` frame take.
    pub fn bytes(width: u32, height: u32) -> u64 {
        width as u64 * height as u64 * std::mem::size_of::<[AtomicI64; 3]>() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_are_exact_in_any_order_and_land_on_their_pixel() {
        let values: Vec<f32> = (0..1000).map(|i| ((i * 7919) % 1000) as f32 * 1e-3 + 1e-7).collect();
        let (a, b) = (Splats::new(4, 3), Splats::new(4, 3));
        for v in &values {
            a.add(Vec2::new(2.5, 1.2), Spectrum::splat(*v));
        }
        for v in values.iter().rev() {
            b.add(Vec2::new(2.9, 1.99), Spectrum::splat(*v));
        }
        let image = |s: &Splats| (0..12).map(|i| s.film_sums(i)).collect::<Vec<_>>();
        let (ia, ib) = (image(&a), image(&b));
        assert_eq!(ia, ib, "the same sums in either order");
        assert!(ia[4 + 2][0] > 0 && ia.iter().filter(|p| p[0] != 0).count() == 1);
        a.add(Vec2::new(-0.5, 1.0), Spectrum::ONE);
        a.add(Vec2::new(4.0, 1.0), Spectrum::ONE);
        assert_eq!(image(&a), ia, "off the frame: nothing");
        a.add(Vec2::new(0.5, 0.5), Spectrum::splat(f32::NAN));
        assert_eq!(a.rejected(), 1);
    }
}

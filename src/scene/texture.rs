//! Texture images (8- or 16-bit RGBA) and their samplers: wrap modes, nearest or bilinear
//! lookup.

use crate::math::wrap_index;
use glam::{Vec2, Vec4};

/// An RGBA image as decoded from the file.
pub struct Image {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Row-major texels, top row first.
    pub texels: Texels,
}

/// Texel storage: 8 bits per channel, or 16 for images that have 16 (PNGs of bit depth 16).
#[derive(Clone, Debug, PartialEq)]
pub enum Texels {
    /// 8-bit codes.
    Bytes(Vec<[u8; 4]>),
    /// 16-bit codes.
    Words(Vec<[u16; 4]>),
}

/// How coordinates outside [0, 1] map back into the image (glTF sampler wrap modes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// Tile the image.
    Repeat,
    /// Tile, mirroring every other copy.
    MirroredRepeat,
    /// Clamp to the edge texel.
    ClampToEdge,
}

/// A glTF texture: an image plus its sampler.
#[derive(Clone, Debug)]
pub struct Texture {
    /// Name for the user: the texture's, its image's, or its image file's.
    pub name: String,
    /// Index into the scene's images.
    pub image: u32,
    /// Wrap along u and v.
    pub wrap: [Wrap; 2],
    /// Nearest-texel lookup instead of bilinear.
    pub nearest: bool,
}

/// Colour space of the values a texture slot holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorSpace {
    /// sRGB-encoded colour (baseColor, emissive): decoded to linear on lookup.
    Srgb,
    /// Linear data (metallic-roughness).
    Linear,
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1), for 8-bit codes.
fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// Decoding tables from 8-bit codes to linear values.
struct Lut {
    srgb: [f32; 256],
}

static LUT: std::sync::LazyLock<Lut> =
    std::sync::LazyLock::new(|| Lut { srgb: std::array::from_fn(|i| srgb_to_linear(i as u8)) });

/// The same for 16-bit codes (256 KiB, built the first time a 16-bit image is read).
static LUT16: std::sync::LazyLock<Vec<f32>> = std::sync::LazyLock::new(|| {
    (0..=u16::MAX)
        .map(|c| {
            let c = f32::from(c) / 65535.0;
            if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
        })
        .collect()
});

impl Image {
    fn texel(&self, x: i64, y: i64, space: ColorSpace) -> Vec4 {
        let i = (y as usize) * self.width as usize + x as usize;
        match &self.texels {
            Texels::Bytes(texels) => {
                let t = texels[i];
                let lin = |c: u8| match space {
                    ColorSpace::Srgb => LUT.srgb[c as usize],
                    ColorSpace::Linear => c as f32 / 255.0,
                };
                Vec4::new(lin(t[0]), lin(t[1]), lin(t[2]), t[3] as f32 / 255.0)
            }
            Texels::Words(texels) => {
                let t = texels[i];
                let lin = |c: u16| match space {
                    ColorSpace::Srgb => LUT16[c as usize],
                    ColorSpace::Linear => f32::from(c) / 65535.0,
                };
                Vec4::new(lin(t[0]), lin(t[1]), lin(t[2]), f32::from(t[3]) / 65535.0)
            }
        }
    }

    /// Mean linear colour of the image, used to estimate emitted power.
    pub fn mean(&self, space: ColorSpace) -> Vec4 {
        let sum = (0..self.height as i64)
            .flat_map(|y| (0..self.width as i64).map(move |x| (x, y)))
            .fold(Vec4::ZERO, |acc, (x, y)| acc + self.texel(x, y, space));
        sum / (self.width as f32 * self.height as f32).max(1.0)
    }
}

fn wrap(i: i64, n: i64, mode: Wrap) -> i64 {
    match mode {
        Wrap::Repeat => wrap_index(i, n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let m = wrap_index(i, 2 * n);
            if m < n { m } else { 2 * n - 1 - m }
        }
    }
}

impl Texture {
    /// Filtered lookup at `uv` (glTF convention: v grows downwards from the top row).
    pub fn sample(&self, images: &[Image], uv: Vec2, space: ColorSpace) -> Vec4 {
        let img = &images[self.image as usize];
        let (w, h) = (img.width as i64, img.height as i64);
        let x = uv.x * w as f32 - 0.5;
        let y = uv.y * h as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return img.texel(0, 0, space);
        }
        let fetch = |xi: i64, yi: i64| img.texel(wrap(xi, w, self.wrap[0]), wrap(yi, h, self.wrap[1]), space);
        if self.nearest {
            return fetch((x + 0.5).floor() as i64, (y + 0.5).floor() as i64);
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = fetch(x0, y0).lerp(fetch(x0 + 1, y0), fx);
        let bottom = fetch(x0, y0 + 1).lerp(fetch(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> Vec<Image> {
        let texels = vec![[0, 0, 0, 255], [255, 255, 255, 255], [255, 255, 255, 255], [0, 0, 0, 255]];
        vec![Image { width: 2, height: 2, texels: Texels::Bytes(texels) }]
    }

    #[test]
    fn wrap_modes_map_outside_coordinates_back() {
        assert_eq!(wrap(-1, 4, Wrap::Repeat), 3);
        assert_eq!(wrap(-1, 4, Wrap::MirroredRepeat), 0);
        assert_eq!(wrap(5, 4, Wrap::MirroredRepeat), 2);
        assert_eq!(wrap(9, 4, Wrap::ClampToEdge), 3);
    }

    #[test]
    fn bilinear_hits_texel_centres_and_blends_between_them() {
        let images = checker();
        let t = Texture { name: "t".into(), image: 0, wrap: [Wrap::Repeat; 2], nearest: false };
        assert_eq!(t.sample(&images, Vec2::new(0.25, 0.25), ColorSpace::Linear).x, 0.0);
        assert_eq!(t.sample(&images, Vec2::new(0.75, 0.25), ColorSpace::Linear).x, 1.0);
        assert!((t.sample(&images, Vec2::new(0.5, 0.25), ColorSpace::Linear).x - 0.5).abs() < 1e-6);
        let srgb_mid = t.sample(&images, Vec2::new(0.75, 0.25), ColorSpace::Srgb).x;
        assert_eq!(srgb_mid, 1.0);
        assert!((srgb_to_linear(128) - 0.2158605).abs() < 1e-5);
    }
}

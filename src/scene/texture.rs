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
        let [t] = self.decode([y as usize * self.width as usize + x as usize], space);
        t
    }

    /// The four texels at (xs[0], ys[0]), (xs[1], ys[0]), (xs[0], ys[1]) and (xs[1], ys[1]).
    fn quad(&self, xs: [usize; 2], ys: [usize; 2], space: ColorSpace) -> [Vec4; 4] {
        let w = self.width as usize;
        self.decode([ys[0] * w + xs[0], ys[0] * w + xs[1], ys[1] * w + xs[0], ys[1] * w + xs[1]], space)
    }

    /// The texels at row-major indices `at`, decoded to linear values with one dispatch on
    /// the storage and colour space for all of them: a bilinear lookup's four once, not one
    /// per texel and a look at the decoding table's lazy cell per channel.
    fn decode<const N: usize>(&self, at: [usize; N], space: ColorSpace) -> [Vec4; N] {
        fn each<T: Copy, const N: usize>(
            texels: &[[T; 4]],
            at: [usize; N],
            lin: impl Fn(T) -> f32,
            alpha: impl Fn(T) -> f32,
        ) -> [Vec4; N] {
            at.map(|i| {
                let t = texels[i];
                Vec4::new(lin(t[0]), lin(t[1]), lin(t[2]), alpha(t[3]))
            })
        }
        match (&self.texels, space) {
            (Texels::Bytes(t), ColorSpace::Srgb) => {
                let lut = &LUT.srgb;
                each(t, at, |c| lut[c as usize], |c| c as f32 / 255.0)
            }
            (Texels::Bytes(t), ColorSpace::Linear) => each(t, at, |c| c as f32 / 255.0, |c| c as f32 / 255.0),
            (Texels::Words(t), ColorSpace::Srgb) => {
                let lut = &**LUT16;
                each(t, at, |c| lut[c as usize], |c| f32::from(c) / 65535.0)
            }
            (Texels::Words(t), ColorSpace::Linear) => {
                each(t, at, |c| f32::from(c) / 65535.0, |c| f32::from(c) / 65535.0)
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
        if self.nearest {
            let (xi, yi) = ((x + 0.5).floor() as i64, (y + 0.5).floor() as i64);
            return img.texel(wrap(xi, w, self.wrap[0]), wrap(yi, h, self.wrap[1]), space);
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let xs = [x0, x0 + 1].map(|xi| wrap(xi, w, self.wrap[0]) as usize);
        let ys = [y0, y0 + 1].map(|yi| wrap(yi, h, self.wrap[1]) as usize);
        let [t00, t10, t01, t11] = img.quad(xs, ys, space);
        let top = t00.lerp(t10, fx);
        let bottom = t01.lerp(t11, fx);
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
    fn a_bilinear_lookup_blends_the_four_texels_each_read_alone() {
        let (w, h) = (5u32, 3u32);
        let mut bits = 0x2545_f491u32;
        let mut next = move || {
            bits ^= bits << 13;
            bits ^= bits >> 17;
            bits ^= bits << 5;
            bits
        };
        let bytes: Vec<[u8; 4]> = (0..w * h).map(|_| next().to_le_bytes()).collect();
        let words: Vec<[u16; 4]> =
            (0..w * h).map(|_| [next() as u16, next() as u16, next() as u16, next() as u16]).collect();
        let images = [
            Image { width: w, height: h, texels: Texels::Bytes(bytes) },
            Image { width: w, height: h, texels: Texels::Words(words) },
        ];
        let modes = [Wrap::Repeat, Wrap::MirroredRepeat, Wrap::ClampToEdge];
        for (image, img) in images.iter().enumerate() {
            for (wrap_u, wrap_v) in modes.iter().flat_map(|&a| modes.map(|b| (a, b))) {
                let t = Texture { name: "t".into(), image: image as u32, wrap: [wrap_u, wrap_v], nearest: false };
                for space in [ColorSpace::Srgb, ColorSpace::Linear] {
                    for _ in 0..200 {
                        let uv =
                            Vec2::new(next() as f32 / u32::MAX as f32, next() as f32 / u32::MAX as f32) * 3.0 - 1.0;
                        let (x, y) = (uv.x * w as f32 - 0.5, uv.y * h as f32 - 0.5);
                        let (x0, y0) = (x.floor(), y.floor());
                        let at = |dx: i64, dy: i64| {
                            let xi = wrap(x0 as i64 + dx, w as i64, wrap_u);
                            img.texel(xi, wrap(y0 as i64 + dy, h as i64, wrap_v), space)
                        };
                        let top = at(0, 0).lerp(at(1, 0), x - x0);
                        let want = top.lerp(at(0, 1).lerp(at(1, 1), x - x0), y - y0);
                        assert_eq!(t.sample(&images, uv, space), want, "image {image}, {wrap_u:?} {wrap_v:?}, {uv}");
                    }
                }
            }
        }
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

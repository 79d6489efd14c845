//! Accumulation buffer: per-pixel sums of radiance in 128-bit fixed point (exact, so any
//! order of additions, and any split of a render into pieces merged later, gives the same
//! bits) and f64 sums of its square, owned by tiles so that workers add samples without
//! locks; NaN or infinite samples are dropped and counted. Asked for, the tiles also sum the
//! denoiser's albedo and normal per pixel (f64, added in sample order as the radiance is).
//! With a noise threshold, tiles also keep what the pixels' error estimates need
//! (`super::adaptive`) and which pixels still take samples.

use super::splat::Splats;
use super::window::Window;
use crate::spectrum::Spectrum;
use glam::{DVec3, UVec2, Vec3};

/// Side of a square tile in pixels.
pub const TILE_SIZE: u32 = 16;

/// Fraction bits of the fixed-point sums: a resolution of 2^-50 (8.9e-16).
pub(super) const FRACTION_BITS: u32 = 50;

/// Largest sample magnitude kept (larger ones are clamped to it): 2^46 (7.0e13), so that
/// 2^30 samples of it still fit in an i128 at 2^50.
const MAX_SAMPLE: f64 = (1u64 << 46) as f64;

/// A channel value in fixed point, rounded half away from zero. Values below 2^13 in
/// magnitude (nearly all radiance) take a 64-bit conversion, inline, cheaper than the
/// 128-bit one.
#[inline]
fn to_fixed(v: f64) -> i128 {
    let y = v * (1u64 << FRACTION_BITS) as f64;
    if y.abs() < (1u64 << 62) as f64 {
        (y + 0.5f64.copysign(y)) as i64 as i128
    } else {
        (v.clamp(-MAX_SAMPLE, MAX_SAMPLE) * (1u64 << FRACTION_BITS) as f64).round() as i128
    }
}

/// A fixed-point sum as f64, from its high and low parts: correctly rounded below 2^85
/// (sums below 2^35), and always the same function of the sum, which is what merging needs.
/// (The compiler's own 128-bit conversion routine is slower.)
#[inline]
fn from_fixed(v: i128) -> f64 {
    let (high, low) = ((v >> 32) as i64, (v & 0xffff_ffff) as u32);
    (high as f64 * 4_294_967_296.0 + low as f64) / (1u64 << FRACTION_BITS) as f64
}

/// Running sums of one pixel's samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSums {
    /// Sum of radiance samples, per channel, in fixed point (see `FRACTION_BITS`).
    pub sum: [i128; 3],
    /// Sum of squared radiance samples (per channel), for variance estimates.
    pub sum_sq: DVec3,
    /// Number of samples added.
    pub count: u64,
}

impl PixelSums {
    /// Sum of the radiance samples.
    pub fn total(&self) -> DVec3 {
        DVec3::new(from_fixed(self.sum[0]), from_fixed(self.sum[1]), from_fixed(self.sum[2]))
    }

    /// Mean radiance so far (zero before the first sample).
    pub fn mean(&self) -> DVec3 {
        if self.count == 0 { DVec3::ZERO } else { self.total() / self.count as f64 }
    }

    /// Adds fixed-point `sums` (splatted contributions) to the sum of the samples.
    fn add_to_sum(&mut self, sums: [i128; 3]) {
        for (s, v) in self.sum.iter_mut().zip(sums) {
            *s += v;
        }
    }

    /// Adds another pixel's sums (a piece of the same pixel's samples).
    pub fn merge(&mut self, other: &PixelSums) {
        for c in 0..3 {
            self.sum[c] += other.sum[c];
        }
        self.sum_sq += other.sum_sq;
        self.count += other.count;
    }

    /// Estimated variance of the mean (sample variance / n), per channel.
    pub fn variance_of_mean(&self) -> DVec3 {
        if self.count < 2 {
            return DVec3::ZERO;
        }
        let n = self.count as f64;
        let sum = self.total();
        let var = (self.sum_sq - sum * sum / n) / (n - 1.0);
        var.max(DVec3::ZERO) / n
    }
}

/// Running sums of one pixel's albedo and normal samples (the denoiser's AOVs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AovSums {
    /// Sum of albedo samples.
    pub albedo: DVec3,
    /// Sum of normal samples.
    pub normal: DVec3,
    /// Number of samples added.
    pub count: u64,
}

/// Per-pixel means of the denoiser's auxiliary images, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct AovImages {
    /// Mean albedo (linear RGB in [0, 1]).
    pub albedo: Vec<Vec3>,
    /// Mean world-space shading normal (not renormalised: shorter where normals differ).
    pub normal: Vec<Vec3>,
}

/// What a pixel's error estimate needs beyond its `PixelSums`: the sums of its first
/// replicate (the samples of even index, see `Sampler::replicated`) and the sum of squared
/// luminance (for the variance of luminance, covariance between channels included).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorSums {
    /// Sum of the samples of even index, per channel.
    pub half: DVec3,
    /// Number of samples of even index added.
    pub half_count: u64,
    /// Sum of the squared luminance of every sample added.
    pub luminance_sq: f64,
}

/// A rectangle of pixels and their sums, owned by one worker at a time.
#[derive(Clone, Debug)]
pub struct Tile {
    /// Top-left pixel.
    pub origin: UVec2,
    /// Width and height in pixels.
    pub size: UVec2,
    /// Row-major sums.
    pub pixels: Vec<PixelSums>,
    /// Row-major AOV sums; empty unless the film records AOVs (`Film::record_aovs`).
    pub aovs: Vec<AovSums>,
    /// Samples dropped for being NaN or infinite.
    pub rejected: u64,
    /// Row-major error sums, kept with a noise threshold (empty otherwise).
    pub errors: Vec<ErrorSums>,
    /// Row-major: the sample count at which the noise threshold stopped each pixel, 0
    /// while it takes samples (empty without a threshold).
    pub stopped_at: Vec<u32>,
}

impl Tile {
    /// Adds one sample to the pixel at `local` (tile coordinates); drops it if not finite.
    pub fn add(&mut self, local: UVec2, radiance: Spectrum) {
        if !radiance.is_finite() {
            self.rejected += 1;
            return;
        }
        let r = radiance.to_rgb().as_dvec3();
        let px = &mut self.pixels[(local.y * self.size.x + local.x) as usize];
        for c in 0..3 {
            px.sum[c] += to_fixed(r[c]);
        }
        px.sum_sq += r * r;
        px.count += 1;
    }

    /// Adds one sample's albedo and normal to the pixel at `local`, if the film records
    /// AOVs; drops them if not finite.
    pub fn add_aov(&mut self, local: UVec2, albedo: Vec3, normal: Vec3) {
        let i = (local.y * self.size.x + local.x) as usize;
        if let Some(px) = self.aovs.get_mut(i)
            && albedo.is_finite()
            && normal.is_finite()
        {
            px.albedo += albedo.as_dvec3();
            px.normal += normal.as_dvec3();
            px.count += 1;
        }
    }

    /// Adds sample `index` of the pixel at `local` to its error sums (kept with a noise
    /// threshold; call it beside `add`, which drops the same non-finite samples).
    pub fn add_error(&mut self, local: UVec2, index: u64, radiance: Spectrum) {
        if !radiance.is_finite() {
            return;
        }
        let r = radiance.to_rgb().as_dvec3();
        let e = &mut self.errors[(local.y * self.size.x + local.x) as usize];
        if index.is_multiple_of(2) {
            e.half += r;
            e.half_count += 1;
        }
        e.luminance_sq += super::adaptive::luminance(r).powi(2);
    }

    /// Whether the pixel at `local` still takes samples.
    pub fn active(&self, local: UVec2) -> bool {
        self.stopped_at.get((local.y * self.size.x + local.x) as usize).is_none_or(|&n| n == 0)
    }
}

/// The accumulation buffer of a window of the frame.
#[derive(Clone, Debug)]
pub struct Film {
    /// The frame's pixels this film covers (tile origins are frame coordinates).
    pub window: Window,
    /// Width in pixels (the window's).
    pub width: u32,
    /// Height in pixels (the window's).
    pub height: u32,
    /// Tiles covering the image, row-major.
    pub tiles: Vec<Tile>,
}

impl Film {
    /// An empty `width` x `height` film split into tiles of `TILE_SIZE`.
    pub fn new(width: u32, height: u32) -> Self {
        Self::window(Window::full(width, height))
    }

    /// An empty film of the frame's `window`, split into tiles of `TILE_SIZE`.
    pub fn window(window: Window) -> Self {
        let (width, height) = (window.width(), window.height());
        let mut tiles = Vec::new();
        for y0 in (0..height).step_by(TILE_SIZE as usize) {
            for x0 in (0..width).step_by(TILE_SIZE as usize) {
                let size = UVec2::new(TILE_SIZE.min(width - x0), TILE_SIZE.min(height - y0));
                let pixels = vec![PixelSums::default(); (size.x * size.y) as usize];
                let origin = UVec2::new(window.x0 + x0, window.y0 + y0);
                tiles.push(Tile {
                    origin,
                    size,
                    pixels,
                    aovs: Vec::new(),
                    rejected: 0,
                    errors: Vec::new(),
                    stopped_at: Vec::new(),
                });
            }
        }
        Self { window, width, height, tiles }
    }

    /// The film with what a noise threshold needs: every pixel taking samples, and error sums.
    pub fn with_threshold(mut self) -> Self {
        for tile in &mut self.tiles {
            tile.errors = vec![ErrorSums::default(); tile.pixels.len()];
            tile.stopped_at = vec![0; tile.pixels.len()];
        }
        self
    }

    /// Bytes `Film::new(width, height)` allocates at most: pixel sums and tiles (listed with slack).
    pub fn bytes(width: u32, height: u32) -> u64 {
        let pixels = width as u64 * height as u64;
        let tiles = width.div_ceil(TILE_SIZE) as u64 * height.div_ceil(TILE_SIZE) as u64;
        pixels * std::mem::size_of::<PixelSums>() as u64 + 2 * tiles * std::mem::size_of::<Tile>() as u64
    }

    /// Bytes `record_aovs` adds to a `width` x `height` film.
    pub fn aov_bytes(width: u32, height: u32) -> u64 {
        width as u64 * height as u64 * std::mem::size_of::<AovSums>() as u64
    }

    /// Makes the tiles sum the denoiser's albedo and normal too, from the next sample on.
    pub fn record_aovs(&mut self) {
        for tile in &mut self.tiles {
            tile.aovs.resize(tile.pixels.len(), AovSums::default());
        }
    }

    /// Mean albedo and normal images, if the film records AOVs.
    pub fn aov_images(&self) -> Option<AovImages> {
        if self.tiles.iter().any(|t| t.aovs.is_empty()) {
            return None;
        }
        let n = (self.width * self.height) as usize;
        let mut images = AovImages { albedo: vec![Vec3::ZERO; n], normal: vec![Vec3::ZERO; n] };
        for tile in &self.tiles {
            let (x0, y0) = (tile.origin.x - self.window.x0, tile.origin.y - self.window.y0);
            for (i, px) in tile.aovs.iter().enumerate() {
                let at = ((y0 + i as u32 / tile.size.x) * self.width + x0 + i as u32 % tile.size.x) as usize;
                if px.count > 0 {
                    images.albedo[at] = (px.albedo / px.count as f64).as_vec3();
                    images.normal[at] = (px.normal / px.count as f64).as_vec3();
                }
            }
        }
        Some(images)
    }

    /// Bytes `with_threshold` adds to a `width` x `height` film.
    pub fn threshold_bytes(width: u32, height: u32) -> u64 {
        width as u64 * height as u64 * (std::mem::size_of::<ErrorSums>() + std::mem::size_of::<u32>()) as u64
    }

    /// Row-major index in the film of pixel `i` of `tile`.
    fn index(&self, tile: &Tile, i: usize) -> usize {
        let (x0, y0) = (tile.origin.x - self.window.x0, tile.origin.y - self.window.y0);
        let (x, y) = (x0 + i as u32 % tile.size.x, y0 + i as u32 / tile.size.x);
        (y * self.width + x) as usize
    }

    /// Row-major image of `value(tile, i)` per pixel.
    fn image<T: Clone + Default>(&self, value: impl Fn(&Tile, usize) -> T) -> Vec<T> {
        let mut img = vec![T::default(); (self.width * self.height) as usize];
        for tile in &self.tiles {
            for i in 0..tile.pixels.len() {
                img[self.index(tile, i)] = value(tile, i);
            }
        }
        img
    }

    /// Row-major image of per-pixel means, with `splats` (of a whole-frame film) added to
    /// each pixel's sum before it is divided, as `add_splats` and `lucent merge` add them.
    pub fn mean_image(&self, splats: Option<&Splats>) -> Vec<Vec3> {
        self.image(|t, i| {
            let mut p = t.pixels[i];
            if let Some(s) = splats {
                p.add_to_sum(s.film_sums(self.index(t, i)));
            }
            p.mean().as_vec3()
        })
    }

    /// Adds `splats` (of a whole-frame film) to each pixel's sum, so that the film's sums
    /// are the image's, as a piece holds them.
    pub fn add_splats(&mut self, splats: &Splats) {
        debug_assert_eq!(self.window, Window::full(self.width, self.height));
        let width = self.width;
        for tile in &mut self.tiles {
            for (i, p) in tile.pixels.iter_mut().enumerate() {
                let (x, y) = (tile.origin.x + i as u32 % tile.size.x, tile.origin.y + i as u32 / tile.size.x);
                p.add_to_sum(splats.film_sums((y * width + x) as usize));
            }
        }
    }

    /// Row-major images of the estimated variance of each pixel's mean, per channel and of
    /// its luminance: the sample variance over n, times the sampler's local gain over
    /// independent sampling where the film keeps error sums (`super::adaptive`). The
    /// luminance image is empty unless the film keeps error sums.
    pub fn variance_images(&self, replicates: bool) -> (Vec<Vec3>, Vec<f32>) {
        let pixels = (self.width * self.height) as usize;
        let kept = self.tiles.iter().any(|t| !t.errors.is_empty());
        let (mut channels, mut luminance) = (vec![Vec3::ZERO; pixels], vec![0.0; if kept { pixels } else { 0 }]);
        for tile in &self.tiles {
            let gains = if kept { super::adaptive::gains(tile, replicates) } else { vec![1.0; tile.pixels.len()] };
            let variances = if kept { super::adaptive::luminance_variances(tile, &gains) } else { Vec::new() };
            for (i, px) in tile.pixels.iter().enumerate() {
                let at = self.index(tile, i);
                channels[at] = super::adaptive::channel_variance(px, gains[i]).as_vec3();
                if kept {
                    luminance[at] = variances[i] as f32;
                }
            }
        }
        (channels, luminance)
    }

    /// Row-major image of the samples each pixel took: where the noise threshold stopped
    /// it, or `spp` while it takes samples; empty without a threshold.
    pub fn spp_image(&self, spp: u32) -> Vec<u32> {
        if self.tiles.iter().all(|t| t.stopped_at.is_empty()) {
            return Vec::new();
        }
        self.image(|t, i| if t.stopped_at[i] == 0 { spp } else { t.stopped_at[i] })
    }

    /// Pixels still taking samples.
    pub fn active_pixels(&self) -> u64 {
        self.tiles.iter().map(|t| t.stopped_at.iter().filter(|&&n| n == 0).count() as u64).sum::<u64>()
            + self.tiles.iter().filter(|t| t.stopped_at.is_empty()).map(|t| t.pixels.len() as u64).sum::<u64>()
    }

    /// Samples dropped for being NaN or infinite.
    pub fn rejected(&self) -> u64 {
        self.tiles.iter().map(|t| t.rejected).sum()
    }

    /// Every pixel's sums in row-major order, as runs of one tile's row.
    pub fn row_segments(&self) -> impl Iterator<Item = &[PixelSums]> {
        let across = self.width.div_ceil(TILE_SIZE) as usize;
        self.tiles.chunks(across.max(1)).flat_map(|band| {
            (0..band[0].size.y as usize).flat_map(move |ly| {
                band.iter().map(move |t| &t.pixels[ly * t.size.x as usize..(ly + 1) * t.size.x as usize])
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_every_pixel_once() {
        let film = Film::new(37, 20);
        let covered: u32 = film.tiles.iter().map(|t| t.size.x * t.size.y).sum();
        assert_eq!(covered, 37 * 20);
        assert_eq!(film.mean_image(None).len(), 37 * 20);
        let mut film = Film::window(Window { x0: 3, y0: 5, x1: 40, y1: 25 });
        for tile in &mut film.tiles {
            for (i, px) in tile.pixels.iter_mut().enumerate() {
                let (x, y) = (tile.origin.x + i as u32 % tile.size.x, tile.origin.y + i as u32 / tile.size.x);
                px.count = (y * 1000 + x) as u64;
            }
        }
        let order: Vec<u64> = film.row_segments().flatten().map(|p| p.count).collect();
        let expected: Vec<u64> = (5..25).flat_map(|y| (3..40).map(move |x| (y * 1000 + x) as u64)).collect();
        assert_eq!(order, expected, "frame coordinates, row-major");
    }

    #[test]
    fn non_finite_samples_are_counted_not_added() {
        let mut film = Film::new(4, 4);
        let tile = &mut film.tiles[0];
        tile.add(UVec2::new(1, 1), Spectrum::splat(2.0));
        tile.add(UVec2::new(1, 1), Spectrum::from_rgb(Vec3::new(f32::NAN, 0.0, 0.0)));
        tile.add(UVec2::new(1, 1), Spectrum::splat(f32::INFINITY));
        tile.add(UVec2::new(1, 1), Spectrum::splat(4.0));
        assert_eq!(film.rejected(), 2);
        assert_eq!(film.mean_image(None)[5], Vec3::splat(3.0));
        assert!((film.variance_images(false).0[5].x - 1.0).abs() < 1e-6, "s^2 = 2, n = 2");
    }

    #[test]
    fn aovs_are_summed_only_when_recorded_and_averaged_per_pixel() {
        let mut film = Film::window(Window { x0: 16, y0: 0, x1: 36, y1: 4 });
        film.tiles[1].add_aov(UVec2::new(1, 2), Vec3::ONE, Vec3::Z);
        assert_eq!(film.aov_images(), None, "not asked for: nothing kept");
        film.record_aovs();
        let tile = &mut film.tiles[1];
        tile.add_aov(UVec2::new(1, 2), Vec3::new(0.5, 0.25, 1.0), Vec3::Z);
        tile.add_aov(UVec2::new(1, 2), Vec3::new(0.25, 0.25, 0.0), Vec3::X);
        tile.add_aov(UVec2::new(1, 2), Vec3::splat(f32::NAN), Vec3::X);
        let images = film.aov_images().unwrap();
        let at = (2 * 20 + 16 + 1) as usize;
        assert_eq!(images.albedo[at], Vec3::new(0.375, 0.25, 0.5), "the NaN sample is dropped");
        assert_eq!(images.normal[at], Vec3::new(0.5, 0.0, 0.5));
        assert_eq!(images.albedo.iter().filter(|a| **a != Vec3::ZERO).count(), 1);
    }
}

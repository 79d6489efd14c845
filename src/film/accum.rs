//! Accumulation buffer: per-pixel f64 sums of radiance and its square, owned by tiles so
//! that workers add samples without locks; NaN or infinite samples are dropped and counted.

use crate::spectrum::Spectrum;
use glam::{DVec3, UVec2, Vec3};

/// Side of a square tile in pixels.
pub const TILE_SIZE: u32 = 16;

/// Running sums of one pixel's samples.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelSums {
    /// Sum of radiance samples.
    pub sum: DVec3,
    /// Sum of squared radiance samples (per channel), for variance estimates.
    pub sum_sq: DVec3,
    /// Number of samples added.
    pub count: u64,
}

impl PixelSums {
    /// Mean radiance so far (zero before the first sample).
    pub fn mean(&self) -> DVec3 {
        if self.count == 0 { DVec3::ZERO } else { self.sum / self.count as f64 }
    }

    /// Estimated variance of the mean (sample variance / n), per channel.
    pub fn variance_of_mean(&self) -> DVec3 {
        if self.count < 2 {
            return DVec3::ZERO;
        }
        let n = self.count as f64;
        let var = (self.sum_sq - self.sum * self.sum / n) / (n - 1.0);
        var.max(DVec3::ZERO) / n
    }
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
    /// Samples dropped for being NaN or infinite.
    pub rejected: u64,
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
        px.sum += r;
        px.sum_sq += r * r;
        px.count += 1;
    }
}

/// The whole accumulation buffer.
#[derive(Clone, Debug)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Tiles covering the image, row-major.
    pub tiles: Vec<Tile>,
}

impl Film {
    /// An empty film split into tiles of `TILE_SIZE`.
    pub fn new(width: u32, height: u32) -> Self {
        let mut tiles = Vec::new();
        for y0 in (0..height).step_by(TILE_SIZE as usize) {
            for x0 in (0..width).step_by(TILE_SIZE as usize) {
                let size = UVec2::new(TILE_SIZE.min(width - x0), TILE_SIZE.min(height - y0));
                let pixels = vec![PixelSums::default(); (size.x * size.y) as usize];
                tiles.push(Tile { origin: UVec2::new(x0, y0), size, pixels, rejected: 0 });
            }
        }
        Self { width, height, tiles }
    }

    /// Bytes `Film::new(width, height)` allocates at most: pixel sums and tiles (listed with slack).
    pub fn bytes(width: u32, height: u32) -> u64 {
        let pixels = width as u64 * height as u64;
        let tiles = width.div_ceil(TILE_SIZE) as u64 * height.div_ceil(TILE_SIZE) as u64;
        pixels * std::mem::size_of::<PixelSums>() as u64 + 2 * tiles * std::mem::size_of::<Tile>() as u64
    }

    /// Applies `f(x, y, sums)` to every pixel.
    fn for_each_pixel(&self, mut f: impl FnMut(u32, u32, &PixelSums)) {
        for tile in &self.tiles {
            for (i, px) in tile.pixels.iter().enumerate() {
                let (lx, ly) = (i as u32 % tile.size.x, i as u32 / tile.size.x);
                f(tile.origin.x + lx, tile.origin.y + ly, px);
            }
        }
    }

    /// Row-major image of per-pixel means.
    pub fn mean_image(&self) -> Vec<Vec3> {
        let mut img = vec![Vec3::ZERO; (self.width * self.height) as usize];
        self.for_each_pixel(|x, y, p| img[(y * self.width + x) as usize] = p.mean().as_vec3());
        img
    }

    /// Row-major image of the estimated variance of each pixel's mean.
    pub fn variance_image(&self) -> Vec<Vec3> {
        let mut img = vec![Vec3::ZERO; (self.width * self.height) as usize];
        self.for_each_pixel(|x, y, p| img[(y * self.width + x) as usize] = p.variance_of_mean().as_vec3());
        img
    }

    /// Samples dropped for being NaN or infinite.
    pub fn rejected(&self) -> u64 {
        self.tiles.iter().map(|t| t.rejected).sum()
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
        assert_eq!(film.mean_image().len(), 37 * 20);
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
        assert_eq!(film.mean_image()[5], Vec3::splat(3.0));
        assert!((film.variance_image()[5].x - 1.0).abs() < 1e-6, "s^2 = 2, n = 2");
    }
}

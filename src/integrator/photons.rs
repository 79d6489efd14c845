//! Vertex merging's light vertices (Georgiev et al. 2012, "Light Transport Simulation with
//! Vertex Connection and Merging"; Hachisuka et al. 2012): every iteration first traces one
//! light subpath per pixel, keeps each of their vertices compactly (position, normal,
//! throughput and the densities multiple importance sampling needs) and finds, for a point,
//! the vertices within the merging radius through a hashed grid of cells twice the radius
//! wide (the 2x2x2 cells a sphere of that radius can touch). Paths are kept in pixel order
//! and every query visits its cells and their vertices in a fixed order, so the merged
//! sums, and the image, do not depend on the thread count.

use super::Context;
use super::bdpt::{PathVertex, Subpath, light_subpath};
use super::kernel::PathOutput;
use crate::math::sampler::{PixelSequence, hash3};
use crate::spectrum::{Spectrum, Wavelengths, sampled::Sampled};
use glam::{IVec3, UVec2, Vec3};
use rayon::prelude::*;

/// Seed offset of the light subpaths' random streams (apart from the camera paths').
const LIGHT_STREAM: u64 = 0x6c69_6768_7470_6174;

/// Seed offset of the iterations' wavelengths.
const WAVELENGTH_STREAM: u64 = 0x7761_7665_6c65_6e67;

/// A subpath vertex's densities per unit area (per solid angle for light at infinity), as
/// its subpath sampled it (`fwd`) and as the other direction would have (`rev`), with
/// whether a connection cannot end there (`delta`) and whether it can be merged at.
#[derive(Clone, Copy, Debug, Default)]
pub struct Densities {
    /// Forward density.
    pub fwd: f32,
    /// Reverse density.
    pub rev: f32,
    /// A delta lobe scattered the subpath here (or, for a connection's end, never).
    pub delta: bool,
    /// A surface vertex with a non-delta lobe.
    pub merge: bool,
}

/// A light subpath's vertex, as merging and its weights need it.
#[derive(Clone, Copy, Debug)]
pub struct LightVertex {
    /// Position (for the light of a light at infinity, the direction light leaves it in,
    /// negated, as `PathVertex` keeps it).
    pub p: Vec3,
    /// Geometric normal on the side the subpath arrived from (zero off surfaces).
    pub n: Vec3,
    /// Throughput from the light up to this vertex over its density (a photon's power,
    /// times the number of light paths).
    pub beta: Spectrum,
    /// The subpath's densities at this vertex, forwards and backwards.
    pub densities: Densities,
    /// A light at infinity (its `p` a direction).
    pub infinite: bool,
    /// A light whose position or direction is a delta (at the subpath's first vertex).
    pub delta_light: bool,
    /// Index of the vertex in its subpath (0: on the light).
    pub index: u32,
    /// Its subpath kept only its hero wavelength (it met a dispersive surface).
    pub hero_only: bool,
}

impl LightVertex {
    /// The most memory an iteration's light vertices and their grid take over a `width` x
    /// `height` frame with subpaths of up to `max_depth` bounces.
    pub fn bytes(width: u32, height: u32, max_depth: u32) -> u64 {
        let per_path = (max_depth as u64 + 1).min(super::bdpt::MAX_VERTICES as u64);
        // Each vertex, its grid index, and up to two bucket starts.
        width as u64 * height as u64 * per_path * (std::mem::size_of::<LightVertex>() as u64 + 12)
    }

    fn of(v: &PathVertex, index: usize, hero_only: bool) -> Self {
        LightVertex {
            p: v.p,
            n: v.n,
            beta: v.beta,
            densities: v.densities(),
            infinite: v.is_infinite(),
            delta_light: v.is_delta_light(),
            index: index as u32,
            hero_only,
        }
    }
}

/// One iteration's light vertices and the grid that finds them.
pub struct Photons {
    /// Every light subpath's vertices, path after path in pixel order.
    pub vertices: Vec<LightVertex>,
    /// The merging radius of this iteration.
    pub radius: f32,
    /// Vertex merging's density factor eta = N pi r^2 for N light paths (Georgiev et al.
    /// eq. 23): a merge's density against a connection's.
    pub eta: f32,
    grid: Grid,
}

impl Photons {
    /// The light subpaths of iteration (sample index) `index` over a `width` x `height` frame,
    /// one per pixel, with the radius of that iteration; the rays traced are added to `rays`.
    pub(crate) fn trace(cx: Context, (width, height): (u32, u32), index: u64, rays: &mut u64) -> Self {
        let settings = cx.settings;
        let max = (settings.max_depth as usize + 2).min(super::bdpt::MAX_VERTICES) - 1;
        let iteration = wavelengths(cx, index);
        let rows: Vec<(Vec<LightVertex>, u64)> = (0..height)
            .into_par_iter()
            .map(|y| {
                let (mut row, mut out) = (Vec::new(), PathOutput::default());
                let mut path = Subpath::new();
                for x in 0..width {
                    path.clear();
                    let mut sampler = light_sampler(cx, UVec2::new(x, y), index);
                    let mut wl = iteration;
                    light_subpath(cx, &mut sampler, max, &mut path, (&mut out, &mut wl));
                    let hero_only = wl.secondary_terminated();
                    row.extend(path.iter().enumerate().map(|(i, v)| LightVertex::of(v, i, hero_only)));
                }
                (row, out.rays as u64)
            })
            .collect();
        *rays += rows.iter().map(|r| r.1).sum::<u64>();
        let vertices: Vec<LightVertex> = rows.into_iter().flat_map(|r| r.0).collect();
        let radius = radius(cx, index);
        let eta = (width as f64 * height as f64 * std::f64::consts::PI * (radius as f64).powi(2)) as f32;
        let grid = Grid::build(&vertices, radius);
        Photons { vertices, radius, eta, grid }
    }

    /// Calls `found` with the index of every mergeable light vertex within the radius of
    /// `p`, in a fixed order.
    pub fn near(&self, p: Vec3, mut found: impl FnMut(usize)) {
        let r2 = self.radius * self.radius;
        self.grid.visit(p, self.radius, |i| {
            if (self.vertices[i].p - p).length_squared() < r2 {
                found(i);
            }
        });
    }
}

/// The random stream of pixel `pixel`'s light subpath at iteration `index`.
pub(crate) fn light_sampler(cx: Context, pixel: UVec2, index: u64) -> crate::math::sampler::Sampler {
    let s = cx.settings;
    PixelSequence::new(s.sampler, 1, pixel, s.seed ^ LIGHT_STREAM).sampler(index)
}

/// The wavelengths every path of iteration `index` carries, camera and light subpaths alike,
/// so that any camera vertex can merge with any light vertex (RGB where the kernel is).
pub(crate) fn wavelengths(cx: Context, index: u64) -> Wavelengths {
    if super::kernel::is_spectral(cx.scene, cx.settings) {
        let u = (hash3(index, cx.settings.seed, WAVELENGTH_STREAM) >> 40) as f32 / (1u64 << 24) as f32;
        Wavelengths::Sampled(Sampled::new(u))
    } else {
        Wavelengths::Rgb
    }
}

/// The merging radius at iteration (sample index) `index`: the setting's share of the
/// scene's radius, shrunk as (index + 1)^((alpha - 1) / 2) (Knaus and Zwicker 2011), which
/// keeps the estimate consistent for alpha < 1: its bias vanishes and its variance stays
/// bounded.
pub(crate) fn radius(cx: Context, index: u64) -> f32 {
    let r0 = cx.settings.vcm_radius * cx.scene.radius();
    r0 * ((index + 1) as f32).powf((cx.settings.vcm_alpha - 1.0) / 2.0)
}

/// A hashed grid of cells of twice the radius over the mergeable vertices (counting sort by
/// cell hash, so each bucket's vertices stay in path order).
struct Grid {
    cell: f32,
    origin: Vec3,
    /// Bucket b's vertex indices are `indices[starts[b]..starts[b + 1]]`.
    starts: Vec<u32>,
    indices: Vec<u32>,
}

impl Grid {
    fn build(vertices: &[LightVertex], radius: f32) -> Self {
        let mergeable: Vec<u32> =
            (0..vertices.len() as u32).filter(|&i| vertices[i as usize].densities.merge).collect();
        let origin = mergeable.iter().fold(Vec3::splat(f32::INFINITY), |m, &i| m.min(vertices[i as usize].p));
        let buckets = mergeable.len().next_power_of_two().max(1);
        let mut grid = Grid { cell: 2.0 * radius, origin, starts: vec![0; buckets + 1], indices: Vec::new() };
        let keys: Vec<usize> = mergeable.iter().map(|&i| grid.bucket(grid.cell_of(vertices[i as usize].p))).collect();
        for &k in &keys {
            grid.starts[k + 1] += 1;
        }
        for b in 0..buckets {
            grid.starts[b + 1] += grid.starts[b];
        }
        let mut next = grid.starts.clone();
        grid.indices = vec![0; mergeable.len()];
        for (&i, &k) in mergeable.iter().zip(&keys) {
            grid.indices[next[k] as usize] = i;
            next[k] += 1;
        }
        grid
    }

    fn cell_of(&self, p: Vec3) -> IVec3 {
        ((p - self.origin) / self.cell).floor().as_ivec3()
    }

    /// The bucket of cell `c` (Teschner et al. 2003's spatial hash).
    fn bucket(&self, c: IVec3) -> usize {
        let h = (c.x as u32).wrapping_mul(73_856_093)
            ^ (c.y as u32).wrapping_mul(19_349_663)
            ^ (c.z as u32).wrapping_mul(83_492_791);
        h as usize & (self.starts.len() - 2)
    }

    /// Calls `f` with every vertex in the cells a sphere of `radius` around `p` touches,
    /// each bucket once.
    fn visit(&self, p: Vec3, radius: f32, mut f: impl FnMut(usize)) {
        if self.indices.is_empty() || !p.is_finite() {
            return;
        }
        let lo = self.cell_of(p - Vec3::splat(radius));
        let mut buckets = [0usize; 8];
        for (k, b) in buckets.iter_mut().enumerate() {
            *b = self.bucket(lo + IVec3::new(k as i32 & 1, (k as i32 >> 1) & 1, k as i32 >> 2));
        }
        buckets.sort_unstable();
        for (k, &b) in buckets.iter().enumerate() {
            if k > 0 && buckets[k - 1] == b {
                continue;
            }
            for &i in &self.indices[self.starts[b] as usize..self.starts[b + 1] as usize] {
                f(i as usize);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vertex(p: Vec3) -> LightVertex {
        LightVertex {
            p,
            n: Vec3::Z,
            beta: Spectrum::ONE,
            densities: Densities { fwd: 1.0, rev: 1.0, delta: false, merge: true },
            infinite: false,
            delta_light: false,
            index: 1,
            hero_only: false,
        }
    }

    #[test]
    fn the_grid_finds_exactly_the_vertices_within_the_radius_once_each() {
        // A pseudo-random cloud, queried at points of it and between them, against brute force.
        let mut rng = rand_pcg::Pcg32::new(12345, 1);
        let mut next = || (rand_core::RngCore::next_u32(&mut rng) >> 8) as f32 / (1u32 << 24) as f32;
        let points: Vec<Vec3> = (0..2000).map(|_| Vec3::new(next(), next(), next()) * 2.0 - 1.0).collect();
        let vertices: Vec<LightVertex> = points.iter().map(|&p| vertex(p)).collect();
        let radius = 0.08;
        let grid = Grid::build(&vertices, radius);
        for q in points.iter().take(200).map(|p| *p + Vec3::splat(0.01)) {
            let mut found = Vec::new();
            grid.visit(q, radius, |i| {
                if (vertices[i].p - q).length_squared() < radius * radius {
                    found.push(i);
                }
            });
            let mut sorted = found.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), found.len(), "a vertex found twice");
            let brute: Vec<usize> = (0..vertices.len()).filter(|&i| (vertices[i].p - q).length() < radius).collect();
            assert_eq!(sorted, brute);
        }
    }
}

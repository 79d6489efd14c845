//! Heterogeneous media: a density grid read from an OpenVDB file (the vdb-rs crate), made
//! dense over the bounding box of its active voxels and fitted to the bounds of the meshes
//! that hold it, with a coarse grid of majorants. Free-flight distances come from delta
//! tracking and shadow-ray transmittance from ratio tracking against those majorants,
//! cell by cell along the ray (pbrt-v4 chapter 11; Novák et al. 2014).

use glam::{I64Vec3, IVec3, UVec3, Vec3};
use std::path::Path;

/// Voxels per side of a majorant cell.
const CELL: i32 = 8;

/// Ratio tracking plays Russian roulette once its estimate falls below this, ending the
/// walk with this probability.
const ROULETTE_BELOW: f32 = 0.05;
const ROULETTE_END: f32 = 0.75;

/// Most tentative collisions one free-flight or transmittance walk takes.
const MAX_COLLISIONS: u32 = 1 << 12;

/// Most voxels a grid may hold once dense (1 GiB of f32).
const MAX_VOXELS: u64 = 1 << 28;

/// A scalar density on a voxel grid, placed in the scene.
#[derive(Clone, Debug)]
pub struct DensityGrid {
    /// File and grid name, for messages.
    pub name: String,
    /// Voxels per axis.
    dims: UVec3,
    /// Densities, x fastest.
    data: Vec<f32>,
    /// Majorant cells per axis.
    cells: UVec3,
    /// Largest density that interpolation reaches in each cell, x fastest.
    majorants: Vec<f32>,
    /// World position of the grid's corner and world-to-voxel scale (set by `fit`).
    origin: Vec3,
    scale: Vec3,
}

impl DensityGrid {
    /// A grid of the given active voxels (index, density); densities that are negative or
    /// not finite count as 0. The error is one line.
    pub fn from_voxels(name: &str, voxels: &[(IVec3, f32)]) -> Result<Self, String> {
        let boxes = voxels.iter().map(|&(i, _)| (i.as_i64vec3(), 1));
        let (lo, dims) = Self::span(name, boxes, crate::memory::Limits::from_machine().memory)?;
        let mut data = vec![0.0f32; (dims.x * dims.y * dims.z) as usize];
        for &(i, v) in voxels {
            Self::fill(&mut data, dims, i.as_i64vec3() - lo, 1, v);
        }
        Ok(Self::dense(name, dims.as_uvec3(), data))
    }

    /// The corner and size of the box around `boxes` (corner, side in voxels), in i64 so
    /// that voxels at the i32 extremes do not overflow, after checking that it holds at
    /// most `MAX_VOXELS` and that their f32 densities fit in `room` bytes.
    fn span(name: &str, boxes: impl Iterator<Item = (I64Vec3, i64)>, room: u64) -> Result<(I64Vec3, I64Vec3), String> {
        let (lo, hi) = boxes.fold((I64Vec3::MAX, I64Vec3::MIN), |(lo, hi), (p, side)| {
            (lo.min(p), hi.max(p + I64Vec3::splat(side - 1)))
        });
        if lo.x > hi.x {
            return Err(format!("{name}: the grid has no active voxel"));
        }
        let dims = hi - lo + I64Vec3::ONE;
        let count = [dims.x, dims.y, dims.z].into_iter().try_fold(1u64, |n, d| n.checked_mul(d as u64));
        if count.is_none_or(|n| n > MAX_VOXELS) {
            return Err(format!(
                "{name}: the grid spans {}x{}x{} voxels, over the limit of {MAX_VOXELS}",
                dims.x, dims.y, dims.z
            ));
        }
        let bytes = count.unwrap_or(0) * 4;
        if bytes > room {
            return Err(format!(
                "{name}: the grid's {}x{}x{} voxels take {}, over the memory limit of {}",
                dims.x,
                dims.y,
                dims.z,
                crate::memory::format_bytes(bytes),
                crate::memory::format_bytes(room)
            ));
        }
        Ok((lo, dims))
    }

    /// Sets the cube of `side` voxels at `local` (from the grid's corner) to density `v`
    /// (0 if negative or not finite).
    fn fill(data: &mut [f32], dims: I64Vec3, local: I64Vec3, side: i64, v: f32) {
        let v = if v.is_finite() { v.max(0.0) } else { 0.0 };
        for z in local.z..local.z + side {
            for y in local.y..local.y + side {
                let row = ((z * dims.y + y) * dims.x + local.x) as usize;
                data[row..row + side as usize].fill(v);
            }
        }
    }

    /// The grid of `dims` voxels holding `data` (x fastest), with its majorants: each
    /// cell's is the largest density of the voxels within one of it, as trilinear
    /// interpolation reaches into the cell from its neighbours.
    fn dense(name: &str, dims: UVec3, data: Vec<f32>) -> Self {
        let cells = (dims + UVec3::splat(CELL as u32 - 1)) / CELL as u32;
        let mut grid = Self {
            name: name.into(),
            dims,
            data,
            cells,
            majorants: vec![0.0; (cells.x * cells.y * cells.z) as usize],
            origin: Vec3::ZERO,
            scale: Vec3::ONE,
        };
        grid.fit(Vec3::ZERO, dims.as_vec3());
        let (d, c) = (dims.as_ivec3(), cells.as_ivec3());
        for cz in 0..c.z {
            for cy in 0..c.y {
                for cx in 0..c.x {
                    let cell = IVec3::new(cx, cy, cz);
                    let lo = (cell * CELL - IVec3::ONE).max(IVec3::ZERO);
                    let hi = (cell * CELL + IVec3::splat(CELL + 1)).min(d);
                    let mut m = 0.0f32;
                    for z in lo.z..hi.z {
                        for y in lo.y..hi.y {
                            let row = ((z * d.y + y) * d.x) as usize;
                            m = grid.data[row + lo.x as usize..row + hi.x as usize].iter().fold(m, |m, &v| m.max(v));
                        }
                    }
                    grid.majorants[(cx + c.x * (cy + c.y * cz)) as usize] = m;
                }
            }
        }
        grid
    }

    /// Reads the float grid `grid` (the first grid by name if None) of an OpenVDB file,
    /// checked first ([`super::vdb`]) and read by vdb-rs behind the decoder guard.
    pub fn load_vdb(path: &Path, grid: Option<&str>) -> Result<Self, String> {
        let fail = |e: &dyn std::fmt::Display| format!("cannot read density grid {}: {e}", path.display());
        let limit = crate::memory::Limits::from_machine().memory;
        crate::memory::regular_file_size(path, limit).map_err(|e| fail(&e))?;
        let bytes = std::fs::read(path).map_err(|e| fail(&e))?;
        let prepared = super::vdb::prepare(bytes, grid).map_err(|e| fail(&e))?;
        let (file, name) = (prepared.bytes.len() as u64, prepared.grid);
        if file.saturating_add(prepared.held) > limit {
            return Err(fail(&format!(
                "reading grid \"{name}\" takes {}, over the memory limit of {}",
                crate::memory::format_bytes(file.saturating_add(prepared.held)),
                crate::memory::format_bytes(limit)
            )));
        }
        let label = format!("{} (grid \"{name}\")", path.display());
        let room = limit - file - prepared.held;
        crate::guard::decode("vdb-rs", || {
            let mut reader = vdb_rs::VdbReader::new(std::io::Cursor::new(prepared.bytes)).map_err(|e| fail(&e))?;
            let read = reader.read_grid::<f32>(&name).map_err(|e| fail(&format!("grid \"{name}\": {e}")))?;
            // Positions are vdb-rs's glam vectors; tiles (of 8 or 128 voxels a side) are cubes.
            let cube = |x: f32, y: f32, z: f32, side: f32| (I64Vec3::new(x as i64, y as i64, z as i64), side as i64);
            let boxes = read.iter().map(|(p, _, level)| cube(p.x, p.y, p.z, level.scale()));
            let (lo, dims) = Self::span(&label, boxes, room)?;
            let mut data = vec![0.0f32; (dims.x * dims.y * dims.z) as usize];
            for (p, v, level) in read.iter() {
                let (p, side) = cube(p.x, p.y, p.z, level.scale());
                Self::fill(&mut data, dims, p - lo, side, v);
            }
            Ok(Self::dense(&label, dims.as_uvec3(), data))
        })
        .map_err(|e| fail(&e))?
    }

    /// Places the grid's voxel box so that it spans the world box from `lo` to `hi`.
    pub fn fit(&mut self, lo: Vec3, hi: Vec3) {
        self.origin = lo;
        self.scale = self.dims.as_vec3() / (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
    }

    fn voxel(&self, i: IVec3) -> f32 {
        if i.cmplt(IVec3::ZERO).any() || i.cmpge(self.dims.as_ivec3()).any() {
            return 0.0;
        }
        self.data[(i.x as u32 + self.dims.x * (i.y as u32 + self.dims.y * i.z as u32)) as usize]
    }

    /// Position in voxel units (voxel i spans [i, i + 1)) of world point `p`.
    fn to_grid(&self, p: Vec3) -> Vec3 {
        (p - self.origin) * self.scale
    }

    /// Density at world point `p`, trilinear between voxel centres, 0 outside the grid.
    pub fn density(&self, p: Vec3) -> f32 {
        let g = self.to_grid(p);
        if g.cmplt(Vec3::ZERO).any() || g.cmpgt(self.dims.as_vec3()).any() {
            return 0.0;
        }
        let c = g - Vec3::splat(0.5);
        let i = c.floor().as_ivec3();
        let f = c - i.as_vec3();
        let mut sum = 0.0;
        for corner in 0..8 {
            let o = IVec3::new(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let w = Vec3::select(o.cmpeq(IVec3::ONE), f, Vec3::ONE - f);
            sum += w.x * w.y * w.z * self.voxel(i + o);
        }
        sum
    }

    /// Bytes the grid holds: its densities and majorants.
    pub fn bytes(&self) -> u64 {
        4 * (self.data.len() + self.majorants.len()) as u64
    }

    /// The largest density anywhere in the grid.
    pub fn max_density(&self) -> f32 {
        self.majorants.iter().copied().fold(0.0, f32::max)
    }

    /// The majorant cells a ray from `o` along `d` crosses before `t_max`, as (t0, t1,
    /// majorant) in order (3D DDA; Amanatides and Woo 1987), calling `visit` for each; it
    /// returns false to stop.
    pub fn march(&self, o: Vec3, d: Vec3, t_max: f32, mut visit: impl FnMut(f32, f32, f32) -> bool) {
        let cell_size = Vec3::splat(CELL as f32);
        let (go, gd) = (self.to_grid(o) / cell_size, d * self.scale / cell_size);
        let extent = self.dims.as_vec3() / CELL as f32;
        // Clip to the grid's box.
        let (mut t0, mut t1) = (0.0f32, t_max);
        for a in 0..3 {
            if gd[a] == 0.0 {
                if go[a] < 0.0 || go[a] >= extent[a] {
                    return;
                }
                continue;
            }
            let (ta, tb) = ((0.0 - go[a]) / gd[a], (extent[a] - go[a]) / gd[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        if t0 >= t1 {
            return;
        }
        let start = go + gd * t0;
        let mut cell = start.floor().as_ivec3().clamp(IVec3::ZERO, self.cells.as_ivec3() - IVec3::ONE);
        let step = IVec3::new(gd.x.signum() as i32, gd.y.signum() as i32, gd.z.signum() as i32);
        let next_boundary = |c: IVec3, a: usize| {
            if gd[a] == 0.0 {
                return f32::INFINITY;
            }
            let edge = if gd[a] > 0.0 { c[a] + 1 } else { c[a] } as f32;
            (edge - go[a]) / gd[a]
        };
        let mut t = t0;
        while t < t1 {
            let exits = [next_boundary(cell, 0), next_boundary(cell, 1), next_boundary(cell, 2)];
            let axis = (0..3).min_by(|&a, &b| exits[a].total_cmp(&exits[b])).unwrap_or(0);
            let t_exit = exits[axis].min(t1).max(t);
            let at = (cell.x as u32 + self.cells.x * (cell.y as u32 + self.cells.y * cell.z as u32)) as usize;
            if !visit(t, t_exit, self.majorants[at]) {
                return;
            }
            t = t_exit;
            cell[axis] += step[axis];
            if cell[axis] < 0 || cell[axis] >= self.cells[axis] as i32 {
                return;
            }
        }
    }

    /// Tentative collisions along a ray from `o` along unit `d` up to `t_max` in a medium
    /// of extinction `sigma` x density: distances drawn against each cell's majorant
    /// (pbrt-v4's SampleT_maj). `visit(t, density / majorant, u)` sees each one and returns
    /// false to stop.
    fn collisions(
        &self,
        (sigma, o, d, t_max): (f32, Vec3, Vec3, f32),
        u: &mut dyn FnMut() -> f32,
        mut visit: impl FnMut(f32, f32, &mut dyn FnMut() -> f32) -> bool,
    ) {
        let mut left = MAX_COLLISIONS;
        self.march(o, d, t_max, |t0, t1, majorant| {
            let sigma_maj = (sigma * majorant).min(f32::MAX);
            if sigma_maj <= 0.0 {
                return true;
            }
            let mut t = t0;
            loop {
                // At least one ulp, so that the walk advances whatever the density.
                t = (t - (1.0 - u()).ln() / sigma_maj).max(t.next_up());
                if t >= t1 {
                    return true;
                }
                let density = self.density(o + d * t);
                if density == 0.0
                    && let Some(exit) = self.empty_span_exit(o, d, t)
                {
                    t = exit;
                    continue;
                }
                left -= 1;
                if left == 0 {
                    // The walk has met more tentative collisions than a ray through any
                    // medium a scene means to show (an optical depth over 2^12 under the
                    // majorant): it ends as at a real one (opaque), a bias only there.
                    visit(t, 1.0, u);
                    return false;
                }
                if !visit(t, density / majorant, u) {
                    return false;
                }
            }
        });
    }

    /// Where the ray leaves the span between voxel centres around `o + d t` if all eight
    /// voxels at its corners are empty: interpolation makes the density 0 all through it,
    /// so its tentative collisions are all null and are skipped (a majorant of 0 there; the
    /// collisions after it start afresh, as the exponential's lack of memory allows).
    fn empty_span_exit(&self, o: Vec3, d: Vec3, t: f32) -> Option<f32> {
        let g = self.to_grid(o + d * t) - Vec3::splat(0.5);
        let base = g.floor();
        let corner = base.as_ivec3();
        for z in 0..2 {
            for y in 0..2 {
                for x in 0..2 {
                    if self.voxel(corner + IVec3::new(x, y, z)) != 0.0 {
                        return None;
                    }
                }
            }
        }
        // Slab exit from the unit box [base, base + 1] in grid units.
        let (go, gd) = (self.to_grid(o) - Vec3::splat(0.5), d * self.scale);
        let exit = (0..3)
            .filter(|&a| gd[a] != 0.0)
            .map(|a| ((if gd[a] > 0.0 { base[a] + 1.0 } else { base[a] }) - go[a]) / gd[a])
            .fold(f32::INFINITY, f32::min);
        Some(exit.max(t.next_up()))
    }

    /// Delta tracking: the distance at which a ray from `o` along unit `d` first really
    /// collides in a medium of extinction `sigma` x density, or None if it passes `t_max`;
    /// `u` draws uniform numbers.
    pub fn delta_track(&self, sigma: f32, o: Vec3, d: Vec3, t_max: f32, u: &mut dyn FnMut() -> f32) -> Option<f32> {
        let mut collision = None;
        self.collisions((sigma, o, d, t_max), u, |t, real, u| {
            let null = u() >= real;
            if !null {
                collision = Some(t);
            }
            null
        });
        collision
    }

    /// Ratio tracking: an unbiased estimate of the transmittance of a medium of extinction
    /// `sigma` x density along a ray from `o` along unit `d` up to `t_max`.
    pub fn ratio_track(&self, sigma: f32, o: Vec3, d: Vec3, t_max: f32, u: &mut dyn FnMut() -> f32) -> f32 {
        let mut tr = 1.0f32;
        self.collisions((sigma, o, d, t_max), u, |_, real, u| {
            tr *= 1.0 - real;
            // Russian roulette once the estimate is small (pbrt-v4's ratio tracking does
            // the same): unbiased, and it ends walks through dense media in a few steps.
            if tr < ROULETTE_BELOW {
                if u() < ROULETTE_END {
                    tr = 0.0;
                    return false;
                }
                tr /= 1.0 - ROULETTE_END;
            }
            tr > 0.0
        });
        tr.max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numbers() -> impl FnMut() -> f32 {
        let mut state = 7u64;
        move || {
            state = crate::math::sampler::mix64(state.wrapping_add(0x9e37_79b9_7f4a_7c15));
            (state >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    #[test]
    fn walks_end_at_any_density_and_skip_empty_space_exactly() {
        // Density 1e12 where x < 8 and 0 elsewhere in a 16^3 grid: the majorant cells on
        // the empty side of the wall see 1e12 through interpolation's reach.
        let voxels: Vec<(IVec3, f32)> = (0..16 * 16 * 16)
            .map(|i| IVec3::new(i % 16, i / 16 % 16, i / 256))
            .map(|p| (p, if p.x < 8 { 1e12 } else { 0.0 }))
            .collect();
        let wall = DensityGrid::from_voxels("wall", &voxels).unwrap();
        let (done, walked) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut u = numbers();
            // Through the empty side, where every tentative collision would be null.
            let (o, up) = (Vec3::new(12.0, -1.0, 8.0), Vec3::Y);
            for sigma in [1.0, 1e7, 1e30] {
                assert_eq!(wall.ratio_track(sigma, o, up, 20.0, &mut u), 1.0, "sigma {sigma}");
                assert_eq!(wall.delta_track(sigma, o, up, 20.0, &mut u), None, "sigma {sigma}");
            }
            // Into the wall: opaque, and the collision is where the density starts
            // (between the centres of voxels 7 and 8).
            let (o, left) = (Vec3::new(17.0, 8.0, 8.0), -Vec3::X);
            let t = wall.delta_track(1.0, o, left, 20.0, &mut u).unwrap();
            assert!(t > 17.0 - 8.5 - 1e-3 && t < 17.0 - 7.5, "{t}");
            assert_eq!(wall.ratio_track(1.0, o, left, 20.0, &mut u), 0.0);
            done.send(()).unwrap();
        });
        walked.recv_timeout(std::time::Duration::from_secs(20)).expect("the walks end");
    }

    fn ramp() -> DensityGrid {
        let mut voxels = Vec::new();
        for z in 0..20 {
            for y in 0..20 {
                for x in 0..20 {
                    voxels.push((IVec3::new(x, y, z), x as f32 / 19.0));
                }
            }
        }
        let mut g = DensityGrid::from_voxels("ramp", &voxels).unwrap();
        g.fit(Vec3::ZERO, Vec3::splat(2.0));
        g
    }

    #[test]
    fn density_interpolates_and_majorants_bound_it() {
        let g = ramp();
        assert!((g.density(Vec3::new(1.0, 1.0, 1.0)) - 0.5).abs() < 1e-5, "trilinear along the ramp");
        assert_eq!(g.density(Vec3::splat(-1.0)), 0.0, "nothing outside");
        let mut covered = 0.0;
        g.march(Vec3::new(-1.0, 0.3, 0.7), Vec3::X, 10.0, |t0, t1, majorant| {
            for k in 0..16 {
                let t = t0 + (t1 - t0) * (k as f32 + 0.5) / 16.0;
                assert!(g.density(Vec3::new(-1.0 + t, 0.3, 0.7)) <= majorant + 1e-6, "majorant bounds the density");
            }
            covered += t1 - t0;
            true
        });
        assert!((covered - 2.0).abs() < 1e-4, "the march covers the grid's width: {covered}");
    }

    #[test]
    fn ratio_tracking_and_delta_tracking_match_the_optical_depth() {
        // Along x the ramp's optical depth over [0, 2] is sigma * integral of the density.
        let (g, sigma) = (ramp(), 1.5f32);
        let (o, d) = (Vec3::new(-0.5, 1.0, 1.0), Vec3::X);
        let n = 200_000;
        let mut u = numbers();
        let depth: f32 =
            (0..2000).map(|k| g.density(o + d * (0.5 + 2.0 * (k as f32 + 0.5) / 2000.0))).sum::<f32>() * 2.0 / 2000.0
                * sigma;
        let expected = (-depth).exp();
        let ratio = (0..n).map(|_| g.ratio_track(sigma, o, d, 5.0, &mut u) as f64).sum::<f64>() / n as f64;
        let passed = (0..n).filter(|_| g.delta_track(sigma, o, d, 5.0, &mut u).is_none()).count() as f64 / n as f64;
        assert!((ratio - expected as f64).abs() < 0.005, "ratio tracking {ratio} vs {expected}");
        assert!((passed - expected as f64).abs() < 0.005, "delta tracking passes {passed} vs {expected}");
    }
}

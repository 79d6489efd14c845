//! Heterogeneous media: a density grid read from an OpenVDB file (the vdb-rs crate), made
//! dense over the bounding box of its active voxels and fitted to the bounds of the meshes
//! that hold it, with a coarse grid of majorants. Free-flight distances come from delta
//! tracking and shadow-ray transmittance from ratio tracking against those majorants,
//! cell by cell along the ray (pbrt-v4 chapter 11; Novák et al. 2014).

use glam::{IVec3, UVec3, Vec3};
use std::path::Path;

/// Voxels per side of a majorant cell.
const CELL: i32 = 8;

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
        let (lo, hi) = voxels.iter().fold((IVec3::MAX, IVec3::MIN), |(lo, hi), &(i, _)| (lo.min(i), hi.max(i)));
        if voxels.is_empty() {
            return Err(format!("{name}: the grid has no active voxel"));
        }
        let dims = (hi - lo + IVec3::ONE).as_uvec3();
        let count = dims.x as u64 * dims.y as u64 * dims.z as u64;
        if count > MAX_VOXELS {
            return Err(format!("{name}: the grid spans {dims} voxels, over the limit of {MAX_VOXELS}"));
        }
        let mut data = vec![0.0f32; count as usize];
        for &(i, v) in voxels {
            let local = (i - lo).as_uvec3();
            data[(local.x + dims.x * (local.y + dims.y * local.z)) as usize] =
                if v.is_finite() { v.max(0.0) } else { 0.0 };
        }
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
        for z in 0..dims.z as i32 {
            for y in 0..dims.y as i32 {
                for x in 0..dims.x as i32 {
                    let v = grid.voxel(IVec3::new(x, y, z));
                    // Trilinear interpolation spreads a voxel over its neighbours' cells.
                    for dz in -1..=1 {
                        for dy in -1..=1 {
                            for dx in -1..=1 {
                                let c = (IVec3::new(x + dx, y + dy, z + dz)).div_euclid(IVec3::splat(CELL));
                                if c.cmpge(IVec3::ZERO).all() && c.cmplt(cells.as_ivec3()).all() {
                                    let at = (c.x + cells.x as i32 * (c.y + cells.y as i32 * c.z)) as usize;
                                    grid.majorants[at] = grid.majorants[at].max(v);
                                }
                            }
                        }
                    }
                }
            }
        }
        Ok(grid)
    }

    /// Reads the float grid `grid` (the first float grid if None) of an OpenVDB file.
    pub fn load_vdb(path: &Path, grid: Option<&str>) -> Result<Self, String> {
        let fail = |e: &dyn std::fmt::Display| format!("cannot read density grid {}: {e}", path.display());
        crate::memory::regular_file_size(path, crate::memory::Limits::from_machine().memory).map_err(|e| fail(&e))?;
        let file = std::fs::File::open(path).map_err(|e| fail(&e))?;
        let mut reader = vdb_rs::VdbReader::new(std::io::BufReader::new(file)).map_err(|e| fail(&e))?;
        let mut names = reader.available_grids();
        names.sort();
        let name = match grid {
            Some(g) if names.iter().any(|n| n == g) => g.to_string(),
            Some(g) => return Err(fail(&format!("it has no grid \"{g}\" (it has {})", names.join(", ")))),
            None => names.first().cloned().ok_or_else(|| fail(&"it holds no grid"))?,
        };
        let read = reader.read_grid::<f32>(&name).map_err(|e| fail(&format!("grid \"{name}\": {e}")))?;
        if !read.descriptor.grid_type.contains("float") {
            return Err(fail(&format!("grid \"{name}\" holds {}, not float densities", read.descriptor.grid_type)));
        }
        let mut voxels = Vec::new();
        for (p, v, level) in read.iter() {
            let (p, size) = (IVec3::new(p.x as i32, p.y as i32, p.z as i32), level.scale() as i32);
            if (size as u64).pow(3) + voxels.len() as u64 > MAX_VOXELS {
                return Err(fail(&format!("grid \"{name}\" has more than {MAX_VOXELS} voxels")));
            }
            for z in 0..size {
                for y in 0..size {
                    for x in 0..size {
                        voxels.push((p + IVec3::new(x, y, z), v));
                    }
                }
            }
        }
        Self::from_voxels(&format!("{} (grid \"{name}\")", path.display()), &voxels)
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
        self.march(o, d, t_max, |t0, t1, majorant| {
            let sigma_maj = sigma * majorant;
            if sigma_maj <= 0.0 {
                return true;
            }
            let mut t = t0;
            loop {
                t -= (1.0 - u()).ln() / sigma_maj;
                if t >= t1 {
                    return true;
                }
                if !visit(t, self.density(o + d * t) / majorant, u) {
                    return false;
                }
            }
        });
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
        self.collisions((sigma, o, d, t_max), u, |_, real, _| {
            tr *= 1.0 - real;
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

//! Triangles in BVH order, obvhs's CWBVH over them, and closest-hit and occlusion queries.

use glam::{UVec2, Vec2, Vec3, Vec3A, Vec4};
use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    cwbvh::{CwBvh, builder::build_cwbvh},
    ray::{Ray as BvhRay, RayHit},
    triangle::Triangle,
};
use std::cell::Cell;
use std::time::Duration;

use super::watertight::{SoaTriangles, Watertight, intersect_group};

/// Per-triangle shading attributes, stored in BVH order beside the positions.
#[derive(Clone, Copy, Debug)]
pub struct TriAttrs {
    /// Shading normals at the three vertices (world space, unit length).
    pub normals: [Vec3; 3],
    /// Texture coordinates (set 0) at the three vertices.
    pub uvs: [Vec2; 3],
    /// Unit geometric normal, on the glTF front side (counter-clockwise winding).
    pub ng: Vec3,
    /// Index into the scene's materials.
    pub material: u32,
}

/// Attributes only some scenes have, stored per triangle beside `TriAttrs` when any mesh
/// has one of them.
#[derive(Clone, Copy, Debug)]
pub struct TriExtra {
    /// Texture coordinates of set 1 (set 0 where the mesh has none).
    pub uv1: [Vec2; 3],
    /// Vertex colours (COLOR_0; white where the mesh has none).
    pub colors: [Vec4; 3],
    /// Tangents with the bitangent sign in w (zero where the mesh has no normal map).
    pub tangents: [Vec4; 3],
}

/// A ray with origin, direction (any length) and a parametric interval [0, tmax).
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// Direction; hits are at `o + t d`.
    pub d: Vec3,
    /// Exclusive upper bound on t.
    pub tmax: f32,
}

/// A closest hit: triangle (BVH order), distance parameter and barycentrics.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Triangle index in BVH order.
    pub tri: u32,
    /// Ray parameter of the hit.
    pub t: f32,
    /// Barycentric weights of vertices 0, 1, 2.
    pub b: [f32; 3],
}

/// Triangle positions plus attributes in BVH order, and the BVH over them.
pub struct Geometry {
    bvh: CwBvh,
    positions: Vec<[Vec3; 3]>,
    /// The positions again as structure of arrays, for testing four triangles at once.
    soa: SoaTriangles,
    attrs: Vec<TriAttrs>,
    extra: Vec<TriExtra>,
    /// Length of the direction handed to obvhs, so that its ray parameter is in units of
    /// 1e-5 of the scene's size (see `to_bvh_ray`).
    t_unit: f32,
    /// 1 / `t_unit`.
    inv_t_unit: f32,
    /// Time obvhs took to build the BVH.
    build_time: Duration,
}

impl Geometry {
    /// Builds obvhs's CWBVH over the triangles, then reorders triangles and attributes
    /// once into BVH order so that traversal indexes them directly. Each triangle's box is
    /// padded by a bound on the rounding of obvhs's slab test (1e-6 of its coordinates'
    /// magnitude plus 1e-7 of the scene's size): obvhs compares entry and exit with no
    /// tolerance, so a ray aimed exactly at a vertex on a box corner could otherwise miss
    /// every box around it and slip through a closed mesh. `extra` is empty or one per triangle.
    pub fn build(positions: Vec<[Vec3; 3]>, attrs: Vec<TriAttrs>, extra: Vec<TriExtra>) -> Self {
        let (lo, hi) = positions
            .iter()
            .flatten()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        let size = if positions.is_empty() { 1.0 } else { (hi - lo).length() };
        let boxes: Vec<Aabb> = positions
            .iter()
            .map(|p| {
                let (min, max) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
                let pad = Vec3::splat(1e-6 * min.abs().max(max.abs()).max_element() + 1e-7 * size);
                Aabb::new((min - pad).into(), (max + pad).into())
            })
            .collect();
        let mut build_time = Duration::default();
        let bvh = if boxes.is_empty() {
            CwBvh::default()
        } else {
            build_cwbvh(&boxes, BvhBuildParams::medium_build(), &mut build_time)
        };
        let t_unit = (size * 1e-5).clamp(f32::MIN_POSITIVE * 1e10, 1e30);
        let order = &bvh.primitive_indices;
        let positions: Vec<[Vec3; 3]> = order.iter().map(|&i| positions[i as usize]).collect();
        let soa = SoaTriangles::new(&positions);
        let attrs = order.iter().map(|&i| attrs[i as usize]).collect();
        let extra = if extra.is_empty() { extra } else { order.iter().map(|&i| extra[i as usize]).collect() };
        Self { bvh, positions, soa, attrs, extra, t_unit, inv_t_unit: 1.0 / t_unit, build_time }
    }

    /// Number of triangles (in BVH order, so including any duplicated references).
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// How long building the BVH took.
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// Whether there is no triangle at all.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Vertex positions of triangle `i` (BVH order).
    pub fn positions(&self, i: u32) -> &[Vec3; 3] {
        &self.positions[i as usize]
    }

    /// Shading attributes of triangle `i` (BVH order).
    pub fn attrs(&self, i: u32) -> &TriAttrs {
        &self.attrs[i as usize]
    }

    /// The optional attributes of triangle `i`, if the scene has any.
    pub fn extra(&self, i: u32) -> Option<&TriExtra> {
        self.extra.get(i as usize)
    }

    /// Closest hit along the ray, if any (watertight test).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.intersect_with(ray, true)
    }

    /// Whether anything blocks the ray before `tmax` (watertight test, early exit).
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, true)
    }

    /// Closest hit along the ray with the watertight test, or with obvhs's Moller-Trumbore
    /// test when `watertight` is false (kept to measure and show what watertightness buys).
    pub fn intersect_with(&self, ray: &Ray, watertight: bool) -> Option<Hit> {
        self.intersect_filtered(ray, watertight, |_, _| true)
    }

    /// Whether anything blocks the ray before `tmax`, with the test chosen as in `intersect_with`.
    pub fn occluded_with(&self, ray: &Ray, watertight: bool) -> bool {
        self.occluded_filtered(ray, watertight, |_, _| true)
    }

    /// `intersect_with`, ignoring the hits `accept` (triangle, barycentrics) turns down.
    pub fn intersect_filtered(
        &self,
        ray: &Ray,
        watertight: bool,
        accept: impl Fn(u32, [f32; 3]) -> bool,
    ) -> Option<Hit> {
        if self.is_empty() {
            return None;
        }
        if !watertight {
            return self.intersect_moller(ray, accept);
        }
        let wt = Watertight::new(ray);
        let r = to_bvh_ray(ray, self.t_unit);
        // The closest hit so far, in obvhs's ray units as its node tests take it.
        let bound = Cell::new(r.tmax);
        let mut closest = None;
        self.traverse(&r, |group_base, group, node_ray| {
            let tmax = || bound.get() * self.t_unit;
            intersect_group(&wt, &self.soa, &self.positions, group_base, group, tmax, |tri, t, b| {
                let t_bvh = t * self.inv_t_unit;
                if accept(tri, b) && t_bvh < bound.get() {
                    bound.set(t_bvh);
                    closest = Some(Hit { tri, t, b });
                }
                true
            });
            node_ray.tmax = bound.get();
            true
        });
        closest
    }

    /// `occluded_with`, ignoring the hits `accept` turns down.
    pub fn occluded_filtered(&self, ray: &Ray, watertight: bool, accept: impl Fn(u32, [f32; 3]) -> bool) -> bool {
        if self.is_empty() {
            return false;
        }
        if !watertight {
            return self.occluded_moller(ray, accept);
        }
        let wt = Watertight::new(ray);
        let r = to_bvh_ray(ray, self.t_unit);
        let tmax = r.tmax * self.t_unit;
        let mut blocked = false;
        self.traverse(&r, |group_base, group, _| {
            intersect_group(
                &wt,
                &self.soa,
                &self.positions,
                group_base,
                group,
                || tmax,
                |tri, t, b| {
                    blocked = accept(tri, b) && t * self.inv_t_unit < r.tmax;
                    !blocked
                },
            );
            !blocked
        });
        blocked
    }

    /// obvhs's CWBVH traversal, handing `leaves` each node's group of hit triangles at once
    /// (a base index and a bit per triangle above it) with the ray the node tests use, whose
    /// `tmax` it may lower; `leaves` returns false to stop. obvhs's own `ray_traverse`
    /// takes triangles one at a time, which rules out testing four together.
    #[inline]
    fn traverse(&self, ray: &BvhRay, mut leaves: impl FnMut(u32, u32, &mut BvhRay) -> bool) {
        let mut node_ray = *ray;
        let mut state = self.bvh.new_traversal(ray.direction);
        let mut node;
        obvhs::traverse!(self.bvh, node, state, node.intersect_ray(&node_ray, state.oct_inv4), {
            // The macro has just taken the group's highest bit for one triangle: put it
            // back, take the whole group, and leave none for the macro's next turn.
            let group = state.primitive_group.y | 1 << (state.primitive_id - state.primitive_group.x);
            state.primitive_group.y = 0;
            if !leaves(state.primitive_group.x, group, &mut node_ray) {
                break;
            }
        });
    }

    /// Closest hit with obvhs's own traversal and Moller-Trumbore test.
    fn intersect_moller(&self, ray: &Ray, accept: impl Fn(u32, [f32; 3]) -> bool) -> Option<Hit> {
        let mut hit = RayHit::none();
        // The closest hit's barycentrics, kept instead of computing them again afterwards.
        let mut closest = None;
        let found = self.bvh.ray_traverse(to_bvh_ray(ray, self.t_unit), &mut hit, |r, id| {
            match self.moller(ray, id, r).filter(|&(_, b)| accept(id as u32, b)) {
                Some((t, b)) => {
                    if t < r.tmax {
                        closest = Some(b);
                    }
                    t
                }
                None => f32::INFINITY,
            }
        });
        let b = closest.filter(|_| found)?;
        Some(Hit { tri: hit.primitive_id, t: hit.t * self.t_unit, b })
    }

    /// Occlusion with obvhs's own traversal and Moller-Trumbore test.
    fn occluded_moller(&self, ray: &Ray, accept: impl Fn(u32, [f32; 3]) -> bool) -> bool {
        !self.bvh.ray_traverse_miss(to_bvh_ray(ray, self.t_unit), |r, id| {
            self.moller(ray, id, r).filter(|&(_, b)| accept(id as u32, b)).map_or(f32::INFINITY, |(t, _)| t)
        })
    }

    /// obvhs's Moller-Trumbore test on triangle `id`: positive t in obvhs's ray units, and
    /// the barycentrics of the hit point.
    fn moller(&self, ray: &Ray, id: usize, r: &BvhRay) -> Option<(f32, [f32; 3])> {
        let [v0, v1, v2] = self.positions[id].map(Vec3A::from);
        let t = Triangle { v0, v1, v2 }.intersect(r);
        (t > 0.0 && t < f32::INFINITY).then(|| (t, barycentrics(ray.o + t * self.t_unit * ray.d, &self.positions[id])))
    }
}

/// Barycentric weights of the projection of `q` onto the plane of triangle `p`.
fn barycentrics(q: Vec3, p: &[Vec3; 3]) -> [f32; 3] {
    let (e1, e2, d) = (p[1] - p[0], p[2] - p[0], q - p[0]);
    let n = e1.cross(e2);
    let inv = 1.0 / n.length_squared();
    let b1 = d.cross(e2).dot(n) * inv;
    let b2 = e1.cross(d).dot(n) * inv;
    [1.0 - b1 - b2, b1, b2]
}

/// The ray as obvhs takes it, with its direction scaled to length `k` times the original.
/// obvhs's CWBVH node test culls boxes whose exit is below t = 1e-4 (an absolute epsilon in
/// ray-parameter units), which at scale 1e-4 culls the whole scene; with t in units of 1e-5
/// of the scene's size, that cut is at 1e-9 of it, below f32 precision. The reciprocal is
/// exact: obvhs's `Ray::new` clamps components below f32::EPSILON to +-1/EPSILON, moving
/// the slab planes so that rays aimed at a vertex with a 1e-9 component miss its boxes.
/// Zero components get +1e30 (no 0 x inf NaN, no overflow in the quantised slab tests),
/// and adding +0.0 turns -0.0 into +0.0, matching the octant obvhs takes from the sign.
fn to_bvh_ray(ray: &Ray, k: f32) -> BvhRay {
    let d = ray.d * k + Vec3::ZERO;
    let limit = Vec3::splat(1e30);
    let inv = Vec3::select(d.cmpeq(Vec3::ZERO), limit, (Vec3::ONE / d).clamp(-limit, limit));
    BvhRay {
        origin: Vec3A::from(ray.o),
        direction: Vec3A::from(d),
        inv_direction: Vec3A::from(inv),
        tmin: 0.0,
        tmax: ray.tmax / k,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Geometry {
        let p = [
            [Vec3::new(-1., -1., 0.), Vec3::new(1., -1., 0.), Vec3::new(1., 1., 0.)],
            [Vec3::new(-1., -1., 0.), Vec3::new(1., 1., 0.), Vec3::new(-1., 1., 0.)],
        ];
        let a = TriAttrs { normals: [Vec3::Z; 3], uvs: [Vec2::ZERO; 3], ng: Vec3::Z, material: 0 };
        Geometry::build(p.to_vec(), vec![a; 2], Vec::new())
    }

    #[test]
    fn rays_through_the_shared_diagonal_and_vertices_hit() {
        let g = quad();
        for x in [-0.75f32, -0.5, 0.0, 0.25, 0.75] {
            let ray = Ray { o: Vec3::new(x, x, 1.0), d: -Vec3::Z, tmax: f32::INFINITY };
            let hit = g.intersect(&ray).expect("diagonal hit");
            assert!((hit.t - 1.0).abs() < 1e-6);
            let p = g.positions(hit.tri);
            let q = p[0] * hit.b[0] + p[1] * hit.b[1] + p[2] * hit.b[2];
            assert!((q - Vec3::new(x, x, 0.0)).length() < 1e-6);
        }
    }

    #[test]
    fn axis_aligned_rays_with_negative_zero_components_hit() {
        let g = quad();
        let d = Vec3::new(-0.0, -0.0, -1.0);
        assert!(g.intersect(&Ray { o: Vec3::new(0.5, -0.5, 1.0), d, tmax: f32::INFINITY }).is_some());
    }

    #[test]
    fn occlusion_respects_tmax() {
        let g = quad();
        let ray = Ray { o: Vec3::new(0.1, 0.2, 1.0), d: -Vec3::Z, tmax: 0.999 };
        assert!(!g.occluded(&ray));
        assert!(g.occluded(&Ray { tmax: 1.001, ..ray }));
        let back = Ray { o: Vec3::new(0.1, 0.2, -1.0), d: -Vec3::Z, tmax: f32::INFINITY };
        assert!(g.intersect(&back).is_none());
    }
}

//! One mesh's triangles in BVH order and obvhs's CWBVH over them (a bottom-level BVH), with
//! the watertight closest-hit and occlusion queries of Woop et al. (JCGT 2013).

use glam::{UVec2, Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    cwbvh::{CwBvh, builder::build_cwbvh},
    ray::{Ray as BvhRay, RayHit},
    triangle::Triangle,
};
use std::cell::Cell;
use std::time::Duration;

use super::geometry::{Hit, Ray, TriAttrs, TriExtra, Triangles};
use super::watertight::{SoaTriangles, Watertight, intersect_group};

/// Triangle positions plus attributes in BVH order, and the BVH over them.
pub(super) struct Blas {
    bvh: CwBvh,
    positions: Vec<[Vec3; 3]>,
    /// The positions again as structure of arrays, for testing four triangles at once.
    soa: SoaTriangles,
    attrs: Vec<TriAttrs>,
    extra: Vec<TriExtra>,
    /// Length of the direction handed to obvhs, so that its ray parameter is in units of
    /// 1e-5 of the mesh's size (see `to_bvh_ray`).
    t_unit: f32,
    /// 1 / `t_unit`.
    inv_t_unit: f32,
    /// Bounds of the vertices (min, max); inverted (+inf, -inf) without triangles.
    pub(super) bounds: (Vec3, Vec3),
    /// Time obvhs took to build the BVH.
    pub(super) build_time: Duration,
}

impl Blas {
    /// Builds obvhs's CWBVH over the triangles, then reorders triangles and attributes
    /// once into BVH order so that traversal indexes them directly. Each triangle's box is
    /// padded by a bound on the rounding of obvhs's slab test (1e-6 of its coordinates'
    /// magnitude plus 1e-7 of the mesh's size): obvhs compares entry and exit with no
    /// tolerance, so a ray aimed exactly at a vertex on a box corner could otherwise miss
    /// every box around it and slip through a closed mesh. `extra` is empty or one per triangle.
    pub(super) fn build(triangles: Triangles) -> Self {
        let Triangles { positions, attrs, extra } = triangles;
        let bounds = positions
            .iter()
            .flatten()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        let size = if positions.is_empty() { 1.0 } else { (bounds.1 - bounds.0).length() };
        let boxes: Vec<Aabb> = positions
            .iter()
            .map(|p| {
                let (min, max) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
                padded_box(min, max, size)
            })
            .collect();
        let (bvh, build_time) = build_bvh(&boxes);
        let t_unit = t_unit(size);
        let order = &bvh.primitive_indices;
        let positions: Vec<[Vec3; 3]> = order.iter().map(|&i| positions[i as usize]).collect();
        let soa = SoaTriangles::new(&positions);
        let attrs = order.iter().map(|&i| attrs[i as usize]).collect();
        let extra = if extra.is_empty() { extra } else { order.iter().map(|&i| extra[i as usize]).collect() };
        Self { bvh, positions, soa, attrs, extra, t_unit, inv_t_unit: 1.0 / t_unit, bounds, build_time }
    }

    /// Number of triangles.
    pub(super) fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there is no triangle at all.
    pub(super) fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Vertex positions of triangle `i` (BVH order).
    pub(super) fn positions(&self, i: u32) -> &[Vec3; 3] {
        &self.positions[i as usize]
    }

    /// Shading attributes of triangle `i` (BVH order).
    pub(super) fn attrs(&self, i: u32) -> &TriAttrs {
        &self.attrs[i as usize]
    }

    /// All triangles' shading attributes, in BVH order.
    pub(super) fn all_attrs(&self) -> &[TriAttrs] {
        &self.attrs
    }

    /// The optional attributes of triangle `i`, if the mesh has any.
    pub(super) fn extra(&self, i: u32) -> Option<&TriExtra> {
        self.extra.get(i as usize)
    }

    /// Bytes held: the BVH's nodes and index list, the triangles and their attributes.
    pub(super) fn bytes(&self) -> usize {
        use std::mem::size_of;
        let nodes = self.bvh.nodes.len() * size_of::<obvhs::cwbvh::node::CwBvhNode>();
        let indices = self.bvh.primitive_indices.len() * 4;
        let per_triangle = 2 * size_of::<[Vec3; 3]>() + size_of::<TriAttrs>();
        nodes + indices + self.len() * per_triangle + self.extra.len() * size_of::<TriExtra>()
    }

    /// `intersect_with`, ignoring the hits `accept` (triangle, barycentrics) turns down.
    pub(super) fn intersect_filtered(
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
        traverse(&self.bvh, &r, |group_base, group, node_ray| {
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
    pub(super) fn occluded_filtered(
        &self,
        ray: &Ray,
        watertight: bool,
        accept: impl Fn(u32, [f32; 3]) -> bool,
    ) -> bool {
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
        traverse(&self.bvh, &r, |group_base, group, _| {
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

/// obvhs's CWBVH traversal, handing `leaves` each node's group of hit triangles at once
/// (a base index and a bit per triangle above it) with the ray the node tests use, whose
/// `tmax` it may lower; `leaves` returns false to stop. obvhs's own `ray_traverse`
/// takes triangles one at a time, which rules out testing four together.
#[inline]
pub(super) fn traverse(bvh: &CwBvh, ray: &BvhRay, mut leaves: impl FnMut(u32, u32, &mut BvhRay) -> bool) {
    let mut node_ray = *ray;
    let mut state = bvh.new_traversal(ray.direction);
    let mut node;
    obvhs::traverse!(bvh, node, state, node.intersect_ray(&node_ray, state.oct_inv4), {
        // The macro has just taken the group's highest bit for one triangle: put it
        // back, take the whole group, and leave none for the macro's next turn.
        let group = state.primitive_group.y | 1 << (state.primitive_id - state.primitive_group.x);
        state.primitive_group.y = 0;
        if !leaves(state.primitive_group.x, group, &mut node_ray) {
            break;
        }
    });
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
pub(super) fn to_bvh_ray(ray: &Ray, k: f32) -> BvhRay {
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

/// obvhs's CWBVH over `boxes` (empty without any) and the time building it took.
pub(super) fn build_bvh(boxes: &[Aabb]) -> (CwBvh, Duration) {
    let mut build_time = Duration::default();
    let bvh = if boxes.is_empty() {
        CwBvh::default()
    } else {
        build_cwbvh(boxes, BvhBuildParams::medium_build(), &mut build_time)
    };
    (bvh, build_time)
}

/// The box [min, max] padded by a bound on the rounding of obvhs's slab test: 1e-6 of its
/// coordinates' magnitude plus 1e-7 of `size`, the size of everything the BVH holds.
pub(super) fn padded_box(min: Vec3, max: Vec3, size: f32) -> Aabb {
    let pad = Vec3::splat(1e-6 * min.abs().max(max.abs()).max_element() + 1e-7 * size);
    Aabb::new((min - pad).into(), (max + pad).into())
}

/// The length obvhs's ray direction gets for a BVH over things of size `size` (see `to_bvh_ray`).
pub(super) fn t_unit(size: f32) -> f32 {
    (size * 1e-5).clamp(f32::MIN_POSITIVE * 1e10, 1e30)
}

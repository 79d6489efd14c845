//! One mesh's triangles in BVH order and an eight-wide BVH over them (a bottom-level BVH,
//! `wide`), with the watertight closest-hit and occlusion queries of Woop et al. (JCGT 2013).

use glam::{Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    bvh2::reinsertion::ReinsertionOptimizer,
    cwbvh::{CwBvh, bvh2_to_cwbvh::bvh2_to_cwbvh},
    ploc::PlocBuilder,
    ray::Ray as BvhRay,
    triangle::Triangle,
};
use std::cell::Cell;
use std::time::{Duration, Instant};

use super::geometry::{Hit, Ray, TriAttrs, TriExtra, Triangles};
use super::watertight::{SoaTriangles, Watertight, intersect_group};
use super::wide::{SlabRay, Wide, bits};

/// Triangle positions plus attributes in BVH order, and the BVH over them.
pub(super) struct Blas {
    bvh: Wide,
    positions: Vec<[Vec3; 3]>,
    /// The positions again as structure of arrays, for testing four triangles at once.
    soa: SoaTriangles,
    attrs: Vec<TriAttrs>,
    extra: Vec<TriExtra>,
    /// Bounds of the vertices (min, max); inverted (+inf, -inf) without triangles.
    pub(super) bounds: (Vec3, Vec3),
    /// Time obvhs took to build the BVH.
    pub(super) build_time: Duration,
}

impl Blas {
    /// Builds obvhs's CWBVH over the triangles and the wide BVH from it, then reorders
    /// triangles and attributes once into BVH order so that traversal indexes them
    /// directly. Each triangle's box is padded (`padded_box`), so that a ray aimed exactly
    /// at a vertex on a box corner enters a box around it. `extra` is empty or one per triangle.
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
        // Each array is dropped as soon as what replaces it exists (obvhs's tree, whose node
        // array is allocated for as many nodes as triangles, at the end of this block; each
        // per-triangle array once its reordered copy is made), so that opening a large mesh
        // holds one copy of each at a time.
        let (wide, order, build_time) = {
            let (bvh, build_time) = build_bvh(&boxes);
            (Wide::new(&bvh, &reorder(&bvh.primitive_indices, boxes)), bvh.primitive_indices, build_time)
        };
        let positions = reorder(&order, positions);
        let soa = SoaTriangles::new(&positions);
        let attrs = reorder(&order, attrs);
        let extra = if extra.is_empty() { extra } else { reorder(&order, extra) };
        Self { bvh: wide, positions, soa, attrs, extra, bounds, build_time }
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
        let per_triangle = 2 * size_of::<[Vec3; 3]>() + size_of::<TriAttrs>();
        self.bvh.bytes() + self.len() * per_triangle + self.extra.len() * size_of::<TriExtra>()
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
        let bound = Cell::new(ray.tmax);
        let mut closest = None;
        self.bvh.traverse(&SlabRay::new(ray.o, ray.d), &bound, true, |first, group| {
            intersect_group(
                &wt,
                &self.soa,
                &self.positions,
                first,
                group,
                || bound.get(),
                |tri, t, b| {
                    if t < bound.get() && accept(tri, b) {
                        bound.set(t);
                        closest = Some(Hit { tri, t, b });
                    }
                    true
                },
            );
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
        let mut blocked = false;
        self.bvh.traverse(&SlabRay::new(ray.o, ray.d), &Cell::new(ray.tmax), false, |first, group| {
            intersect_group(
                &wt,
                &self.soa,
                &self.positions,
                first,
                group,
                || ray.tmax,
                |tri, _, b| {
                    blocked = accept(tri, b);
                    !blocked
                },
            );
            !blocked
        });
        blocked
    }

    /// Closest hit with obvhs's Moller-Trumbore test (the non-watertight comparison).
    fn intersect_moller(&self, ray: &Ray, accept: impl Fn(u32, [f32; 3]) -> bool) -> Option<Hit> {
        let r = bvh_ray(ray);
        let bound = Cell::new(ray.tmax);
        let mut closest = None;
        self.bvh.traverse(&SlabRay::new(ray.o, ray.d), &bound, true, |first, group| {
            for tri in bits(group).map(|bit| first + bit as u32) {
                if let Some((t, b)) = self.moller(ray, tri, &r).filter(|&(t, b)| t < bound.get() && accept(tri, b)) {
                    bound.set(t);
                    closest = Some(Hit { tri, t, b });
                }
            }
            true
        });
        closest
    }

    /// Occlusion with obvhs's Moller-Trumbore test.
    fn occluded_moller(&self, ray: &Ray, accept: impl Fn(u32, [f32; 3]) -> bool) -> bool {
        let r = bvh_ray(ray);
        let mut blocked = false;
        self.bvh.traverse(&SlabRay::new(ray.o, ray.d), &Cell::new(ray.tmax), false, |first, group| {
            blocked = bits(group)
                .map(|bit| first + bit as u32)
                .any(|tri| self.moller(ray, tri, &r).is_some_and(|(t, b)| t < ray.tmax && accept(tri, b)));
            !blocked
        });
        blocked
    }

    /// obvhs's Moller-Trumbore test on triangle `tri`: positive t and the barycentrics of
    /// the hit point.
    fn moller(&self, ray: &Ray, tri: u32, r: &BvhRay) -> Option<(f32, [f32; 3])> {
        let p = &self.positions[tri as usize];
        let [v0, v1, v2] = p.map(Vec3A::from);
        let t = Triangle { v0, v1, v2 }.intersect(r);
        (t > 0.0 && t < f32::INFINITY).then(|| (t, barycentrics(ray.o + t * ray.d, p)))
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

/// The ray as obvhs's Moller-Trumbore test takes it.
fn bvh_ray(ray: &Ray) -> BvhRay {
    BvhRay {
        origin: Vec3A::from(ray.o),
        direction: Vec3A::from(ray.d),
        inv_direction: Vec3A::ONE / Vec3A::from(ray.d),
        tmin: 0.0,
        tmax: ray.tmax,
    }
}

/// obvhs's CWBVH over `boxes` (empty without any) and the time building it took: its
/// `build_cwbvh` with the `medium_build` parameters (PLOC, Meister and Bittner 2018, then
/// reinsertion, then the collapse to eight-wide nodes of Ylitie et al. 2017), except that the
/// children are not put in the Morton order that picks a traversal order from the ray's
/// octant: `wide` orders children by their entry distance, and the build is faster without
/// that step (docs/performance.md).
pub(super) fn build_bvh(boxes: &[Aabb]) -> (CwBvh, Duration) {
    if boxes.is_empty() {
        return (CwBvh::default(), Duration::default());
    }
    let start = Instant::now();
    let params = BvhBuildParams::medium_build();
    let untied = untied(boxes);
    let mut bvh2 = PlocBuilder::with_capacity(boxes.len()).build(
        params.ploc_search_distance,
        untied.as_deref().unwrap_or(boxes),
        (0..boxes.len() as u32).collect(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    let bvh = bvh2_to_cwbvh(&bvh2, params.max_prims_per_leaf.clamp(1, 3), false, false);
    (bvh, start.elapsed())
}

/// The boxes PLOC builds over when many are equal: each box of a group of three or more
/// equal ones, but the first, grown on every side by a pseudo-random 1/1024 to 2/1024 of
/// its size. PLOC (Meister and Bittner 2018) merges neighbours in Morton order that choose
/// each other, by the area of their union; boxes all alike tie every cost, one pair merges
/// per pass and the build is quadratic (20,000 copies of one triangle took 7.5 s, 40,000
/// took 78 s). Grown at random, the costs have local minima everywhere again, and the
/// centroids, hence the Morton order, stay. The tree's boxes come from the real ones
/// (`Wide::new`), so only the grouping changes. Pairs (a quad's two triangles) tie
/// harmlessly and are left alone, so that ordinary meshes build as they did. Equal boxes
/// are found by sorting a 64-bit hash of each (a hash collision only grows a box for the
/// build): 35 ms for a million boxes, against 120 ms sorting by the boxes themselves and
/// 200 ms for PLOC itself. None when no group has three.
fn untied(boxes: &[Aabb]) -> Option<Vec<Aabb>> {
    use crate::math::sampler::mix64;
    let hash = |b: &Aabb| {
        [b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z]
            .iter()
            .fold(0u64, |h, x| mix64(h ^ u64::from(x.to_bits())))
    };
    let mut keyed: Vec<(u64, u32)> = boxes.iter().enumerate().map(|(i, b)| (hash(b), i as u32)).collect();
    keyed.sort_unstable();
    let mut out: Option<Vec<Aabb>> = None;
    for group in keyed.chunk_by(|a, b| a.0 == b.0).filter(|g| g.len() >= 3) {
        let out = out.get_or_insert_with(|| boxes.to_vec());
        for &(_, i) in &group[1..] {
            let b = &boxes[i as usize];
            let size = (b.max - b.min).max_element().max(1e-6 * b.min.abs().max(b.max.abs()).max_element());
            let h = (mix64(u64::from(i)) >> 40) as f32 / (1u64 << 24) as f32;
            let grow = Vec3A::splat(size.max(f32::MIN_POSITIVE) * (1.0 + h) / 1024.0);
            out[i as usize] = Aabb::new(b.min - grow, b.max + grow);
        }
    }
    out
}

/// `items` in BVH order (`order` lists the original index of each), the originals dropped.
pub(super) fn reorder<T: Copy>(order: &[u32], items: Vec<T>) -> Vec<T> {
    order.iter().map(|&i| items[i as usize]).collect()
}

/// The box [min, max] padded by 1e-6 of its coordinates' magnitude plus 1e-7 of `size`, the
/// size of everything the BVH holds: a margin beyond the slab test's own rounding bound
/// (`wide`), for rays aimed exactly at a vertex.
pub(super) fn padded_box(min: Vec3, max: Vec3, size: f32) -> Aabb {
    let pad = Vec3::splat(1e-6 * min.abs().max(max.abs()).max_element() + 1e-7 * size);
    Aabb::new((min - pad).into(), (max + pad).into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The depth of the deepest node of `bvh`.
    fn depth(bvh: &CwBvh) -> usize {
        let parents = bvh.compute_parents();
        (0..parents.len())
            .map(|mut i| {
                let mut d = 0;
                while i != 0 {
                    i = parents[i] as usize;
                    d += 1;
                }
                d
            })
            .max()
            .unwrap_or(0)
    }

    #[test]
    fn equal_boxes_build_a_shallow_tree() {
        // One triangle's box 20,000 times: tied merge costs made PLOC merge one pair per
        // pass, in time quadratic in the count, into a tree nearly as deep as a list.
        let one = Aabb::new(Vec3A::ZERO, Vec3A::new(1.0, 1.0, 0.0));
        let (bvh, _) = build_bvh(&vec![one; 20_000]);
        let mut indices = bvh.primitive_indices.clone();
        indices.sort_unstable();
        assert!(indices.iter().copied().eq(0..20_000), "every box is in the tree once");
        // Tied, the tree was 2,856 levels deep; untied, 44 (a balanced 8-wide tree over
        // 20,000 leaves of up to 3 would be 5).
        assert!(depth(&bvh) <= 64, "depth {}", depth(&bvh));
    }
}

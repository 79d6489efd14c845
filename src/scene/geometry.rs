//! The scene's triangles and the queries rays make of them, in two levels (pbrt-v4's
//! instancing, Pharr et al. 2023, section 7.1.4): the triangles placed once, in world space
//! under one BVH, and meshes placed many times, each stored once in its own space under its
//! own BVH, reached through a top-level BVH over their placements, so that memory follows
//! the unique geometry. Every placed triangle still has one global index: the world's
//! triangles first, then each placement's.

use glam::{Affine3A, Mat3A, Vec2, Vec3, Vec4, Vec4Swizzles};
use std::cell::Cell;
use std::time::Duration;

use super::MAX_COORDINATE;
use super::blas::{Blas, build_bvh, padded_box, reorder};
use super::wide::{SlabRay, Wide, bits};
use crate::math::float::gamma;

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
    /// `normals == [ng; 3]`, kept beside them, so that no hit compares nine coordinates.
    flat: bool,
}

impl TriAttrs {
    /// The attributes of a triangle with these vertex normals, texture coordinates, facet
    /// normal and material.
    pub fn new(normals: [Vec3; 3], uvs: [Vec2; 3], ng: Vec3, material: u32) -> Self {
        Self { normals, uvs, ng, material, flat: normals == [ng; 3] }
    }

    /// Every vertex normal is the facet's (none given, or snapped to it when loading): the
    /// triangle shades flat, with nothing to interpolate and no terminator to lift.
    #[inline]
    pub fn is_flat(&self) -> bool {
        self.flat
    }
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

/// Triangles as a scene is built from: positions, attributes and, empty or one per
/// triangle, the optional attributes.
#[derive(Default)]
pub struct Triangles {
    /// Vertex positions.
    pub positions: Vec<[Vec3; 3]>,
    /// Shading attributes.
    pub attrs: Vec<TriAttrs>,
    /// Optional attributes: empty, or one per triangle.
    pub extra: Vec<TriExtra>,
}

/// One placement of a mesh's BVH in the world.
#[derive(Clone, Copy, Debug)]
struct Instance {
    /// Index of the mesh's BVH.
    mesh: u32,
    /// Global index of the placement's first triangle.
    first: u32,
    /// Object to world.
    to_world: Affine3A,
    /// World to object.
    to_object: Affine3A,
    /// Transforms normals to world space: the inverse transpose of the linear part.
    normals: Mat3A,
    /// Sign of the transform's determinant: a mirroring placement flips tangents' handedness.
    handedness: f32,
}

/// All placed triangles and the BVHs over them.
pub struct Geometry {
    /// The triangles placed once, in world space.
    world: Blas,
    /// Meshes placed many times, in their own space.
    meshes: Vec<Blas>,
    /// The meshes' placements, in the top-level BVH's order; `first` increases along it.
    instances: Vec<Instance>,
    /// The top-level BVH over the placements' world bounds.
    tlas: Wide,
    /// Placed triangles in all.
    len: usize,
    /// Time obvhs took to build all the BVHs.
    build_time: Duration,
}

impl Geometry {
    /// Triangles placed once, with no instances.
    pub fn build(positions: Vec<[Vec3; 3]>, attrs: Vec<TriAttrs>, extra: Vec<TriExtra>) -> Self {
        Self::build_instanced(Triangles { positions, attrs, extra }, Vec::new(), &[])
    }

    /// `world`'s triangles in world space, and `meshes` each placed at the transforms
    /// `placements` gives (mesh index, object to world). Placements whose transform cannot
    /// place a mesh (`placeable`), or that name no mesh, are left out. Panics if there are more than
    /// u32::MAX placed triangles (loaders refuse such scenes first).
    pub fn build_instanced(world: Triangles, meshes: Vec<Triangles>, placements: &[(u32, Affine3A)]) -> Self {
        let world = Blas::build(world);
        let meshes: Vec<Blas> = meshes.into_iter().map(Blas::build).collect();
        let instances: Vec<Instance> = placements
            .iter()
            .filter(|(m, t)| meshes.get(*m as usize).is_some_and(|b| !b.is_empty()) && placeable(t))
            .map(|&(mesh, to_world)| Instance {
                mesh,
                first: 0,
                to_world,
                to_object: to_world.inverse(),
                normals: to_world.matrix3.inverse().transpose(),
                handedness: to_world.matrix3.determinant().signum(),
            })
            .collect();
        let boxes: Vec<(Vec3, Vec3)> = instances.iter().map(|i| placed_bounds(&meshes[i.mesh as usize], i)).collect();
        let (lo, hi) = boxes.iter().fold(world.bounds, |(lo, hi), b| (lo.min(b.0), hi.max(b.1)));
        let size = if lo.cmple(hi).all() { (hi - lo).length() } else { 1.0 };
        let padded: Vec<_> = boxes.iter().map(|&(lo, hi)| padded_box(lo, hi, size)).collect();
        let (cwbvh, tlas_time) = build_bvh(&padded);
        let mut instances = reorder(&cwbvh.primitive_indices, instances);
        let tlas = Wide::new(&cwbvh, &reorder(&cwbvh.primitive_indices, padded));
        let mut len = world.len();
        for i in &mut instances {
            i.first = u32::try_from(len).expect("at most u32::MAX placed triangles");
            len += meshes[i.mesh as usize].len();
        }
        assert!(len <= u32::MAX as usize, "at most u32::MAX placed triangles");
        let build_time = world.build_time + meshes.iter().map(|m| m.build_time).sum::<Duration>() + tlas_time;
        Self { world, meshes, instances, tlas, len, build_time }
    }

    /// Number of placed triangles (each placement of a mesh counts all its triangles).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there is no triangle at all.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Triangles stored: the world's and each mesh's once.
    pub fn unique_len(&self) -> usize {
        self.world.len() + self.meshes.iter().map(Blas::len).sum::<usize>()
    }

    /// Placements of meshes (0 when every triangle is placed once).
    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }

    /// Bytes the triangles, their attributes and the BVHs hold.
    pub fn bytes(&self) -> usize {
        let tlas = self.tlas.bytes();
        let instances = self.instances.len() * (std::mem::size_of::<Instance>() + 4);
        self.world.bytes() + self.meshes.iter().map(Blas::bytes).sum::<usize>() + tlas + instances
    }

    /// Meshes stored once for their many placements.
    pub fn instanced_meshes(&self) -> usize {
        self.meshes.len()
    }

    /// How long building the BVHs took.
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// The placement holding global triangle `tri` (past the world's) and the triangle's
    /// index in its mesh.
    fn placement(&self, tri: u32) -> (&Instance, u32) {
        let i = self.instances.partition_point(|i| i.first <= tri) - 1;
        let instance = &self.instances[i];
        (instance, tri - instance.first)
    }

    /// Whether global triangle `tri` is one of the world's (not reached through a placement).
    #[inline(always)]
    fn in_world(&self, tri: u32) -> bool {
        (tri as usize) < self.world.len()
    }

    /// `f` of triangle `tri`'s world-space positions, attributes and optional attributes,
    /// read in place for the world's triangles (no copies on the common path) and made
    /// out of line for placed ones.
    #[inline(always)]
    pub fn with_triangle<R>(&self, tri: u32, f: impl FnOnce(&[Vec3; 3], &TriAttrs, Option<&TriExtra>) -> R) -> R {
        let placed;
        let (p, a, e) = if self.in_world(tri) {
            (self.world.positions(tri), self.world.attrs(tri), self.world.extra(tri))
        } else {
            placed = self.placed_triangle(tri);
            (&placed.0, &placed.1, placed.2.as_ref())
        };
        // One call site, so that `f` is inlined.
        f(p, a, e)
    }

    /// A placed triangle's world-space positions, attributes and optional attributes.
    #[inline(never)]
    fn placed_triangle(&self, tri: u32) -> ([Vec3; 3], TriAttrs, Option<TriExtra>) {
        let (i, t) = self.placement(tri);
        let mesh = &self.meshes[i.mesh as usize];
        (i.positions(mesh, t), i.attrs(mesh, t), i.extra(mesh, t))
    }

    /// World-space vertex positions of triangle `tri`. The world's triangles are read in
    /// line; placed ones are transformed out of line, so that scenes without instances
    /// pay one comparison.
    #[inline(always)]
    pub fn positions(&self, tri: u32) -> [Vec3; 3] {
        if self.in_world(tri) { *self.world.positions(tri) } else { self.placed_positions(tri) }
    }

    #[inline(never)]
    fn placed_positions(&self, tri: u32) -> [Vec3; 3] {
        let (i, t) = self.placement(tri);
        i.positions(&self.meshes[i.mesh as usize], t)
    }

    /// Shading attributes of triangle `tri`, with world-space normals.
    #[inline(always)]
    pub fn attrs(&self, tri: u32) -> TriAttrs {
        if self.in_world(tri) { *self.world.attrs(tri) } else { self.placed_attrs(tri) }
    }

    #[inline(never)]
    fn placed_attrs(&self, tri: u32) -> TriAttrs {
        let (i, t) = self.placement(tri);
        i.attrs(&self.meshes[i.mesh as usize], t)
    }

    /// The optional attributes of triangle `tri` (world-space tangents), if its mesh has any.
    #[inline(always)]
    pub fn extra(&self, tri: u32) -> Option<TriExtra> {
        if self.in_world(tri) { self.world.extra(tri).copied() } else { self.placed_extra(tri) }
    }

    #[inline(never)]
    fn placed_extra(&self, tri: u32) -> Option<TriExtra> {
        let (i, t) = self.placement(tri);
        i.extra(&self.meshes[i.mesh as usize], t)
    }

    /// Every placed triangle's global index and material, in index order, without the
    /// per-triangle lookup of `attrs`.
    pub fn materials(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        let world = self.world.all_attrs().iter().map(|a| a.material);
        let placed =
            self.instances.iter().flat_map(|i| self.meshes[i.mesh as usize].all_attrs().iter().map(|a| a.material));
        world.chain(placed).enumerate().map(|(t, m)| (t as u32, m))
    }

    /// What placing triangle `tri` adds to the error bound of its world-space point `p` at
    /// barycentrics `b` (zero for the world's triangles): the rounding of transforming its
    /// vertices to world space, and of transforming a ray's origin at `p` back to the mesh's
    /// space, carried to world space (pbrt-v4 section 6.8.6, each product and sum rounding
    /// by at most gamma(1) of its magnitude).
    #[inline(always)]
    pub fn placement_error(&self, tri: u32, b: [f32; 3], p: Vec3) -> Vec3 {
        if self.in_world(tri) { Vec3::ZERO } else { self.placed_error(tri, b, p) }
    }

    #[inline(never)]
    fn placed_error(&self, tri: u32, b: [f32; 3], p: Vec3) -> Vec3 {
        let (i, t) = self.placement(tri);
        let q = self.meshes[i.mesh as usize].positions(t);
        let object = (b[0] * q[0]).abs() + (b[1] * q[1]).abs() + (b[2] * q[2]).abs();
        let (m, m_inv) = (abs(i.to_world.matrix3), abs(i.to_object.matrix3));
        let to_world = gamma(4) * (m * object + Vec3::from(i.to_world.translation.abs()));
        let to_object = gamma(4) * (m_inv * p.abs() + Vec3::from(i.to_object.translation.abs()));
        to_world + m * to_object
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

    /// `intersect_with`, ignoring the hits `accept` (global triangle, barycentrics) turns down.
    #[inline(always)]
    pub fn intersect_filtered(
        &self,
        ray: &Ray,
        watertight: bool,
        accept: impl Fn(u32, [f32; 3]) -> bool,
    ) -> Option<Hit> {
        if self.instances.is_empty() {
            self.world.intersect_filtered(ray, watertight, accept)
        } else {
            self.intersect_placed(ray, watertight, accept)
        }
    }

    /// `intersect_filtered` through the world's BVH and then the placements'.
    #[inline(never)]
    fn intersect_placed(&self, ray: &Ray, watertight: bool, accept: impl Fn(u32, [f32; 3]) -> bool) -> Option<Hit> {
        let mut closest = self.world.intersect_filtered(ray, watertight, &accept);
        let bound = Cell::new(closest.map_or(ray.tmax, |h| h.t));
        self.placements_along(ray, &bound, true, |i| {
            let local = i.local_ray(ray, bound.get());
            let hit =
                self.meshes[i.mesh as usize].intersect_filtered(&local, watertight, |t, b| accept(i.first + t, b));
            if let Some(h) = hit.filter(|h| h.t < bound.get()) {
                bound.set(h.t);
                closest = Some(Hit { tri: i.first + h.tri, ..h });
            }
            true
        });
        closest
    }

    /// `occluded_with`, ignoring the hits `accept` turns down.
    #[inline(always)]
    pub fn occluded_filtered(&self, ray: &Ray, watertight: bool, accept: impl Fn(u32, [f32; 3]) -> bool) -> bool {
        if self.instances.is_empty() {
            self.world.occluded_filtered(ray, watertight, accept)
        } else {
            self.occluded_placed(ray, watertight, accept)
        }
    }

    /// `occluded_filtered` through the world's BVH and then the placements'.
    #[inline(never)]
    fn occluded_placed(&self, ray: &Ray, watertight: bool, accept: impl Fn(u32, [f32; 3]) -> bool) -> bool {
        if self.world.occluded_filtered(ray, watertight, &accept) {
            return true;
        }
        let mut blocked = false;
        self.placements_along(ray, &Cell::new(ray.tmax), false, |i| {
            let local = i.local_ray(ray, ray.tmax);
            blocked = self.meshes[i.mesh as usize].occluded_filtered(&local, watertight, |t, b| accept(i.first + t, b));
            !blocked
        });
        blocked
    }

    /// Visits the placements whose bounds the ray enters before `bound`, nearest first if
    /// `ordered`; `visit` may lower `bound` (in ray units), and returns false to stop.
    fn placements_along(&self, ray: &Ray, bound: &Cell<f32>, ordered: bool, mut visit: impl FnMut(&Instance) -> bool) {
        self.tlas.traverse(&SlabRay::new(ray.o, ray.d), bound, ordered, |base, group| {
            bits(group).all(|bit| visit(&self.instances[base as usize + bit]))
        });
    }
}

impl Instance {
    /// World-space positions of triangle `t` of `mesh`, which this instance places.
    fn positions(&self, mesh: &Blas, t: u32) -> [Vec3; 3] {
        mesh.positions(t).map(|p| self.to_world.transform_point3(p))
    }

    /// Attributes of triangle `t` of `mesh`, with world-space normals.
    fn attrs(&self, mesh: &Blas, t: u32) -> TriAttrs {
        let a = mesh.attrs(t);
        let n = |v: Vec3| (self.normals * v).normalize_or_zero();
        // Equal normals map to equal normals: a flat triangle stays flat.
        TriAttrs { normals: a.normals.map(n), ng: n(a.ng), ..*a }
    }

    /// Optional attributes of triangle `t` of `mesh`, with world-space tangents.
    fn extra(&self, mesh: &Blas, t: u32) -> Option<TriExtra> {
        mesh.extra(t).map(|e| {
            let tangent =
                |v: Vec4| self.to_world.transform_vector3(v.xyz()).normalize_or_zero().extend(v.w * self.handedness);
            TriExtra { tangents: e.tangents.map(tangent), ..*e }
        })
    }

    /// The ray in the mesh's space, with the same parameter t (its direction is not
    /// renormalised), up to `tmax`.
    fn local_ray(&self, ray: &Ray, tmax: f32) -> Ray {
        Ray { o: self.to_object.transform_point3(ray.o), d: self.to_object.transform_vector3(ray.d), tmax }
    }
}

/// Whether the transform `t` can place a mesh: every entry finite and within
/// `MAX_COORDINATE` (as vertices must be), and invertible (its determinant finite and not
/// zero). A NaN or 1e38 translation passed the determinant alone and broke the BVH build.
pub fn placeable(t: &Affine3A) -> bool {
    let det = t.matrix3.determinant();
    let entries = [t.matrix3.x_axis, t.matrix3.y_axis, t.matrix3.z_axis, t.translation];
    det != 0.0 && det.is_finite() && entries.iter().all(|c| c.is_finite() && c.abs().max_element() <= MAX_COORDINATE)
}

/// World bounds of `mesh` placed by `instance`: its box's eight corners transformed.
fn placed_bounds(mesh: &Blas, instance: &Instance) -> (Vec3, Vec3) {
    let (lo, hi) = mesh.bounds;
    (0..8).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), k| {
        let corner = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let p = instance.to_world.transform_point3(corner);
        (a.min(p), b.max(p))
    })
}

/// The matrix of absolute values of `m`'s entries.
fn abs(m: Mat3A) -> Mat3A {
    Mat3A::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Geometry {
        let p = [
            [Vec3::new(-1., -1., 0.), Vec3::new(1., -1., 0.), Vec3::new(1., 1., 0.)],
            [Vec3::new(-1., -1., 0.), Vec3::new(1., 1., 0.), Vec3::new(-1., 1., 0.)],
        ];
        let a = TriAttrs::new([Vec3::Z; 3], [Vec2::ZERO; 3], Vec3::Z, 0);
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
    fn placed_triangles_keep_their_front_normals_and_tangent_frames() {
        use glam::Quat;
        let p = [Vec3::new(0.2, 0.1, 0.0), Vec3::new(1.0, 0.3, 0.4), Vec3::new(0.1, 0.9, 0.2)];
        let ng = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        let attrs = TriAttrs::new([ng; 3], [Vec2::ZERO; 3], ng, 0);
        let extra = TriExtra {
            uv1: [Vec2::ZERO; 3],
            colors: [Vec4::ONE; 3],
            tangents: [(p[1] - p[0]).normalize().extend(1.0); 3],
        };
        let mesh = || Triangles { positions: vec![p], attrs: vec![attrs], extra: vec![extra] };
        let turn = Quat::from_rotation_y(0.7);
        let placements = [
            (0, Affine3A::from_scale_rotation_translation(Vec3::new(0.2, 3.0, 1.0), turn, Vec3::X)),
            (0, Affine3A::from_scale_rotation_translation(Vec3::new(-1.0, 0.5, 2.0), turn, -Vec3::X)),
        ];
        let g = Geometry::build_instanced(Triangles::default(), vec![mesh()], &placements);
        assert_eq!((g.len(), g.unique_len(), g.instance_count()), (2, 1, 2));
        // Transforms that are not finite, or place the mesh beyond any coordinate a vertex
        // may have, are left out (they broke the BVH build).
        let hostile = [Vec3::NAN, Vec3::INFINITY, Vec3::splat(1e38)]
            .map(|t| (0, Affine3A::from_translation(t)))
            .into_iter()
            .chain([(0, Affine3A::from_scale(Vec3::new(f32::NAN, 1.0, 1.0))), placements[0]]);
        let kept = Geometry::build_instanced(Triangles::default(), vec![mesh()], &hostile.collect::<Vec<_>>());
        assert_eq!((kept.len(), kept.instance_count()), (1, 1));
        for tri in 0..2 {
            let (q, a) = (g.positions(tri), g.attrs(tri));
            let cross = (q[1] - q[0]).cross(q[2] - q[0]).normalize();
            let t = placements.iter().find(|(_, t)| t.transform_point3(p[0]).abs_diff_eq(q[0], 1e-5)).unwrap().1;
            let mirrored = t.matrix3.determinant() < 0.0;
            // The front face stays on the side of the object's normal, and is perpendicular to
            // the placed triangle: counter-clockwise, or clockwise under a mirroring placement.
            let want = if mirrored { -cross } else { cross };
            assert!(a.ng.abs_diff_eq(want, 1e-5), "{tri}: {} against {want}", a.ng);
            assert!(a.normals[0].abs_diff_eq(want, 1e-5));
            let tangent = g.extra(tri).unwrap().tangents[0];
            assert_eq!(tangent.w, if mirrored { -1.0 } else { 1.0 });
            assert!(tangent.truncate().dot(a.ng).abs() < 1e-5, "the tangent stays in the plane");
        }
    }

    #[test]
    fn the_flat_flag_says_whether_every_vertex_normal_is_the_facets_placed_or_not() {
        use glam::Quat;
        let p = [Vec3::new(0.2, 0.1, 0.0), Vec3::new(1.0, 0.3, 0.4), Vec3::new(0.1, 0.9, 0.2)];
        let ng = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        let bent = (ng + Vec3::new(0.0, 0.1, 0.0)).normalize();
        let flat = TriAttrs::new([ng; 3], [Vec2::ZERO; 3], ng, 0);
        let smooth = TriAttrs::new([ng, bent, ng], [Vec2::ZERO; 3], ng, 0);
        assert!(flat.is_flat() && !smooth.is_flat());
        let mesh = Triangles { positions: vec![p; 2], attrs: vec![flat, smooth], extra: Vec::new() };
        let world = Triangles { positions: vec![p; 2], attrs: vec![flat, smooth], extra: Vec::new() };
        let turn =
            Affine3A::from_scale_rotation_translation(Vec3::new(0.3, 2.0, -1.0), Quat::from_rotation_x(1.1), Vec3::Y);
        let g = Geometry::build_instanced(world, vec![mesh], &[(0, turn)]);
        assert_eq!(g.len(), 4);
        for tri in 0..4 {
            let a = g.attrs(tri);
            assert_eq!(a.is_flat(), a.normals == [a.ng; 3], "{tri}");
        }
        assert_eq!((0..4).filter(|&tri| g.attrs(tri).is_flat()).count(), 2);
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

    #[test]
    fn thousands_of_placements_answer_every_ray_as_their_flattened_copies() {
        use glam::Quat;
        use rand_core::RngCore;
        // A closed tetrahedron placed 3000 times, turned and scaled, in a 40-wide cube.
        let v = [Vec3::new(1., 1., 1.), Vec3::new(1., -1., -1.), Vec3::new(-1., 1., -1.), Vec3::new(-1., -1., 1.)];
        let faces = [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
        let mesh = Triangles {
            positions: faces.iter().map(|f| f.map(|i| v[i])).collect(),
            attrs: faces
                .iter()
                .map(|f| {
                    let ng = (v[f[1]] - v[f[0]]).cross(v[f[2]] - v[f[0]]).normalize();
                    TriAttrs::new([ng; 3], [Vec2::ZERO; 3], ng, 0)
                })
                .collect(),
            extra: Vec::new(),
        };
        let mut rng = rand_pcg::Pcg32::new(5, 3);
        let mut u = move || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        let placements: Vec<(u32, Affine3A)> = (0..3000)
            .map(|_| {
                let turn = Quat::from_euler(glam::EulerRot::XYZ, u() * 6.0, u() * 6.0, u() * 6.0);
                let at = Vec3::new(u(), u(), u()) * 40.0 - 20.0;
                (0, Affine3A::from_scale_rotation_translation(Vec3::splat(0.2 + u()), turn, at))
            })
            .collect();
        let flat = Triangles {
            positions: placements
                .iter()
                .flat_map(|(_, t)| mesh.positions.iter().map(|p| p.map(|q| t.transform_point3(q))))
                .collect(),
            attrs: vec![mesh.attrs[0]; 4 * placements.len()],
            extra: Vec::new(),
        };
        let placed = Geometry::build_instanced(Triangles::default(), vec![mesh], &placements);
        let flat = Geometry::build_instanced(flat, Vec::new(), &[]);
        let (mut hits, mut blocked) = (0, 0);
        for r in 0..4000 {
            let o = Vec3::new(u(), u(), u()) * 50.0 - 25.0;
            let d = Vec3::new(u(), u(), u()) * 2.0 - 1.0;
            let tmax = if r % 2 == 0 { f32::INFINITY } else { 5.0 + 30.0 * u() };
            let ray = Ray { o, d, tmax };
            let (a, b) = (placed.intersect(&ray), flat.intersect(&ray));
            assert_eq!(a.is_some(), b.is_some(), "ray {r}: {a:?} against {b:?}");
            if let (Some(a), Some(b)) = (a, b) {
                assert!((a.t - b.t).abs() <= 1e-4 * (1.0 + b.t), "ray {r}: hit at {} against {}", a.t, b.t);
                hits += 1;
            }
            assert_eq!(placed.occluded(&ray), flat.occluded(&ray), "ray {r}: occlusion");
            blocked += flat.occluded(&ray) as usize;
        }
        assert!(hits > 1000 && blocked > 1000 && blocked < 3900, "{hits} {blocked}");
    }
}

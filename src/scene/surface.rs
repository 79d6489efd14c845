//! Surface points: where rays hit (closest hit and occlusion, consulting alpha and
//! single-sidedness where the scene has them), what a hit point is (position with its error
//! bound, normals, texture coordinates), the points light sampling picks on emitters, and
//! where reflected rays leave from.

use super::geometry::{Hit, Ray, TriAttrs, TriExtra};
use super::material::AlphaMode;
use super::shading::terminator_offset;
use super::texture::ColorSpace;
use super::{Scene, Surface};
use crate::math::float::{gamma, interpolation_error, offset_ray_origin};
use glam::{Vec3, Vec4, Vec4Swizzles};

impl Scene {
    /// Surface data at a hit, with the material's normal map applied to the shading normal.
    pub fn surface(&self, hit: &Hit) -> Surface {
        let b = hit.b;
        let lerp = |v: [Vec4; 3]| v[0] * b[0] + v[1] * b[1] + v[2] * b[2];
        self.geometry.with_triangle(hit.tri, |p, a, extra| {
            let mut surface = self.point_on(hit.tri, b, p, a, extra);
            // Flat triangles keep the facet's normal.
            if !a.is_flat() {
                let ns = (a.normals[0] * b[0] + a.normals[1] * b[1] + a.normals[2] * b[2]).normalize_or_zero();
                if ns != Vec3::ZERO {
                    surface.ns = ns;
                }
            }
            if let Some(e) = extra {
                surface.color = lerp(e.colors);
            }
            if let (Some(e), Some(map)) = (extra, self.materials[a.material as usize].normal_tex) {
                let tangent = lerp(e.tangents);
                let m = map.sample(&self.textures, &self.images, &surface.uv, ColorSpace::Linear).xyz() * 2.0 - 1.0;
                let scale = self.materials[a.material as usize].normal_scale;
                surface.ns = normal_mapped(surface.ns, tangent, m * Vec3::new(scale, scale, 1.0));
            }
            surface
        })
    }

    /// Interpolated tangent at `surface`, the bitangent sign in w; zero where its mesh has
    /// none (only meshes whose material has a normal map, anisotropy or a clearcoat normal
    /// map carry them). With it, the interpolated normal before normal mapping (the
    /// geometric one where the vertex normals cancel).
    pub fn tangent_space(&self, surface: &Surface) -> (Vec4, Vec3) {
        let b = surface.b;
        self.geometry.with_triangle(surface.tri, |_, a, extra| {
            let tangent =
                extra.map_or(Vec4::ZERO, |e| e.tangents[0] * b[0] + e.tangents[1] * b[1] + e.tangents[2] * b[2]);
            let n = a.normals;
            (tangent, (n[0] * b[0] + n[1] * b[1] + n[2] * b[2]).normalize_or(surface.ng))
        })
    }

    /// The point of triangle `tri` at barycentrics `b` as light sampling needs it, and
    /// `surface` starts from: position, its error bound, the geometric normal and the
    /// texture coordinates (for emission textures). The shading normal is the geometric one
    /// and the vertex colour white: no normal map is sampled, since an emitter's sample reads
    /// neither.
    pub fn light_point(&self, tri: u32, b: [f32; 3]) -> Surface {
        self.geometry.with_triangle(tri, |p, a, extra| self.point_on(tri, b, p, a, extra))
    }

    /// What `light_point` gives that a light sample of uniform emission reads: the point,
    /// its error bound, the geometric normal and the material, without the texture
    /// coordinates and the rest of a `Surface`.
    #[inline]
    pub fn light_position(&self, tri: u32, b: [f32; 3]) -> (Vec3, Vec3, Vec3, u32) {
        self.geometry.with_triangle(tri, |p, a, _| {
            let (point, error) = self.position_on(tri, b, p);
            (point, error, a.ng, a.material)
        })
    }

    /// The point of triangle `tri` (vertices `p`) at barycentrics `b`, and its error bound:
    /// the interpolation's and the placement's (pbrt-v4 section 6.8), and on every axis
    /// gamma(16) of the triangle's extent around the point, for the triangle test's own
    /// rounding of a ray that leaves it. The interpolation's bound vanishes along the normal
    /// of a coordinate plane through the origin, where reflections then started on the plane
    /// and a quarter of them found it again; its test in tests/robustness.rs needs 1.5 eps of
    /// the extent, and this is five times that.
    #[inline(always)]
    fn position_on(&self, tri: u32, b: [f32; 3], p: &[Vec3; 3]) -> (Vec3, Vec3) {
        let point = p[0] * b[0] + p[1] * b[1] + p[2] * b[2];
        let extent = (p[0] - point).abs().max((p[1] - point).abs()).max((p[2] - point).abs()).max_element();
        let test = Vec3::splat(gamma(16) * extent);
        (point, interpolation_error(b, *p) + self.geometry.placement_error(tri, b, point) + test)
    }

    /// `light_point` given the triangle's positions and attributes.
    #[inline(always)]
    fn point_on(&self, tri: u32, b: [f32; 3], p: &[Vec3; 3], a: &TriAttrs, extra: Option<&TriExtra>) -> Surface {
        let uv0 = a.uvs[0] * b[0] + a.uvs[1] * b[1] + a.uvs[2] * b[2];
        let uv1 = extra.map_or(uv0, |e| e.uv1[0] * b[0] + e.uv1[1] * b[1] + e.uv1[2] * b[2]);
        let (point, p_error) = self.position_on(tri, b, p);
        Surface {
            p: point,
            p_error,
            ng: a.ng,
            ns: a.ng,
            uv: [uv0, uv1],
            color: Vec4::ONE,
            material: a.material,
            tri,
            b,
        }
    }

    /// Closest hit along the ray. Materials with alpha let rays through where they are
    /// transparent; `camera` rays also pass the back of single-sided materials (what glTF's
    /// doubleSided means for the picture: back-face culling). Only camera rays cull: a path
    /// that turned into a closed single-sided mesh must still be stopped by its far side.
    pub fn intersect(&self, ray: &Ray, watertight: bool, camera: bool) -> Option<Hit> {
        if !self.features.cutouts {
            return self.geometry.intersect_with(ray, watertight);
        }
        self.geometry.intersect_filtered(ray, watertight, |tri, b| self.blocks(ray, tri, b, camera))
    }

    /// Whether anything blocks the ray before `tmax` (alpha as in `intersect`).
    pub fn occluded(&self, ray: &Ray, watertight: bool) -> bool {
        if !self.features.cutouts {
            return self.geometry.occluded_with(ray, watertight);
        }
        self.geometry.occluded_filtered(ray, watertight, |tri, b| self.blocks(ray, tri, b, false))
    }

    /// Whether a candidate hit counts. BLEND alpha is a coin flip hashed from the ray and the
    /// triangle, so the same ray always gets the same answer (determinism).
    fn blocks(&self, ray: &Ray, tri: u32, b: [f32; 3], camera: bool) -> bool {
        let (material, ng) = self.geometry.with_triangle(tri, |_, a, _| (a.material, a.ng));
        let m = &self.materials[material as usize];
        if camera && m.culled_from(ray.d, ng) {
            return false;
        }
        if m.alpha_mode == AlphaMode::Opaque {
            return true;
        }
        let opacity = m.opacity(&self.textures, &self.images, &self.surface(&Hit { tri, t: 0.0, b }));
        match m.alpha_mode {
            AlphaMode::Mask(cutoff) => opacity >= cutoff,
            _ => {
                let key = (ray.o.x.to_bits() as u64) << 32 | ray.d.y.to_bits() as u64;
                let h = crate::math::sampler::hash3(key, (ray.d.x.to_bits() as u64) << 32 | tri as u64, 0xa1fa);
                ((h >> 40) as f32 / (1u64 << 24) as f32) < opacity
            }
        }
    }

    /// Where rays reflected at `surface` leave from, on its front side if `front` (the side
    /// the path arrived from) and its back side otherwise. With `terminator`, the point is
    /// first lifted onto the smooth surface of its vertex normals where that moves it out of
    /// the facet (Hanika 2021); with `offset`, it is then pushed past its floating-point
    /// error. Reflected directions above the shading normal but below the facet start there
    /// too: on a coarse convex mesh they escape, which is what removes the faceted shadow
    /// terminator; elsewhere they hit the facet and count as shadowed.
    pub fn reflection_origin(&self, surface: &Surface, front: bool, terminator: bool, offset: bool) -> Vec3 {
        let ng = if front { surface.ng } else { -surface.ng };
        let (mut p, mut error) = (surface.p, surface.p_error);
        // Flat triangles have nothing to lift.
        let lift = |positions: &[Vec3; 3], attrs: &TriAttrs| {
            (!attrs.is_flat()).then(|| {
                let normals = if front { attrs.normals } else { attrs.normals.map(|n| -n) };
                terminator_offset(p, surface.b, positions, &normals)
            })
        };
        if terminator
            && let Some(lift) = self.geometry.with_triangle(surface.tri, |positions, attrs, _| lift(positions, attrs))
            && lift.dot(ng) > 0.0
        {
            // The sum rounds by at most gamma(1) of its magnitude; lift's own rounding
            // only changes how far the point is lifted, not the side it ends up on.
            error += gamma(2) * (p.abs() + lift.abs());
            p += lift;
        }
        if offset { offset_ray_origin(p, error, ng, ng) } else { p }
    }
}

/// The shading normal `n` perturbed by tangent-space normal `m` (glTF: +x along the
/// tangent, +y along the bitangent sign x n x t); `n` itself where there is no tangent.
pub(super) fn normal_mapped(n: Vec3, tangent: Vec4, m: Vec3) -> Vec3 {
    let t = tangent.xyz() - n * n.dot(tangent.xyz());
    let t = t.normalize_or_zero();
    if t == Vec3::ZERO || !m.is_finite() {
        return n;
    }
    let sign = if tangent.w < 0.0 { -1.0 } else { 1.0 };
    let bitangent = sign * n.cross(t);
    let mapped = (t * m.x + bitangent * m.y + n * m.z).normalize_or_zero();
    if mapped == Vec3::ZERO { n } else { mapped }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{MeshDesc, SceneDesc, material::Material};

    #[test]
    fn flat_triangles_shade_with_their_facet_normal_exactly() {
        // A tilted triangle without normals (flat), and one whose vertex normals fan out.
        let p = vec![Vec3::new(0.1, 0.2, 0.3), Vec3::new(1.7, 0.4, -0.2), Vec3::new(0.3, 1.9, 0.8)];
        let flat =
            MeshDesc { name: "flat".into(), positions: p.clone(), indices: vec![0, 1, 2], ..MeshDesc::default() };
        let fan = [Vec3::new(0.3, 0.1, 1.0), Vec3::new(-0.2, 0.3, 1.0), Vec3::new(0.1, -0.3, 1.0)];
        let smooth = MeshDesc {
            name: "smooth".into(),
            positions: p.iter().map(|v| *v + Vec3::Z * 5.0).collect(),
            normals: Some(fan.to_vec()),
            indices: vec![0, 1, 2],
            ..MeshDesc::default()
        };
        let desc = SceneDesc {
            meshes: vec![flat, smooth],
            materials: vec![Material::lambert("grey", Vec3::splat(0.5))],
            ..SceneDesc::default()
        };
        let scene = Scene::build(desc);
        let is_flat = |t: u32| scene.geometry.positions(t)[0].z < 1.0;
        let (mut rng, mut smooth_seen) = (rand_pcg::Pcg32::new(5, 3), 0);
        for _ in 0..2000 {
            use rand_core::RngCore;
            let mut u = || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
            let (b1, b2) = (u(), u());
            let b = if b1 + b2 > 1.0 { [b1 + b2 - 1.0, 1.0 - b1, 1.0 - b2] } else { [1.0 - b1 - b2, b1, b2] };
            for tri in 0..2 {
                let surface = scene.surface(&Hit { tri, t: 1.0, b });
                if is_flat(tri) {
                    assert_eq!(surface.ns, surface.ng, "a flat triangle at {b:?}");
                } else {
                    let n = fan.map(|n| n.normalize());
                    let want = (n[0] * b[0] + n[1] * b[1] + n[2] * b[2]).normalize();
                    assert!((surface.ns - want).length() < 1e-5 && surface.ns != surface.ng);
                    smooth_seen += 1;
                }
            }
        }
        assert_eq!(smooth_seen, 2000);
    }

    #[test]
    fn normal_maps_tilt_towards_the_tangent_and_mirrored_bitangents_flip() {
        let m = Vec3::new(0.6, 0.0, 0.8);
        assert!((normal_mapped(Vec3::Z, Vec4::new(1.0, 0.0, 0.0, 1.0), m) - m).length() < 1e-6);
        let up = Vec3::new(0.0, 0.6, 0.8);
        assert!((normal_mapped(Vec3::Z, Vec4::new(1.0, 0.0, 0.0, 1.0), up) - up).length() < 1e-6);
        let flipped = normal_mapped(Vec3::Z, Vec4::new(1.0, 0.0, 0.0, -1.0), up);
        assert!((flipped - Vec3::new(0.0, -0.6, 0.8)).length() < 1e-6, "{flipped}");
        assert_eq!(normal_mapped(Vec3::Z, Vec4::ZERO, m), Vec3::Z, "no tangent: no mapping");
    }
}

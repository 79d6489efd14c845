//! Emissive triangles as lights: a point chosen uniformly on the triangle's area, its
//! density converted to solid angle, and each triangle's power for choosing among lights
//! (a textured emitter weighted by its texture over the triangle's footprint).

use super::{LightLeSample, LightSample, LightTarget};
use crate::math::{float::offset_ray_origin, frame::Frame, luminance, warp};
use crate::scene::geometry::Geometry;
use crate::scene::geometry::Ray;
use crate::scene::material::{Material, TexRef};
use crate::scene::texture::{ColorSpace, Image, Texture};
use crate::scene::{Scene, Surface};
use glam::{Vec2, Vec3};

/// An emissive triangle (BVH order), its area and its power.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleLight {
    /// The triangle.
    pub tri: u32,
    /// Its area.
    pub area: f32,
    /// Emitted power (luminance): pi times the area times the mean emitted luminance, a
    /// textured emitter's over its footprint (`Emitters`).
    pub power: f32,
}

impl TriangleLight {
    /// A point on the triangle for the uniforms `u` as seen from `p`, with the probability
    /// `pmf` of having chosen the triangle folded into the solid-angle density. None from
    /// behind, where the triangle emits nothing.
    pub fn sample_li(&self, scene: &Scene, p: Vec3, u: Vec2, pmf: f32) -> Option<LightSample> {
        let b = warp::uniform_triangle(u);
        let (q, error, ng, material) = scene.light_position(self.tri, b);
        let to_light = q - p;
        let dist2 = to_light.length_squared();
        let wi = to_light / dist2.sqrt();
        let cos_light = -wi.dot(ng);
        if cos_light <= 0.0 || !wi.is_finite() {
            return None;
        }
        let radiance = match scene.materials[material as usize].uniform_emission() {
            Some(radiance) => radiance,
            None => scene.emission(&scene.light_point(self.tri, b)),
        };
        let pdf = pmf * dist2 / (cos_light * self.area);
        let target = LightTarget::Surface { p: q, error, n: ng };
        Some(LightSample { wi, radiance, pdf, target, is_delta: false })
    }
}

impl TriangleLight {
    /// A ray leaving the triangle's front: a point uniform over its area (`u_pos`) and a
    /// cosine-weighted direction about its normal (`u_dir`), Lambertian emission's.
    pub fn sample_le(&self, scene: &Scene, u_pos: Vec2, u_dir: Vec2) -> Option<LightLeSample> {
        // The whole surface point (not `light_position`, which `sample_li` alone calls so
        // that it stays inlined there).
        let surface = scene.light_point(self.tri, warp::uniform_triangle(u_pos));
        let (local, ng) = (warp::cos_hemisphere(u_dir), surface.ng);
        let d = Frame::from_normal(ng).to_world(local);
        let radiance = scene.emission(&surface);
        if radiance.is_black() || local.z <= 0.0 || !d.is_finite() {
            return None;
        }
        let ray = Ray { o: offset_ray_origin(surface.p, surface.p_error, ng, d), d, tmax: f32::INFINITY };
        let (pdf_pos, pdf_dir) = (1.0 / self.area, warp::cos_hemisphere_pdf(local.z));
        Some(LightLeSample { ray, n: Some(ng), radiance, pdf_pos, pdf_dir })
    }

    /// `sample_le`'s densities for a ray leaving along `w` from a point of normal `n`.
    pub fn pdf_le(&self, n: Vec3, w: Vec3) -> (f32, f32) {
        let cos = n.dot(w);
        (1.0 / self.area, if cos > 0.0 { warp::cos_hemisphere_pdf(cos) } else { 0.0 })
    }
}

/// The solid-angle density with which `sample_li` finds the point `surface` of a triangle
/// of choice probability `pmf` and area `area`, reached along `-wo` after `distance`.
pub(super) fn pdf_li(surface: &Surface, wo: Vec3, distance: f32, pmf: f32, area: f32) -> f32 {
    let cos_light = surface.ng.dot(wo);
    // Surfaces that emit nothing light sampling could choose have no area here.
    if pmf == 0.0 { 0.0 } else { pmf * distance * distance / (cos_light * area) }
}

/// The emissive triangles as lights, and the area of each emissive triangle by index (empty
/// without any): integrating a textured emitter over its triangles is most of building a
/// light sampler, and a new environment or punctual light changes none of it.
#[derive(Default)]
pub(crate) struct Emitters {
    pub(crate) lights: Vec<TriangleLight>,
    pub(crate) areas: Vec<f32>,
}

impl Emitters {
    pub(crate) fn new(geometry: &Geometry, materials: &[Material], textures: &[Texture], images: &[Image]) -> Self {
        let mean_emission: Vec<f32> = materials
            .iter()
            .map(|m| {
                if m.unlit {
                    return 0.0;
                }
                let tex = m.emissive_tex.map_or(Vec3::ONE, |t| {
                    images[textures[t.texture as usize].image as usize].mean(ColorSpace::Srgb).truncate()
                });
                luminance(m.emitted() * tex)
            })
            .collect();
        let mut emitters = Self::default();
        for (t, material) in geometry.materials() {
            let material = material as usize;
            let le = mean_emission[material];
            if le > 0.0 {
                let p = geometry.positions(t);
                let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
                let le = match materials[material].emissive_tex {
                    // A textured emitter is weighted by its texture over the triangle's UV
                    // footprint, mixed with a tenth of the texture's mean so that every triangle
                    // that may emit keeps a chance (explicit light sampling counts no other way).
                    Some(tex) => {
                        let uv = triangle_uvs(geometry, t, tex.set);
                        let footprint = footprint_emission(materials[material].emitted(), tex, uv, textures, images);
                        0.9 * footprint + 0.1 * le
                    }
                    None => le,
                };
                emitters.lights.push(TriangleLight { tri: t, area, power: std::f32::consts::PI * area * le });
                if emitters.areas.is_empty() {
                    emitters.areas = vec![0.0; geometry.len()];
                }
                emitters.areas[t as usize] = area;
            }
        }
        emitters
    }
}

/// Texture coordinates of `set` (0 or 1) at the corners of triangle `t`.
fn triangle_uvs(geometry: &Geometry, t: u32, set: u8) -> [Vec2; 3] {
    match (set, geometry.extra(t)) {
        (1, Some(extra)) => extra.uv1,
        _ => geometry.attrs(t).uvs,
    }
}

/// Mean emitted luminance over a triangle with corner texture coordinates `uv`: `emitted`
/// times the texture at the centroids of the 16 equal-area cells of the triangle cut four
/// ways along each edge.
fn footprint_emission(emitted: Vec3, tex: TexRef, uv: [Vec2; 3], textures: &[Texture], images: &[Image]) -> f32 {
    const N: usize = 4;
    let at = |a: f32, b: f32| {
        let p = uv[0] + (uv[1] - uv[0]) * a + (uv[2] - uv[0]) * b;
        luminance(emitted * tex.sample(textures, images, &[p, p], ColorSpace::Srgb).truncate())
    };
    let mut sum = 0.0;
    for i in 0..N {
        for j in 0..N - i {
            let (a, b) = (i as f32, j as f32);
            sum += at((a + 1.0 / 3.0) / N as f32, (b + 1.0 / 3.0) / N as f32);
            if i + j + 1 < N {
                sum += at((a + 2.0 / 3.0) / N as f32, (b + 2.0 / 3.0) / N as f32);
            }
        }
    }
    sum / (N * N) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::environment::{EnvSettings, Environment};
    use crate::scene::texture::{Texels, Wrap};
    use crate::scene::{MeshDesc, SceneDesc};

    /// Two emissive triangles of one area, at z = 0 and z = 1, mapped into the white left half
    /// and the black right half of a 16x1 emissive texture.
    fn screen_scene() -> Scene {
        // A 16x1 emissive texture, white on its left half and black on its right; two
        // triangles of one area, one mapped into each half.
        let texels = (0..16).map(|x| if x < 8 { [255, 255, 255, 255] } else { [0, 0, 0, 255] }).collect();
        let tri = |u0: f32, z: f32| MeshDesc {
            name: "emitter".into(),
            positions: vec![Vec3::new(0.0, 0.0, z), Vec3::new(1.0, 0.0, z), Vec3::new(0.0, 1.0, z)],
            uvs: Some(vec![Vec2::new(u0, 0.1), Vec2::new(u0 + 0.4, 0.1), Vec2::new(u0, 0.9)]),
            indices: vec![0, 1, 2],
            ..MeshDesc::default()
        };
        let emitter = Material {
            emissive: Vec3::ONE,
            emissive_tex: Some(TexRef::plain(0)),
            ..Material::lambert("screen", Vec3::ZERO)
        };
        let desc = SceneDesc {
            meshes: vec![tri(0.05, 0.0), tri(0.55, 1.0)],
            materials: vec![emitter],
            textures: vec![Texture { name: "t".into(), image: 0, wrap: [Wrap::Repeat; 2], nearest: false }],
            images: vec![Image { width: 16, height: 1, texels: Texels::Bytes(texels) }],
            ..SceneDesc::default()
        };
        Scene::build(desc)
    }

    /// The light sampler's probability of the screen's triangle at `z`.
    fn screen_pmf(scene: &Scene, z: f32) -> f32 {
        let t = (0..scene.geometry.len() as u32).find(|&t| scene.geometry.positions(t)[0].z == z).unwrap();
        scene.light_sampler.triangle_pmf(t)
    }

    #[test]
    fn textured_emitters_are_chosen_by_the_texture_over_their_footprint() {
        let scene = screen_scene();
        let pmf = |z: f32| screen_pmf(&scene, z);
        // White footprint: 0.9 x 1 + 0.1 x 0.5 (the texture's mean); black: 0.1 x 0.5.
        assert!((pmf(0.0) / pmf(1.0) - 19.0).abs() < 1e-3, "{} {}", pmf(0.0), pmf(1.0));
        assert!((pmf(0.0) + pmf(1.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn a_new_environment_keeps_the_emitters_and_edits_recompute_them() {
        let scene = screen_scene();
        let lit = scene.with_environment(Some(Environment::load(EnvSettings::built_in()).unwrap()));
        let env = lit.light_sampler.environment_pmf();
        assert!(env > 0.0 && env < 1.0, "{env}");
        for z in [0.0, 1.0] {
            let (before, after) = (screen_pmf(&scene, z), screen_pmf(&lit, z));
            assert!((after / before - (1.0 - env)).abs() < 1e-5, "z = {z}: {before} then {after}");
        }
        // Edits keep the emitters while the materials stay, and integrate them again from
        // the new materials otherwise: the same materials give the same probabilities.
        let edited = lit.with_edits(lit.materials.clone(), lit.lights.clone());
        for z in [0.0, 1.0] {
            assert_eq!(screen_pmf(&edited, z).to_bits(), screen_pmf(&lit, z).to_bits(), "z = {z}");
        }
        // A black screen emits nothing: the edit leaves the environment alone to sample.
        let mut dark = lit.materials.clone();
        dark[0].emissive = Vec3::ZERO;
        let dark = lit.with_edits(dark, lit.lights.clone());
        assert_eq!((screen_pmf(&dark, 0.0), dark.light_sampler.environment_pmf()), (0.0, 1.0));
    }
}

//! Lights: KHR_lights_punctual lights, and a sampler that picks among all lights
//! (emissive triangles, punctual lights, the environment) in proportion to their power,
//! and the interface the integrators sample lights through: `Scene::sample_li` beside its
//! density `Scene::pdf_li` (pbrt-v4's `Light::SampleLi` and `PDF_Li`). Shadow rays are
//! the integrator's: a sample says where its shadow ray ends.

use super::{Scene, Surface};
use crate::math::{distribution::AliasTable, luminance, warp};
use crate::spectrum::Spectrum;
use glam::{DMat4, Vec2, Vec3};

/// A spot light's cone: the glTF angles from its axis, and one minus their cosines, in
/// which the falloff is computed (1 - cos keeps its precision for cones of a fraction of a
/// degree, where cos itself rounds to within a few units of 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    inner: f32,
    outer: f32,
    vers_inner: f32,
    vers_outer: f32,
}

/// 1 - cos(theta) = 2 sin^2(theta / 2), without the cancellation of the first form.
fn versine(theta: f32) -> f32 {
    2.0 * (0.5 * theta).sin().powi(2)
}

/// 1 - cos of the angle between unit vectors `w` and `axis`: sin^2 / (1 + cos) on the
/// axis's side, where 1 - w.axis would cancel.
fn versine_between(w: Vec3, axis: Vec3) -> f32 {
    let cos = w.dot(axis);
    if cos > 0.0 { w.cross(axis).length_squared() / (1.0 + cos) } else { 1.0 - cos }
}

impl Cone {
    /// The cone of innerConeAngle `inner` and outerConeAngle `outer` (radians).
    pub fn new(inner: f32, outer: f32) -> Self {
        Self { inner, outer, vers_inner: versine(inner), vers_outer: versine(outer) }
    }

    /// KHR_lights_punctual's falloff towards a direction `vers` = 1 - cos(angle) off the
    /// axis: 1 inside the inner cone, 0 outside the outer one, and between them the square
    /// of the linear ramp in cos (the extension's smooth falloff). Equal angles make a hard
    /// edge; no floor on the ramp's width, so a narrow cone keeps its full intensity inside.
    pub fn falloff(&self, vers: f32) -> f32 {
        if vers <= self.vers_inner {
            1.0
        } else if vers >= self.vers_outer {
            0.0
        } else {
            let t = (self.vers_outer - vers) / (self.vers_outer - self.vers_inner);
            t * t
        }
    }

    /// The falloff's integral over the sphere of directions (steradians): 2 pi times
    /// (1 - cos inner) for the full inner cone, plus a third of the ring's (cos inner - cos
    /// outer), the integral of t^2 over the ramp.
    pub fn solid_angle(&self) -> f32 {
        2.0 * std::f32::consts::PI * (self.vers_inner + (self.vers_outer - self.vers_inner) / 3.0)
    }

    /// innerConeAngle: full intensity inside it (radians).
    pub fn inner(&self) -> f32 {
        self.inner
    }

    /// outerConeAngle: no light outside it (radians).
    pub fn outer(&self) -> f32 {
        self.outer
    }
}

/// The kind of a KHR_lights_punctual light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PunctualKind {
    /// Point light: `intensity` is radiant intensity (glTF candela, used 1:1) in all directions.
    Point,
    /// Spot light with the glTF smooth cone falloff between the two angles.
    Spot(Cone),
    /// Directional light: `intensity` is irradiance (glTF lux, used 1:1) on a facing surface.
    Directional,
}

/// Where a punctual light came from in its glTF file, to write edits back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSource {
    /// Index in the file's KHR_lights_punctual lights.
    pub light: u32,
    /// The node that places it.
    pub node: u32,
    /// From the node's parent's space to the scene's space (the file's world space moved as
    /// the loader centres the scene): a position p in the scene is the local translation
    /// `parent.inverse() * p`.
    pub parent: DMat4,
}

/// A punctual light placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct PunctualLight {
    /// Name from the file.
    pub name: String,
    /// What kind of light it is.
    pub kind: PunctualKind,
    /// World position (unused for directional lights).
    pub position: Vec3,
    /// Unit direction the light shines along (the node's -z axis).
    pub direction: Vec3,
    /// Linear RGB colour (glTF color).
    pub color: Vec3,
    /// glTF intensity: candela for point and spot lights, lux for directional ones.
    pub intensity: f32,
    /// KHR_lights_punctual `range` of a point or spot light: the distance at which its
    /// intensity reaches zero (None: infinite, the inverse square alone).
    pub range: Option<f32>,
    /// Where it is in its file (None: not from a file).
    pub source: Option<LightSource>,
}

impl PunctualLight {
    /// Colour times intensity: radiant intensity (or irradiance, for directional lights) per channel.
    pub fn emitted(&self) -> Vec3 {
        self.color * self.intensity
    }

    /// Radiant intensity (or irradiance, for directional) towards unit direction `w`
    /// leaving the light, with a spot's cone falloff (`Cone::falloff`).
    pub fn intensity_towards(&self, w: Vec3) -> Spectrum {
        let intensity = Spectrum::from_illuminant_rgb(self.emitted());
        match self.kind {
            PunctualKind::Spot(cone) => intensity * cone.falloff(versine_between(w, self.direction)),
            _ => intensity,
        }
    }

    /// The window KHR_lights_punctual recommends for `range`, by which the inverse-square
    /// falloff is scaled at squared distance `dist2`: `clamp(1 - (d / range)^4, 0, 1)`
    /// (1 without a range).
    pub fn range_window(&self, dist2: f32) -> f32 {
        self.range.map_or(1.0, |r| (1.0 - (dist2 / (r * r)).powi(2)).clamp(0.0, 1.0))
    }

    /// Total emitted power (luminance-weighted), used to choose lights.
    /// `scene_radius` sizes the disc a directional light covers.
    pub fn power(&self, scene_radius: f32) -> f32 {
        let i = luminance(self.emitted());
        match self.kind {
            PunctualKind::Point => 4.0 * std::f32::consts::PI * i,
            PunctualKind::Spot(cone) => cone.solid_angle() * i,
            PunctualKind::Directional => std::f32::consts::PI * scene_radius * scene_radius * i,
        }
    }
}

/// One light the sampler can choose.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LightRef {
    /// An emissive triangle (BVH order).
    Triangle(u32),
    /// A punctual light (index into the scene's punctual lights).
    Punctual(u32),
    /// The environment.
    Environment,
}

/// Chooses a light with probability proportional to its power, in constant time (an alias
/// table: scenes with many emissive triangles do not pay a binary search per shadow ray).
#[derive(Default)]
pub struct LightSampler {
    lights: Vec<LightRef>,
    table: AliasTable,
    /// Per triangle: the probability of choosing it and its area (empty without emitters).
    triangles: Vec<TriangleLight>,
    environment_pmf: f32,
}

/// What light sampling and MIS read of an emissive triangle, kept beside each other.
#[derive(Clone, Copy, Default)]
struct TriangleLight {
    pmf: f32,
    area: f32,
}

impl LightSampler {
    /// Builds the distribution from (light, power) pairs; lights of zero power are
    /// never chosen. `areas` holds, per triangle, the area of each emissive one (empty
    /// without any); it sizes the per-triangle lookup used by MIS.
    pub fn new(candidates: Vec<(LightRef, f32)>, areas: &[f32]) -> Self {
        let candidates: Vec<_> = candidates.into_iter().filter(|&(_, p)| p > 0.0 && p.is_finite()).collect();
        let weights: Vec<f64> = candidates.iter().map(|&(_, p)| p as f64).collect();
        let Some(table) = AliasTable::new(&weights) else { return Self::default() };
        let mut sampler = Self { lights: Vec::with_capacity(candidates.len()), table, ..Self::default() };
        for (i, &(light, _)) in candidates.iter().enumerate() {
            sampler.lights.push(light);
            let pmf = sampler.table.pmf(i);
            match light {
                LightRef::Triangle(t) => {
                    if sampler.triangles.is_empty() {
                        sampler.triangles = areas.iter().map(|&area| TriangleLight { pmf: 0.0, area }).collect();
                    }
                    sampler.triangles[t as usize].pmf = pmf;
                }
                LightRef::Environment => sampler.environment_pmf = pmf,
                LightRef::Punctual(_) => {}
            }
        }
        sampler
    }

    /// Whether there is no light to sample.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Number of lights with non-zero power.
    pub fn len(&self) -> usize {
        self.lights.len()
    }

    /// Picks a light for the uniform numbers `u`; returns it with its probability.
    pub fn sample(&self, u: Vec2) -> Option<(LightRef, f32)> {
        if self.lights.is_empty() {
            return None;
        }
        let (i, pmf) = self.table.sample(u);
        Some((self.lights[i], pmf))
    }

    /// Probability that `sample` picks emissive triangle `tri` (0 for non-emitters).
    pub fn triangle_pmf(&self, tri: u32) -> f32 {
        self.triangle(tri).pmf
    }

    /// Emissive triangle `tri`'s choice probability and area (zeros for non-emitters).
    #[inline]
    fn triangle(&self, tri: u32) -> TriangleLight {
        self.triangles.get(tri as usize).copied().unwrap_or_default()
    }

    /// Probability that `sample` picks the environment.
    pub fn environment_pmf(&self) -> f32 {
        self.environment_pmf
    }
}

/// Where a shadow ray towards a light sample ends.
#[derive(Clone, Copy, Debug)]
pub enum LightTarget {
    /// A point on an emitting surface, known to within `error`, with front normal `n`: the
    /// ray stops short of it by that bound.
    Surface {
        /// The point.
        p: Vec3,
        /// Absolute error bound on `p`, per coordinate.
        error: Vec3,
        /// The emitter's geometric normal.
        n: Vec3,
    },
    /// A point light's position.
    Point(Vec3),
    /// Infinitely far along the sample's direction (directional lights, the environment).
    Infinite,
}

/// A light sample for a reference point (pbrt-v4's `LightLiSample`).
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit world direction from the reference point towards the light.
    pub wi: Vec3,
    /// Radiance arriving along `wi` (for delta lights, intensity / d^2 or irradiance).
    pub radiance: Spectrum,
    /// Density of `wi` in solid angle, including the probability of choosing the light;
    /// for delta lights only that probability.
    pub pdf: f32,
    /// Where the shadow ray ends.
    pub target: LightTarget,
    /// The light is a delta (point, spot, directional): BSDF sampling cannot find it.
    pub is_delta: bool,
}

/// Light a BSDF-sampled ray found, for `Scene::pdf_li`.
#[derive(Clone, Copy, Debug)]
pub enum LightHit<'a> {
    /// An emitting surface reached at `distance` (in units of the ray's direction) by a ray
    /// travelling along `-wo`.
    Emitter {
        /// The surface point.
        surface: &'a Surface,
        /// Direction back along the ray.
        wo: Vec3,
        /// Distance travelled from the last scattering vertex.
        distance: f32,
    },
    /// The environment, along this unit direction.
    Escaped(Vec3),
}

impl Scene {
    /// Radiance emitted by the front of `surface` (the same in every direction).
    pub fn emission(&self, surface: &Surface) -> Spectrum {
        self.materials[surface.material as usize].emission(&self.textures, &self.images, surface)
    }

    /// Samples a light, in proportion to power, and a point or direction on it for
    /// reference point `p`, from the uniforms `u_select` (which light) and `u` (where on it).
    /// None where the sample carries no light (the back of an emitter, a spot's outside).
    pub fn sample_li(&self, p: Vec3, u_select: Vec2, u: Vec2) -> Option<LightSample> {
        let (light, pmf) = self.light_sampler.sample(u_select)?;
        match light {
            LightRef::Triangle(tri) => {
                let b = warp::uniform_triangle(u);
                let (q, error, ng, material) = self.light_position(tri, b);
                let to_light = q - p;
                let dist2 = to_light.length_squared();
                let wi = to_light / dist2.sqrt();
                let cos_light = -wi.dot(ng);
                if cos_light <= 0.0 || !wi.is_finite() {
                    return None;
                }
                let radiance = match self.materials[material as usize].uniform_emission() {
                    Some(radiance) => radiance,
                    None => self.emission(&self.light_point(tri, b)),
                };
                let pdf = pmf * dist2 / (cos_light * self.light_sampler.triangle(tri).area);
                let target = LightTarget::Surface { p: q, error, n: ng };
                Some(LightSample { wi, radiance, pdf, target, is_delta: false })
            }
            LightRef::Punctual(i) => {
                let light = &self.lights[i as usize];
                let (wi, radiance, target) = match light.kind {
                    PunctualKind::Directional => {
                        (-light.direction, Spectrum::from_illuminant_rgb(light.emitted()), LightTarget::Infinite)
                    }
                    _ => {
                        let to_light = light.position - p;
                        let dist2 = to_light.length_squared();
                        let wi = to_light / dist2.sqrt();
                        let radiance = light.intensity_towards(-wi) * (light.range_window(dist2) / dist2);
                        (wi, radiance, LightTarget::Point(light.position))
                    }
                };
                if radiance.is_black() || !wi.is_finite() {
                    return None;
                }
                Some(LightSample { wi, radiance, pdf: pmf, target, is_delta: true })
            }
            LightRef::Environment => {
                let (wi, radiance, pdf) = self.environment.as_ref()?.sample(u)?;
                if radiance.is_black() {
                    return None;
                }
                Some(LightSample { wi, radiance, pdf: pmf * pdf, target: LightTarget::Infinite, is_delta: false })
            }
        }
    }

    /// Density with which `sample_li` would have sampled the light `hit` (solid angle,
    /// including the choice of the light), for MIS with the BSDF sample that found it.
    pub fn pdf_li(&self, hit: LightHit) -> f32 {
        match hit {
            LightHit::Emitter { surface, wo, distance: t } => {
                let cos_light = surface.ng.dot(wo);
                // Surfaces that emit nothing light sampling could choose have no area here.
                let TriangleLight { pmf, area } = self.light_sampler.triangle(surface.tri);
                if pmf == 0.0 { 0.0 } else { pmf * t * t / (cos_light * area) }
            }
            LightHit::Escaped(d) => match &self.environment {
                Some(env) => self.light_sampler.environment_pmf() * env.pdf(d),
                None => 0.0,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_lights_in_proportion_to_power() {
        let s = LightSampler::new(
            vec![
                (LightRef::Triangle(0), 1.0),
                (LightRef::Punctual(0), 2.0),
                (LightRef::Triangle(2), 0.0),
                (LightRef::Environment, 1.0),
            ],
            &[1.0, 1.0, 1.0],
        );
        assert_eq!(s.len(), 3);
        let mut counts = std::collections::HashMap::new();
        // A grid of midpoints with whole columns per light: the shares are exact.
        let (nx, ny) = (3 * 64, 64);
        for i in 0..nx {
            for j in 0..ny {
                let u = Vec2::new((i as f32 + 0.5) / nx as f32, (j as f32 + 0.5) / ny as f32);
                let (light, pmf) = s.sample(u).unwrap();
                assert_eq!(pmf, if light == LightRef::Punctual(0) { 0.5 } else { 0.25 });
                *counts.entry(light).or_insert(0) += 1;
            }
        }
        assert_eq!(counts[&LightRef::Punctual(0)], nx * ny / 2);
        assert_eq!(counts[&LightRef::Environment], nx * ny / 4);
        assert_eq!(s.triangle_pmf(0), 0.25);
        assert_eq!(s.triangle_pmf(2), 0.0);
        assert_eq!(s.environment_pmf(), 0.25);
    }

    #[test]
    fn spot_falloff_is_full_inside_and_zero_outside() {
        let l = PunctualLight {
            name: "s".into(),
            kind: PunctualKind::Spot(Cone::new(0.9f32.acos(), 0.8f32.acos())),
            position: Vec3::ZERO,
            direction: -Vec3::Z,
            color: Vec3::ONE,
            intensity: 1.0,
            range: None,
            source: None,
        };
        assert_eq!(l.intensity_towards(-Vec3::Z), Spectrum::ONE);
        assert_eq!(l.intensity_towards(Vec3::X), Spectrum::ZERO);
        let mid = l.intensity_towards(Vec3::new(0.0, (1.0f32 - 0.85 * 0.85).sqrt(), -0.85)).to_rgb().x;
        assert!((mid - 0.25).abs() < 1e-3);
    }

    fn spot(inner: f32, outer: f32) -> PunctualLight {
        PunctualLight {
            name: "s".into(),
            kind: PunctualKind::Spot(Cone::new(inner, outer)),
            position: Vec3::ZERO,
            direction: -Vec3::Z,
            color: Vec3::ONE,
            intensity: 1.0,
            range: None,
            source: None,
        }
    }

    /// The direction `theta` off the axis -z.
    fn off_axis(theta: f64) -> Vec3 {
        Vec3::new(theta.sin() as f32, 0.0, -theta.cos() as f32)
    }

    #[test]
    fn narrow_spots_are_full_inside_their_inner_cone_and_equal_angles_cut_hard() {
        let degree = 1f64.to_radians();
        for (inner, outer) in [(0.003, 0.004), (0.1 * degree, 0.2 * degree), (0.0, 1e-4), (0.3, 0.30001)] {
            let l = spot(inner as f32, outer as f32);
            for f in [0.0, 0.5, 0.99] {
                assert_eq!(l.intensity_towards(off_axis(f * inner)), Spectrum::ONE, "{inner}..{outer} at {f} x inner");
            }
            // Half-way in cos between the cones: (1/2)^2 of the intensity.
            let mid = (0.5 * (inner.cos() + outer.cos())).acos();
            let at_mid = l.intensity_towards(off_axis(mid)).to_rgb().x;
            assert!((at_mid - 0.25).abs() < 0.02, "{inner}..{outer}: {at_mid} half-way");
            assert_eq!(l.intensity_towards(off_axis(outer * 1.01)), Spectrum::ZERO);
        }
        let hard = spot(0.01, 0.01);
        assert_eq!(hard.intensity_towards(off_axis(0.00999)), Spectrum::ONE);
        assert_eq!(hard.intensity_towards(off_axis(0.01001)), Spectrum::ZERO);
    }

    #[test]
    fn a_spots_power_is_the_integral_of_its_falloff() {
        let degree = 1f64.to_radians();
        for (inner, outer) in
            [(0.003, 0.004), (0.1 * degree, 0.2 * degree), (0.0, 0.5), (0.4, 0.4), (0.2, 1.5), (1.0, 3.0)]
        {
            let l = spot(inner as f32, outer as f32);
            // Midpoint rule in theta over [0, outer]; the azimuth is uniform.
            let n = 200_000;
            let dt = outer / n as f64;
            let integral: f64 = (0..n)
                .map(|k| {
                    let theta = (k as f64 + 0.5) * dt;
                    l.intensity_towards(off_axis(theta)).to_rgb().x as f64 * theta.sin() * dt
                })
                .sum::<f64>()
                * 2.0
                * std::f64::consts::PI;
            let power = l.power(1.0) as f64;
            assert!((power / integral - 1.0).abs() < 1e-3, "{inner}..{outer}: power {power:e}, integral {integral:e}");
        }
    }

    #[test]
    fn the_range_window_is_one_at_the_light_and_zero_from_the_range_on() {
        let l = |range| PunctualLight {
            name: "p".into(),
            kind: PunctualKind::Point,
            position: Vec3::ZERO,
            direction: -Vec3::Z,
            color: Vec3::ONE,
            intensity: 1.0,
            range,
            source: None,
        };
        assert_eq!(l(None).range_window(1e6), 1.0);
        let ranged = l(Some(2.0));
        assert_eq!(ranged.range_window(0.0), 1.0);
        assert_eq!(ranged.range_window(1.0), 1.0 - 1.0 / 16.0, "d = range / 2");
        assert_eq!(ranged.range_window(4.0), 0.0);
        assert_eq!(ranged.range_window(9.0), 0.0);
    }
}

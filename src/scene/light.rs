//! Lights: KHR_lights_punctual lights, and a sampler that picks among all lights
//! (emissive triangles, punctual lights, the environment) in proportion to their power.

use crate::math::{distribution::AliasTable, luminance};
use glam::{Vec2, Vec3};

/// The kind of a KHR_lights_punctual light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PunctualKind {
    /// Point light: `intensity` is radiant intensity (glTF candela, used 1:1) in all directions.
    Point,
    /// Spot light with the glTF smooth cone falloff between the two cosines.
    Spot {
        /// Cosine of the inner cone angle (full intensity inside).
        cos_inner: f32,
        /// Cosine of the outer cone angle (no light outside).
        cos_outer: f32,
    },
    /// Directional light: `intensity` is irradiance (glTF lux, used 1:1) on a facing surface.
    Directional,
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
    /// Colour times intensity (linear RGB).
    pub intensity: Vec3,
}

impl PunctualLight {
    /// Radiant intensity (or irradiance, for directional) towards unit direction `w`
    /// leaving the light. Spot falloff follows the KHR_lights_punctual reference formula.
    pub fn intensity_towards(&self, w: Vec3) -> Vec3 {
        match self.kind {
            PunctualKind::Spot { cos_inner, cos_outer } => {
                let scale = 1.0 / (cos_inner - cos_outer).max(1e-4);
                let a = ((w.dot(self.direction) - cos_outer) * scale).clamp(0.0, 1.0);
                self.intensity * a * a
            }
            _ => self.intensity,
        }
    }

    /// Total emitted power (luminance-weighted), used to choose lights.
    /// `scene_radius` sizes the disc a directional light covers.
    pub fn power(&self, scene_radius: f32) -> f32 {
        let i = luminance(self.intensity);
        match self.kind {
            PunctualKind::Point => 4.0 * std::f32::consts::PI * i,
            PunctualKind::Spot { cos_inner, cos_outer } => {
                2.0 * std::f32::consts::PI * i * (1.0 - 0.5 * (cos_inner + cos_outer))
            }
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
    triangle_pmf: Vec<f32>,
    environment_pmf: f32,
}

impl LightSampler {
    /// Builds the distribution from (light, power) pairs; lights of zero power are
    /// never chosen. `triangle_count` sizes the per-triangle pmf lookup used by MIS.
    pub fn new(candidates: Vec<(LightRef, f32)>, triangle_count: usize) -> Self {
        let candidates: Vec<_> = candidates.into_iter().filter(|&(_, p)| p > 0.0 && p.is_finite()).collect();
        let weights: Vec<f64> = candidates.iter().map(|&(_, p)| p as f64).collect();
        let Some(table) = AliasTable::new(&weights) else { return Self::default() };
        let mut sampler = Self { lights: Vec::with_capacity(candidates.len()), table, ..Self::default() };
        for (i, &(light, _)) in candidates.iter().enumerate() {
            sampler.lights.push(light);
            let pmf = sampler.table.pmf(i);
            match light {
                LightRef::Triangle(t) => {
                    if sampler.triangle_pmf.is_empty() {
                        sampler.triangle_pmf = vec![0.0; triangle_count];
                    }
                    sampler.triangle_pmf[t as usize] = pmf;
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
        self.triangle_pmf.get(tri as usize).copied().unwrap_or(0.0)
    }

    /// Probability that `sample` picks the environment.
    pub fn environment_pmf(&self) -> f32 {
        self.environment_pmf
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
            3,
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
            kind: PunctualKind::Spot { cos_inner: 0.9, cos_outer: 0.8 },
            position: Vec3::ZERO,
            direction: -Vec3::Z,
            intensity: Vec3::ONE,
        };
        assert_eq!(l.intensity_towards(-Vec3::Z), Vec3::ONE);
        assert_eq!(l.intensity_towards(Vec3::X), Vec3::ZERO);
        let mid = l.intensity_towards(Vec3::new(0.0, (1.0f32 - 0.85 * 0.85).sqrt(), -0.85)).x;
        assert!((mid - 0.25).abs() < 1e-3);
    }
}

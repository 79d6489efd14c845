//! Lights: KHR_lights_punctual lights, and a sampler that picks among all lights
//! (emissive triangles and punctual lights) in proportion to their power.

use crate::math::luminance;
use glam::Vec3;

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
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightRef {
    /// An emissive triangle (BVH order).
    Triangle(u32),
    /// A punctual light (index into the scene's punctual lights).
    Punctual(u32),
}

/// Chooses a light with probability proportional to its power (inverse-CDF lookup).
#[derive(Default)]
pub struct LightSampler {
    lights: Vec<LightRef>,
    cdf: Vec<f32>,
    pmf: Vec<f32>,
    triangle_pmf: Vec<f32>,
}

impl LightSampler {
    /// Builds the distribution from (light, power) pairs; lights of zero power are
    /// never chosen. `triangle_count` sizes the per-triangle pmf lookup used by MIS.
    pub fn new(candidates: Vec<(LightRef, f32)>, triangle_count: usize) -> Self {
        let candidates: Vec<_> = candidates.into_iter().filter(|&(_, p)| p > 0.0 && p.is_finite()).collect();
        let total: f64 = candidates.iter().map(|&(_, p)| p as f64).sum();
        let mut sampler = Self::default();
        if candidates.is_empty() {
            return sampler;
        }
        let mut running = 0.0f64;
        for &(light, power) in &candidates {
            running += power as f64;
            let pmf = (power as f64 / total) as f32;
            sampler.lights.push(light);
            sampler.cdf.push((running / total) as f32);
            sampler.pmf.push(pmf);
            if let LightRef::Triangle(t) = light {
                if sampler.triangle_pmf.is_empty() {
                    sampler.triangle_pmf = vec![0.0; triangle_count];
                }
                sampler.triangle_pmf[t as usize] = pmf;
            }
        }
        *sampler.cdf.last_mut().expect("non-empty") = 1.0;
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

    /// Picks a light for the uniform number `u`; returns it with its probability.
    pub fn sample(&self, u: f32) -> Option<(LightRef, f32)> {
        if self.lights.is_empty() {
            return None;
        }
        let i = self.cdf.partition_point(|&c| c <= u).min(self.lights.len() - 1);
        Some((self.lights[i], self.pmf[i]))
    }

    /// Probability that `sample` picks emissive triangle `tri` (0 for non-emitters).
    pub fn triangle_pmf(&self, tri: u32) -> f32 {
        self.triangle_pmf.get(tri as usize).copied().unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_lights_in_proportion_to_power() {
        let s = LightSampler::new(
            vec![(LightRef::Triangle(0), 1.0), (LightRef::Punctual(0), 3.0), (LightRef::Triangle(2), 0.0)],
            3,
        );
        assert_eq!(s.len(), 2);
        assert_eq!(s.sample(0.1), Some((LightRef::Triangle(0), 0.25)));
        assert_eq!(s.sample(0.3), Some((LightRef::Punctual(0), 0.75)));
        assert_eq!(s.sample(0.999_999), Some((LightRef::Punctual(0), 0.75)));
        assert_eq!(s.triangle_pmf(0), 0.25);
        assert_eq!(s.triangle_pmf(2), 0.0);
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

//! Chooses a light with probability proportional to its power, in constant time (an alias
//! table: scenes with many emissive triangles do not pay a binary search per shadow ray),
//! and answers MIS's question of how likely a light found by a ray was to be chosen.

use super::Light;
use super::triangle::TriangleLight;
use crate::math::distribution::AliasTable;
use glam::Vec2;

/// The lights of non-zero power, their alias table, and per-triangle lookups for MIS.
#[derive(Default)]
pub struct LightSampler {
    lights: Vec<Light>,
    table: AliasTable,
    /// Per triangle: the probability of choosing it and its area (empty without emitters).
    triangles: Vec<TrianglePick>,
    environment_pmf: f32,
}

/// What MIS reads of an emissive triangle, kept beside each other.
#[derive(Clone, Copy, Default)]
pub(super) struct TrianglePick {
    pub(super) pmf: f32,
    pub(super) area: f32,
}

impl LightSampler {
    /// Builds the distribution from (light, power) pairs; lights of zero power are
    /// never chosen. `areas` holds, per triangle, the area of each emissive one (empty
    /// without any); it sizes the per-triangle lookup used by MIS.
    pub fn new(candidates: Vec<(Light, f32)>, areas: &[f32]) -> Self {
        let candidates: Vec<_> = candidates.into_iter().filter(|(_, p)| *p > 0.0 && p.is_finite()).collect();
        let weights: Vec<f64> = candidates.iter().map(|(_, p)| *p as f64).collect();
        let Some(table) = AliasTable::new(&weights) else { return Self::default() };
        let mut sampler = Self { lights: Vec::with_capacity(candidates.len()), table, ..Self::default() };
        for (i, (light, _)) in candidates.into_iter().enumerate() {
            let pmf = sampler.table.pmf(i);
            match light {
                Light::Triangle(TriangleLight { tri, .. }) => {
                    if sampler.triangles.is_empty() {
                        sampler.triangles = areas.iter().map(|&area| TrianglePick { pmf: 0.0, area }).collect();
                    }
                    sampler.triangles[tri as usize].pmf = pmf;
                }
                Light::Environment => sampler.environment_pmf = pmf,
                Light::Point(_) | Light::Spot(_) | Light::Directional(_) => {}
            }
            sampler.lights.push(light);
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
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(&Light, f32)> {
        if self.lights.is_empty() {
            return None;
        }
        let (i, pmf) = self.table.sample(u);
        Some((&self.lights[i], pmf))
    }

    /// Probability that `sample` picks emissive triangle `tri` (0 for non-emitters).
    pub fn triangle_pmf(&self, tri: u32) -> f32 {
        self.triangle(tri).pmf
    }

    /// The area of emissive triangle `tri` (0 for non-emitters).
    pub fn triangle_area(&self, tri: u32) -> f32 {
        self.triangle(tri).area
    }

    /// Emissive triangle `tri`'s choice probability and area (zeros for non-emitters).
    #[inline]
    pub(super) fn triangle(&self, tri: u32) -> TrianglePick {
        self.triangles.get(tri as usize).copied().unwrap_or_default()
    }

    /// Probability that `sample` picks the environment.
    pub fn environment_pmf(&self) -> f32 {
        self.environment_pmf
    }
}

#[cfg(test)]
mod tests {
    use super::super::point::PointLight;
    use super::*;
    use glam::Vec3;

    #[test]
    fn picks_lights_in_proportion_to_power() {
        let triangle = |tri| Light::Triangle(TriangleLight { tri, area: 1.0, power: 1.0 });
        let point = Light::Point(Box::new(PointLight { position: Vec3::ZERO, intensity: Vec3::ONE, range: None }));
        let s = LightSampler::new(
            vec![(triangle(0), 1.0), (point.clone(), 2.0), (triangle(2), 0.0), (Light::Environment, 1.0)],
            &[1.0, 1.0, 1.0],
        );
        assert_eq!(s.len(), 3);
        let (mut points, mut environment) = (0, 0);
        // A grid of midpoints with whole columns per light: the shares are exact.
        let (nx, ny) = (3 * 64, 64);
        for i in 0..nx {
            for j in 0..ny {
                let u = Vec2::new((i as f32 + 0.5) / nx as f32, (j as f32 + 0.5) / ny as f32);
                let (light, pmf) = s.sample(u).unwrap();
                assert_eq!(pmf, if *light == point { 0.5 } else { 0.25 });
                points += (*light == point) as usize;
                environment += (*light == Light::Environment) as usize;
            }
        }
        assert_eq!(points, nx * ny / 2);
        assert_eq!(environment, nx * ny / 4);
        assert_eq!(s.triangle_pmf(0), 0.25);
        assert_eq!(s.triangle_pmf(2), 0.0);
        assert_eq!(s.environment_pmf(), 0.25);
    }
}

//! A KHR_lights_punctual point light: radiant intensity the same in every direction.

use super::punctual::range_window;
use super::{LightLeSample, LightSample, LightTarget};
use crate::math::warp;
use crate::scene::geometry::Ray;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// A point light placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    /// World position.
    pub position: Vec3,
    /// Radiant intensity (glTF candela, used 1:1), linear RGB.
    pub intensity: Vec3,
    /// KHR_lights_punctual `range` (None: the inverse square alone).
    pub range: Option<f32>,
}

impl PointLight {
    /// The light as seen from `p`, with the probability `pmf` of having chosen it.
    pub fn sample_li(&self, p: Vec3, pmf: f32) -> Option<LightSample> {
        let to_light = self.position - p;
        let dist2 = to_light.length_squared();
        let wi = to_light / dist2.sqrt();
        let radiance = Spectrum::from_illuminant_rgb(self.intensity) * (range_window(self.range, dist2) / dist2);
        if radiance.is_black() || !wi.is_finite() {
            return None;
        }
        Some(LightSample { wi, radiance, pdf: pmf, target: LightTarget::Point(self.position), is_delta: true })
    }

    /// A ray leaving the light in a direction uniform over the sphere (`u_dir`), carrying
    /// the intensity; `range` windows the light where a path meets a surface, not here.
    pub fn sample_le(&self, u_dir: Vec2) -> Option<LightLeSample> {
        let d = warp::uniform_sphere(u_dir);
        let ray = Ray { o: self.position, d, tmax: f32::INFINITY };
        let radiance = Spectrum::from_illuminant_rgb(self.intensity);
        Some(LightLeSample { ray, n: None, radiance, pdf_pos: 1.0, pdf_dir: warp::UNIFORM_SPHERE_PDF })
    }

    /// Emitted power (luminance), for choosing among lights: 4 pi times the intensity.
    pub fn power(&self) -> f32 {
        4.0 * std::f32::consts::PI * crate::math::luminance(self.intensity)
    }
}

//! A KHR_lights_punctual directional light: parallel light of a given irradiance.

use super::{Disc, LightLeSample, LightSample, LightTarget};
use crate::scene::geometry::Ray;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// A directional light.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionalLight {
    /// Unit direction the light travels along.
    pub direction: Vec3,
    /// Irradiance on a surface facing the light (glTF lux, used 1:1), linear RGB.
    pub irradiance: Vec3,
}

impl DirectionalLight {
    /// The light as seen from anywhere, with the probability `pmf` of having chosen it.
    pub fn sample_li(&self, pmf: f32) -> Option<LightSample> {
        let (wi, radiance) = (-self.direction, Spectrum::from_illuminant_rgb(self.irradiance));
        if radiance.is_black() || !wi.is_finite() {
            return None;
        }
        Some(LightSample { wi, radiance, pdf: pmf, target: LightTarget::Infinite, is_delta: true })
    }

    /// A ray of the light entering the scene through a point of `disc` (`u_pos`), carrying
    /// the irradiance.
    pub fn sample_le(&self, disc: Disc, u_pos: Vec2) -> Option<LightLeSample> {
        let d = self.direction;
        let ray = Ray { o: disc.point(d, u_pos), d, tmax: f32::INFINITY };
        let radiance = Spectrum::from_illuminant_rgb(self.irradiance);
        Some(LightLeSample { ray, n: None, radiance, pdf_pos: disc.pdf(), pdf_dir: 1.0 })
    }

    /// Power (luminance) reaching a scene of radius `scene_radius`, for choosing among
    /// lights: the irradiance over the disc the scene presents to it.
    pub fn power(&self, scene_radius: f32) -> f32 {
        std::f32::consts::PI * scene_radius * scene_radius * crate::math::luminance(self.irradiance)
    }
}

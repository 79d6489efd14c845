//! The Henyey-Greenstein phase function (Henyey and Greenstein 1941), sampled by inverting
//! its CDF in cos theta. Convention: `wo` points back along the incoming light (towards
//! where the path came from, as a BSDF's wo) and `wi` towards where light comes from, so the
//! scattering angle theta is between the direction light travelled, -wi, and the one it
//! leaves in, wo: p = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^(3/2)) with
//! cos theta = dot(-wi, wo). g > 0 scatters forward (light keeps going: wi close to -wo).

use crate::math::frame::Frame;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Largest |g| used: beyond it the lobe is a spike f32 cannot resolve.
pub const MAX_G: f32 = 0.99;

/// A Henyey-Greenstein phase function of asymmetry `g` in (-1, 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HenyeyGreenstein {
    /// Mean cosine of the scattering angle.
    pub g: f32,
}

/// A sampled incident direction.
#[derive(Clone, Copy, Debug)]
pub struct PhaseSample {
    /// Direction towards where light comes from (unit length).
    pub wi: Vec3,
    /// Solid-angle density of `wi`, equal to the phase function's value (it is normalised).
    pub pdf: f32,
}

impl HenyeyGreenstein {
    /// Density of scattering by angle theta with cos theta = `cos_theta`, per steradian.
    fn density(&self, cos_theta: f32) -> f32 {
        let g = self.g;
        let denom = 1.0 + g * g - 2.0 * g * cos_theta;
        (1.0 - g * g) / (4.0 * PI * denom * denom.max(1e-12).sqrt())
    }

    /// p(wo, wi), which is also the pdf of `sample`.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.density((-wi).dot(wo))
    }

    /// A direction wi for outgoing `wo` from uniforms `u`, with density `eval(wo, wi)`.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> PhaseSample {
        let g = self.g;
        // Inverse CDF of cos theta (pbrt-v4, Section 11.3.1).
        let cos_theta = if g.abs() < 1e-3 {
            1.0 - 2.0 * u.x
        } else {
            let s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u.x);
            ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
        };
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        // The direction light leaves in, scattered by theta from the direction it travelled.
        let travelled = Frame::from_normal(wo);
        let local = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta);
        let wi = -travelled.to_world(local);
        PhaseSample { wi, pdf: self.density(cos_theta) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_density_integrates_to_one_and_g_is_its_mean_cosine() {
        for g in [-0.9f32, -0.3, 0.0, 0.3, 0.9] {
            let hg = HenyeyGreenstein { g };
            let n = 200_000;
            let (mut total, mut mean_cos) = (0.0f64, 0.0f64);
            for i in 0..n {
                let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                let p = hg.density(c as f32) as f64 * 2.0 * std::f64::consts::PI * 2.0 / n as f64;
                total += p;
                mean_cos += p * c;
            }
            assert!((total - 1.0).abs() < 1e-3, "g {g}: integral {total}");
            assert!((mean_cos - g as f64).abs() < 2e-3, "g {g}: mean cosine {mean_cos}");
        }
    }

    #[test]
    fn forward_scattering_keeps_the_direction_light_travelled() {
        let hg = HenyeyGreenstein { g: 0.9 };
        let wo = Vec3::new(0.0, 0.6, 0.8);
        // Light travelled along wo (it came from -wo): wi = -wo keeps going straight.
        assert!(hg.eval(wo, -wo) > 10.0 * hg.eval(wo, wo));
        let s = hg.sample(wo, Vec2::new(0.5, 0.25));
        assert!((s.wi.length() - 1.0).abs() < 1e-5 && s.wi.dot(-wo) > 0.5, "{:?}", s.wi);
        assert!((s.pdf - hg.eval(wo, s.wi)).abs() < 1e-4 * s.pdf);
    }
}

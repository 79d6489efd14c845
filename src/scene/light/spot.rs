//! A KHR_lights_punctual spot light: a point emitting within a cone, with the extension's
//! smooth falloff between its inner and outer angles.

use super::punctual::range_window;
use super::{LightLeSample, LightSample, LightTarget};
use crate::math::frame::Frame;
use crate::scene::geometry::Ray;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

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

    /// innerConeAngle: full intensity inside it (radians).
    pub fn inner(&self) -> f32 {
        self.inner
    }

    /// outerConeAngle: no light outside it (radians).
    pub fn outer(&self) -> f32 {
        self.outer
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
}

/// A spot light placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct SpotLight {
    /// World position.
    pub position: Vec3,
    /// Unit direction of the cone's axis.
    pub direction: Vec3,
    /// Radiant intensity on the axis (glTF candela, used 1:1), linear RGB.
    pub intensity: Vec3,
    /// The cone.
    pub cone: Cone,
    /// KHR_lights_punctual `range` (None: the inverse square alone).
    pub range: Option<f32>,
}

impl SpotLight {
    /// Radiant intensity towards unit direction `w` leaving the light.
    pub fn intensity_towards(&self, w: Vec3) -> Spectrum {
        Spectrum::from_illuminant_rgb(self.intensity) * self.cone.falloff(versine_between(w, self.direction))
    }

    /// The light as seen from `p`, with the probability `pmf` of having chosen it.
    pub fn sample_li(&self, p: Vec3, pmf: f32) -> Option<LightSample> {
        let to_light = self.position - p;
        let dist2 = to_light.length_squared();
        let wi = to_light / dist2.sqrt();
        let radiance = self.intensity_towards(-wi) * (range_window(self.range, dist2) / dist2);
        if radiance.is_black() || !wi.is_finite() {
            return None;
        }
        Some(LightSample { wi, radiance, pdf: pmf, target: LightTarget::Point(self.position), is_delta: true })
    }

    /// A ray leaving the light in a direction uniform over the outer cone (`u_dir`: 1 - cos
    /// uniform in [0, 1 - cos outer], the azimuth uniform), carrying the intensity there.
    pub fn sample_le(&self, u_dir: Vec2) -> Option<LightLeSample> {
        let vers = u_dir.x * self.cone.vers_outer;
        let cos = 1.0 - vers;
        let sin = (vers * (2.0 - vers)).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * u_dir.y;
        let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
        let d = Frame::from_normal(self.direction).to_world(local);
        let radiance = Spectrum::from_illuminant_rgb(self.intensity) * self.cone.falloff(vers);
        if radiance.is_black() || !d.is_finite() {
            return None;
        }
        let ray = Ray { o: self.position, d, tmax: f32::INFINITY };
        Some(LightLeSample { ray, n: None, radiance, pdf_pos: 1.0, pdf_dir: self.pdf_dir(d) })
    }

    /// `sample_le`'s density of direction `w` (unit) per solid angle.
    pub fn pdf_dir(&self, w: Vec3) -> f32 {
        if versine_between(w, self.direction) <= self.cone.vers_outer {
            1.0 / (std::f32::consts::TAU * self.cone.vers_outer)
        } else {
            0.0
        }
    }

    /// Emitted power (luminance), for choosing among lights: the intensity times the
    /// falloff's solid angle.
    pub fn power(&self) -> f32 {
        self.cone.solid_angle() * crate::math::luminance(self.intensity)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spot(inner: f32, outer: f32) -> SpotLight {
        SpotLight {
            position: Vec3::ZERO,
            direction: -Vec3::Z,
            intensity: Vec3::ONE,
            cone: Cone::new(inner, outer),
            range: None,
        }
    }

    /// The direction `theta` off the axis -z.
    fn off_axis(theta: f64) -> Vec3 {
        Vec3::new(theta.sin() as f32, 0.0, -theta.cos() as f32)
    }

    #[test]
    fn spot_falloff_is_full_inside_and_zero_outside() {
        let l = spot(0.9f32.acos(), 0.8f32.acos());
        assert_eq!(l.intensity_towards(-Vec3::Z), Spectrum::ONE);
        assert_eq!(l.intensity_towards(Vec3::X), Spectrum::ZERO);
        let mid = l.intensity_towards(Vec3::new(0.0, (1.0f32 - 0.85 * 0.85).sqrt(), -0.85)).to_rgb().x;
        assert!((mid - 0.25).abs() < 1e-3);
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
            let power = l.power() as f64;
            assert!((power / integral - 1.0).abs() < 1e-3, "{inner}..{outer}: power {power:e}, integral {integral:e}");
        }
    }
}

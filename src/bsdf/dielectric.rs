//! A rough dielectric interface (Walter et al. 2007, in pbrt-v4's formulation): GGX
//! microfacets reflect with the exact Fresnel probability and refract otherwise. A thin wall
//! (no volume behind it) lets the refracted light out of its far side at once, along the
//! mirror image of the reflection. In the local frame wo is on the +z side; `eta` is
//! n_other / n_wo. Transmission carries the 1/eta^2 of radiance entering a denser medium
//! (for radiance only; importance is not scaled). Below `SMOOTH_ALPHA` the interface is
//! smooth and its two lobes are deltas, which `MetalRough` samples through
//! `reflectance` and `smooth_transmission`.

use super::TransportMode;
use super::microfacet::{Ggx, fresnel_dielectric, reflect, refract};
use glam::{Vec2, Vec3};

/// A dielectric boundary at one surface point.
#[derive(Clone, Copy, Debug)]
pub struct Interface {
    /// GGX distribution of the microfacets (anisotropic with KHR_materials_anisotropy).
    pub ggx: Ggx,
    /// Relative index of refraction n_other / n_wo.
    pub eta: f32,
    /// Thin-walled: transmitted light leaves the far side without bending.
    pub thin: bool,
    /// KHR_materials_specular factor: scales the Fresnel reflectance.
    pub specular: f32,
}

/// How a pair of directions is connected by one microfacet `h`, with the share of light
/// (Fresnel's R or 1 - R) that goes that way.
enum Connection {
    /// Reflection, or a thin wall's transmission: `wr` is wi mirrored back above the surface.
    Mirrored { h: Vec3, wr: Vec3, share: f32 },
    /// Refraction; `denom` = (wi.h + wo.h / eta)^2 is the Jacobian's denominator.
    Refracted { h: Vec3, oh: f32, ih: f32, denom: f32, share: f32 },
}

/// Mirror image through the surface plane.
fn flip(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

impl Interface {
    /// Relative index crossed by transmitted light: 1 through a thin wall.
    pub fn crossed_eta(&self) -> f32 {
        if self.thin { 1.0 } else { self.eta }
    }

    /// The factor transmitted light of `mode` carries: 1/eta^2 for radiance refracted
    /// into a volume, 1 otherwise.
    pub fn transmission_scale(&self, mode: TransportMode) -> f32 {
        match mode {
            TransportMode::Radiance if !self.thin => 1.0 / (self.eta * self.eta),
            _ => 1.0,
        }
    }

    /// Direction of the smooth interface's transmission lobe: straight through a thin
    /// wall, refracted otherwise; None under total internal reflection.
    pub fn smooth_transmission(&self, wo: Vec3) -> Option<Vec3> {
        if self.thin { Some(-wo) } else { refract(wo, Vec3::Z, self.eta) }
    }

    /// Reflectance of a microfacet seen at cosine `cos` from wo's side.
    pub fn reflectance(&self, cos: f32) -> f32 {
        (self.specular * fresnel_dielectric(cos, self.eta)).clamp(0.0, 1.0)
    }

    /// Half vector of a refraction from wo into wi (wi.z < 0), facing +z; None if the pair
    /// cannot be connected by a microfacet that faces wo and turns its back on wi.
    fn refraction_half_vector(&self, wo: Vec3, wi: Vec3) -> Option<Vec3> {
        let h = (wo + wi * self.eta).normalize_or_zero();
        let h = if h.z < 0.0 { -h } else { h };
        (h != Vec3::ZERO && wo.dot(h) > 0.0 && wi.dot(h) < 0.0).then_some(h)
    }

    /// The microfacet that connects wo to wi, or None if none can.
    fn connect(&self, wo: Vec3, wi: Vec3) -> Option<Connection> {
        if wi.z == 0.0 || wo.z <= 0.0 {
            return None;
        }
        if wi.z > 0.0 || self.thin {
            let transmitted = wi.z < 0.0;
            let wr = if transmitted { flip(wi) } else { wi };
            let h = (wo + wr).normalize_or_zero();
            if h == Vec3::ZERO {
                return None;
            }
            let r = self.reflectance(wo.dot(h));
            let share = if transmitted { 1.0 - r } else { r };
            return Some(Connection::Mirrored { h, wr, share });
        }
        let h = self.refraction_half_vector(wo, wi)?;
        let (oh, ih) = (wo.dot(h), wi.dot(h));
        let denom = (ih + oh / self.eta).powi(2);
        Some(Connection::Refracted { h, oh, ih, denom, share: 1.0 - self.reflectance(oh) })
    }

    /// f |cos theta_i| of the rough interface before tinting, and the solid-angle density
    /// of `sample`: reflection for wi.z > 0, transmission for wi.z < 0.
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (f32, f32) {
        let ggx = self.ggx;
        match self.connect(wo, wi) {
            Some(Connection::Mirrored { h, wr, share }) => {
                let d = ggx.d(h);
                let f = share * d * ggx.g2(wo, wr) / (4.0 * wo.z);
                (f, share * ggx.visible_normal_pdf(wo, h, d) / (4.0 * wo.dot(h).abs()))
            }
            Some(Connection::Refracted { h, oh, ih, denom, share }) => {
                let d = ggx.d(h);
                let f = share * d * ggx.g2(wo, -wi) * (ih * oh).abs() * self.transmission_scale(mode) / (wo.z * denom);
                (f, share * ggx.visible_normal_pdf(wo, h, d) * ih.abs() / denom)
            }
            None => (0.0, 0.0),
        }
    }

    /// A visible microfacet of the rough interface from `u`, then reflection with
    /// probability F (decided by `u_lobe`) or refraction. None for directions on the wrong side.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        let h = self.ggx.sample_visible_normal(wo, u);
        let r = self.reflectance(wo.dot(h));
        let wi = if u_lobe < r {
            reflect(wo, h)
        } else if self.thin {
            flip(reflect(wo, h))
        } else {
            refract(wo, h, self.eta)?
        };
        let reflected = u_lobe < r;
        (if reflected { wi.z > 0.0 } else { wi.z < 0.0 }).then_some(wi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_matches_normal_incidence_and_total_internal_reflection() {
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
        // Critical angle from glass to air: sin = 1 / 1.5.
        let critical = (1.0f32 - 1.0 / 2.25).sqrt();
        assert_eq!(fresnel_dielectric(critical - 1e-3, 1.0 / 1.5), 1.0);
        assert!(fresnel_dielectric(critical + 1e-3, 1.0 / 1.5) < 1.0);
        assert_eq!(fresnel_dielectric(-1.0, 1.5), fresnel_dielectric(1.0, 1.0 / 1.5));
    }

    #[test]
    fn refraction_obeys_snells_law() {
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let wi = refract(wo, Vec3::Z, 1.5).unwrap();
        assert!((wi.length() - 1.0).abs() < 1e-6);
        assert!((-wi.x - 0.6 / 1.5).abs() < 1e-6 && wi.z < 0.0);
        assert!(refract(Vec3::new(0.9, 0.0, 0.4359), Vec3::Z, 1.0 / 1.5).is_none());
    }
}

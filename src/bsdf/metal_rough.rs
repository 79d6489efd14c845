//! The glTF metallic-roughness BRDF (glTF 2.0 spec Appendix B, with KHR_materials_specular):
//! mix(dielectric, metal, metallic), where the dielectric is a Lambertian base under a GGX
//! specular layer, and the metal is GGX with Schlick's conductor Fresnel.
//!
//! The spec's `fresnel_mix` weights the base by 1 - F(v.h), which creates energy at grazing
//! incidence (a smooth white dielectric reflected 1.65 at theta_o = 1.5 rad). The base is
//! instead weighted by the energy the layer leaves to it, in the reciprocal form of Kelemen
//! and Szirmay-Kalos (2001): (1 - s E(wo)) (1 - s E(wi)) / (1 - s E_avg), with E the layer's
//! directional albedo (`albedo.rs`) and s the specular factor. Its albedo is then
//! s E_c(wo) + base (1 - s E(wo)) <= 1, and it stays symmetric in wo and wi.

use super::albedo::{ggx_albedo, ggx_average_albedo};
use super::microfacet::{Ggx, reflect};
use crate::math::{luminance, warp};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Parameters of the glTF BRDF at one surface point.
#[derive(Clone, Copy, Debug)]
pub struct MetalRough {
    /// Base colour (diffuse albedo for dielectrics, F0 for metals).
    pub base: Vec3,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// GGX alpha = roughness^2.
    pub alpha: f32,
    /// Dielectric F0: ((ior - 1) / (ior + 1))^2 x specularColor, clamped to 1.
    pub dielectric_f0: Vec3,
    /// KHR_materials_specular specularFactor: weight of the dielectric layer.
    pub specular: f32,
}

fn schlick_weight(cos: f32) -> f32 {
    (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

impl MetalRough {
    fn ggx(&self) -> Ggx {
        Ggx { alpha: self.alpha }
    }

    /// Dielectric Fresnel F = f0 + (1 - f0)(1 - cos)^5 (the spec's `fresnel_mix`).
    fn dielectric_fresnel(&self, cos: f32) -> Vec3 {
        self.dielectric_f0 + (Vec3::ONE - self.dielectric_f0) * schlick_weight(cos)
    }

    /// Metal Fresnel F = base + (1 - base)(1 - cos)^5 (the spec's `conductor_fresnel`).
    fn metal_fresnel(&self, cos: f32) -> Vec3 {
        self.base + (Vec3::ONE - self.base) * schlick_weight(cos)
    }

    /// f |cos theta_i|, both directions above the surface.
    pub fn eval_cos(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let ggx = self.ggx();
        let voh = wo.dot(h);
        let specular = ggx.d(h) * ggx.g2(wo, wi) / (4.0 * wo.z * wi.z);
        let f_d = self.dielectric_fresnel(voh);
        let dielectric = self.base * (FRAC_1_PI * self.base_weight(wo.z, wi.z)) + self.specular * f_d * specular;
        let metal = self.metal_fresnel(voh) * specular;
        dielectric.lerp(metal, self.metallic) * wi.z
    }

    /// Share of the energy the specular layer leaves to the diffuse base, for the pair of
    /// directions (the reciprocal albedo-scaling weight described above).
    fn base_weight(&self, mu_o: f32, mu_i: f32) -> f32 {
        let s = self.specular;
        if s <= 0.0 {
            return 1.0;
        }
        let roughness = self.alpha.sqrt();
        let f0 = self.dielectric_f0.max_element();
        let avg = 1.0 - s * ggx_average_albedo(roughness, f0);
        if avg <= 1e-6 {
            return 0.0;
        }
        (1.0 - s * ggx_albedo(mu_o, roughness, f0)) * (1.0 - s * ggx_albedo(mu_i, roughness, f0)) / avg
    }

    /// Probability of sampling the specular lobe rather than the diffuse one, from the
    /// lobes' albedos estimated at normal-to-wo Fresnel.
    fn specular_probability(&self, wo: Vec3) -> f32 {
        let f_d = self.specular * self.dielectric_fresnel(wo.z).max_element();
        let spec = (1.0 - self.metallic) * f_d + self.metallic * luminance(self.metal_fresnel(wo.z));
        let diff = (1.0 - self.metallic) * (1.0 - f_d) * luminance(self.base);
        if spec + diff > 0.0 { spec / (spec + diff) } else { 1.0 }
    }

    /// Chooses a lobe with `u_lobe`, then a direction: VNDF reflection or cosine.
    pub fn sample_direction(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        let wi = if u_lobe < self.specular_probability(wo) {
            reflect(wo, self.ggx().sample_visible_normal(wo, u))
        } else {
            warp::cos_hemisphere(u)
        };
        (wi.z > 0.0).then_some(wi)
    }

    /// Mixture pdf of `sample_direction`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let p = self.specular_probability(wo);
        p * self.ggx().pdf_reflect(wo, wi) + (1.0 - p) * warp::cos_hemisphere_pdf(wi.z)
    }
}

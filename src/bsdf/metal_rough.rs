//! The glTF metallic-roughness BRDF (glTF 2.0 spec Appendix B, with KHR_materials_specular):
//! mix(dielectric, metal, metallic), where the dielectric is a Fresnel mix of a Lambertian
//! base under a GGX specular layer, and the metal is GGX with Schlick's conductor Fresnel.
//! The spec's mix weights the base by 1 - F(v.h), which is not energy conserving at grazing
//! incidence: a smooth white dielectric reflects up to 1.65 at theta_o = 1.5 rad. Metals
//! and the base alone never exceed 1 (tests/bsdf_chi2.rs).

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
        let diffuse = self.base * FRAC_1_PI;
        let dielectric = diffuse * (1.0 - self.specular * f_d.max_element()) + self.specular * f_d * specular;
        let metal = self.metal_fresnel(voh) * specular;
        dielectric.lerp(metal, self.metallic) * wi.z
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

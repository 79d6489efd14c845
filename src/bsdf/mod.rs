//! BSDFs in the local shading frame (normal = +z), as a closed enum. One contract for all:
//! `eval_cos` is f |cos theta_i|, `sample` returns a direction with weight f |cos| / pdf,
//! `pdf` is the solid-angle density of `sample`. Degenerate samples are rejected here.

pub mod albedo;
mod dielectric;
mod diffuse;
pub mod measured;
mod metal_rough;
pub mod microfacet;
pub mod sheen;

pub use diffuse::Lambert;
pub use metal_rough::MetalRough;

use crate::math::warp;
use glam::{Vec2, Vec3};

/// A sampled incident direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Incident direction (local frame, unit length).
    pub wi: Vec3,
    /// f(wo, wi) |cos theta_i| / pdf.
    pub weight: Vec3,
    /// Solid-angle pdf of `wi`.
    pub pdf: f32,
}

/// How `Bsdf::sample` chooses directions (the textbook's "importance sampling" toggle).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Directions in proportion to the BSDF (cosine for diffuse, VNDF for glossy).
    Importance,
    /// Directions uniform over the hemisphere, pdf 1 / (2 pi); over the sphere, pdf
    /// 1 / (4 pi), for BSDFs that transmit.
    Uniform,
}

/// The reflection models this renderer knows; measured ones borrow their table from the
/// scene for `'a`.
#[derive(Clone, Copy, Debug)]
pub enum Bsdf<'a> {
    /// Ideal diffuse reflection.
    Lambert(Lambert),
    /// glTF metallic-roughness BRDF (spec Appendix B, with KHR_materials_specular).
    MetalRough(MetalRough),
    /// A measured isotropic BRDF (MERL table).
    Measured(&'a measured::MerlTable),
}

impl Bsdf<'_> {
    /// Whether light can pass through to the other side (wi below the surface).
    pub fn transmits(&self) -> bool {
        matches!(self, Bsdf::MetalRough(b) if b.transmits())
    }

    /// Whether `wi` lies where this BSDF can be non-zero for a wo above the surface.
    fn reaches(&self, wo: Vec3, wi: Vec3) -> bool {
        wo.z > 0.0 && (wi.z > 0.0 || (wi.z < 0.0 && self.transmits()))
    }

    /// f(wo, wi) |cos theta_i|; zero unless wo is above the surface and wi above it too, or
    /// below it for a transmitting BSDF.
    pub fn eval_cos(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !self.reaches(wo, wi) {
            return Vec3::ZERO;
        }
        match self {
            Bsdf::Lambert(b) => b.eval_cos(wi),
            Bsdf::MetalRough(b) => b.eval_cos(wo, wi),
            Bsdf::Measured(t) => t.eval(wo, wi) * wi.z,
        }
    }

    /// Solid-angle pdf with which `sample` under `strategy` returns `wi`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3, strategy: Strategy) -> f32 {
        if !self.reaches(wo, wi) {
            return 0.0;
        }
        match (strategy, self) {
            (Strategy::Uniform, _) if self.transmits() => warp::UNIFORM_SPHERE_PDF,
            (Strategy::Uniform, _) => warp::UNIFORM_HEMISPHERE_PDF,
            (Strategy::Importance, Bsdf::Lambert(_)) => warp::cos_hemisphere_pdf(wi.z),
            (Strategy::Importance, Bsdf::MetalRough(b)) => b.pdf(wo, wi),
            (Strategy::Importance, Bsdf::Measured(t)) => t.pdf(wo, wi),
        }
    }

    /// Samples an incident direction for outgoing `wo` from the uniforms `u_lobe`, `u`.
    /// Returns None for directions with zero pdf or zero or non-finite weight.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, strategy: Strategy) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = match (strategy, self) {
            (Strategy::Uniform, _) if self.transmits() => warp::uniform_sphere(u),
            (Strategy::Uniform, _) => warp::uniform_hemisphere(u),
            (Strategy::Importance, Bsdf::Lambert(_)) => warp::cos_hemisphere(u),
            (Strategy::Importance, Bsdf::MetalRough(b)) => b.sample_direction(wo, u_lobe, u)?,
            (Strategy::Importance, Bsdf::Measured(t)) => t.sample_direction(wo, u_lobe, u)?,
        };
        let pdf = self.pdf(wo, wi, strategy);
        let f = self.eval_cos(wo, wi);
        let weight = f / pdf;
        (pdf > 0.0 && pdf.is_finite() && weight.is_finite() && weight.max_element() > 0.0).then_some(BsdfSample {
            wi,
            weight,
            pdf,
        })
    }
}

//! How a vertex chooses the next direction: in proportion to the BSDF (importance sampling,
//! the textbook's section 10.8), or uniformly over the hemisphere (the sphere where the BSDF
//! transmits) as the switched-off baseline, like pbrt-v4's SimplePathIntegrator. Delta lobes
//! can be found only by sampling them, so with uniform directions they are still chosen by
//! the BSDF, with the probability its own sampling gives them, and the uniform directions
//! take the rest of the probability.

use crate::bsdf::{Bsdf, BsdfSample, LobeFlags, TransportMode};
use crate::math::warp;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// Which way directions are chosen at every vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampling {
    /// `Bsdf::sample`.
    Importance,
    /// Uniform over the hemisphere or sphere for the non-delta lobes.
    Uniform,
}

impl Sampling {
    /// The strategy for the settings' importance-sampling switch.
    pub fn new(importance_sampling: bool) -> Self {
        if importance_sampling { Self::Importance } else { Self::Uniform }
    }

    /// Density of uniform directions for `bsdf`: sphere if it transmits, else hemisphere.
    fn uniform_pdf(bsdf: &Bsdf) -> f32 {
        if bsdf.transmits() { warp::UNIFORM_SPHERE_PDF } else { warp::UNIFORM_HEMISPHERE_PDF }
    }

    /// Samples the next direction for outgoing `wo` (radiance transport).
    #[inline]
    pub fn sample(self, bsdf: &Bsdf, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let mode = TransportMode::Radiance;
        if self == Self::Importance {
            return bsdf.sample(wo, u_lobe, u, mode);
        }
        let specular = bsdf.specular_probability(wo);
        if u_lobe < specular {
            return bsdf.sample(wo, u_lobe, u, mode);
        }
        let wi = if bsdf.transmits() { warp::uniform_sphere(u) } else { warp::uniform_hemisphere(u) };
        let (f, pdf) = self.eval_pdf(bsdf, wo, wi);
        let side = if wi.z < 0.0 { LobeFlags::TRANSMISSION } else { LobeFlags::REFLECTION };
        let eta = if wi.z < 0.0 { bsdf.eta() } else { 1.0 };
        BsdfSample { wi, weight: f / pdf, pdf, flags: side | LobeFlags::DIFFUSE, eta }.checked()
    }

    /// f |cos| of the non-delta lobes towards `wi`, and the density with which `sample`
    /// returns it.
    #[inline]
    pub fn eval_pdf(self, bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        let (f, pdf) = bsdf.eval_pdf(wo, wi, TransportMode::Radiance);
        match self {
            Self::Importance => (f, pdf),
            Self::Uniform if bsdf.reaches(wo, wi) => {
                (f, (1.0 - bsdf.specular_probability(wo)) * Self::uniform_pdf(bsdf))
            }
            Self::Uniform => (f, 0.0),
        }
    }
}

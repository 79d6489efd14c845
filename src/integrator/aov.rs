//! The denoiser's auxiliary images (AOVs) of one pixel sample: the albedo and the shading
//! normal of the first non-specular vertex, as the documentation of Open Image Denoise's RT
//! filter asks ("Albedos", "Normals"). A path that meets a BSDF made only of delta lobes (a
//! mirror, smooth glass, a smooth thin wall) is followed to its next vertex, the albedo
//! weighted by what the delta lobes passed on: on average smooth glass gets the Fresnel blend
//! of what it reflects and transmits, as the documentation recommends, and Cycles does the
//! same (`film_write_denoising_features_surface`). Transmission's 1/eta^2 radiance scale is
//! undone, so that the weight stays a reflectance. A scattering medium records its
//! single-scattering albedo and a normal facing back along the ray (Cycles' volume
//! convention). A path that escapes, or ends before a non-specular vertex, records zero
//! albedo and normal, as Cycles does for the background.
//!
//! The trace reads what the path computes anyway and never draws from the sampler nor
//! touches the path's wavelengths, so the radiance is the same bits with or without AOVs;
//! when they are not asked for, each check is one test of an `Option`.

use super::vertex::Vertex;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// Albedo and normal of one sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Aov {
    /// Linear RGB reflectance in [0, 1] of the first non-specular vertex, times what the
    /// delta lobes before it passed on.
    pub albedo: Vec3,
    /// World-space unit shading normal there, on the side the path arrived from.
    pub normal: Vec3,
}

/// A path's progress towards its first non-specular vertex.
#[derive(Clone, Copy, Debug)]
pub struct AovTrace {
    /// What the delta lobes crossed so far passed on; None once recorded, or if not asked.
    weight: Option<Vec3>,
    /// What was recorded (None if not asked).
    aov: Option<Aov>,
}

impl AovTrace {
    /// A trace of a camera path; inert unless `asked`.
    pub fn new(asked: bool) -> Self {
        Self { weight: asked.then_some(Vec3::ONE), aov: asked.then(Aov::default) }
    }

    /// An inert trace, for the branches of a distribution ray tracer after its first.
    pub fn off() -> Self {
        Self::new(false)
    }

    /// Whether nothing is recorded yet and the path is still followed.
    #[inline]
    pub fn pending(&self) -> bool {
        self.weight.is_some()
    }

    /// At a surface vertex: records it if its BSDF has a non-delta lobe.
    #[inline]
    pub fn surface(&mut self, vertex: &Vertex) {
        if let Some(w) = self.weight
            && vertex.bsdf.flags().has_non_specular()
        {
            let albedo = (w * vertex.bsdf.albedo(vertex.wo).to_rgb()).clamp(Vec3::ZERO, Vec3::ONE);
            self.record(Aov { albedo, normal: vertex.frame.n });
        }
    }

    /// The path leaves a delta vertex with BSDF sample weight `weight` (RGB, as BSDFs return
    /// it), across relative index `eta` (1 for reflection and straight crossings).
    #[inline]
    pub fn delta(&mut self, weight: Spectrum, eta: f32) {
        if let Some(w) = &mut self.weight {
            *w *= weight.to_rgb() * (eta * eta);
        }
    }

    /// Light scatters in a medium of single-scattering albedo `albedo` (RGB) with the ray
    /// arriving from `wo` (world space, unit).
    #[inline]
    pub fn medium(&mut self, albedo: Vec3, wo: Vec3) {
        if let Some(w) = self.weight {
            self.record(Aov { albedo: (w * albedo).clamp(Vec3::ZERO, Vec3::ONE), normal: wo });
        }
    }

    fn record(&mut self, aov: Aov) {
        self.aov = Some(aov);
        self.weight = None;
    }

    /// What the sample records: None if not asked, zero if no non-specular vertex was found.
    pub fn finish(self) -> Option<Aov> {
        self.aov
    }
}

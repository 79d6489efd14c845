//! BSDFs in the local shading frame (normal = +z), as a closed enum, with one contract
//! for all (after Mitsuba 3's `BSDF` and pbrt-v4's `BSDF::Sample_f`):
//! - `eval` is f |cos theta_i| of the non-delta lobes, `pdf` the solid-angle density with
//!   which `sample` returns a direction from them, `eval_pdf` both at once;
//! - `sample` returns a direction with its lobe flags, the relative index of refraction it
//!   crossed, its pdf and its weight f |cos| / pdf. Delta (specular) lobes are sampled
//!   only here: their pdf is the discrete probability of choosing them, and `eval` and
//!   `pdf` are zero for them in every direction;
//! - the transport mode says whether radiance or importance flows, which decides the
//!   1/eta^2 of refraction (Veach 1997, section 5.2).
//!
//! Degenerate samples (zero pdf, zero or non-finite weight) are rejected in one place.

pub mod albedo;
mod albedo_table;
mod dielectric;
mod diffuse;
pub mod measured;
mod metal_rough;
pub mod microfacet;
pub mod sheen;
mod sheen_table;
pub mod thin_film;

pub use diffuse::Lambert;
pub use metal_rough::MetalRough;

use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// Below this GGX alpha a lobe is an exact delta (pbrt-v4's `EffectivelySmooth`):
/// roughness under about 0.03 renders as a perfect mirror or a perfectly smooth interface.
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// Whether a GGX lobe of width `alpha` is treated as a delta lobe.
pub fn is_smooth(alpha: f32) -> bool {
    alpha < SMOOTH_ALPHA
}

/// Within this of 1, a relative index of refraction makes an index-matched interface: light
/// crosses it straight, without Fresnel reflection or bending.
pub const MATCHED_ETA: f32 = 1e-3;

/// Whether an interface of relative index `eta` is index-matched.
pub fn is_index_matched(eta: f32) -> bool {
    (eta - 1.0).abs() < MATCHED_ETA
}

bitflags::bitflags! {
    /// What a lobe (or the set of lobes of a BSDF) does with light.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct LobeFlags: u8 {
        /// Light leaves on the side it arrived from.
        const REFLECTION = 1;
        /// Light passes to the other side.
        const TRANSMISSION = 1 << 1;
        /// Spread over the whole hemisphere (Lambert, sheen, multiple scattering).
        const DIFFUSE = 1 << 2;
        /// A finite-width lobe (rough microfacets, measured).
        const GLOSSY = 1 << 3;
        /// A delta lobe: one direction (a mirror, a smooth interface).
        const SPECULAR = 1 << 4;
        /// Light passes straight through, as if the surface were not there: an
        /// index-matched interface, or a smooth thin wall's transmission (Mitsuba 3's null
        /// lobe). Paths cross it without a bounce; shadow rays cross it with its weight.
        const NULL = 1 << 5;
    }
}

impl LobeFlags {
    /// Whether some lobe is not a delta (so that light sampling can find it).
    pub fn has_non_specular(self) -> bool {
        self.intersects(Self::DIFFUSE | Self::GLOSSY)
    }

    /// Whether some lobe is a delta.
    pub fn has_specular(self) -> bool {
        self.contains(Self::SPECULAR)
    }
}

/// Which quantity flows along the path (pbrt-v4's `TransportMode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    /// Radiance, traced from the camera: refraction into a denser medium scales it by 1/eta^2.
    Radiance,
    /// Importance, traced from the lights: no 1/eta^2 (the adjoint BSDF).
    Importance,
}

/// A sampled incident direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Incident direction (local frame, unit length).
    pub wi: Vec3,
    /// f(wo, wi) |cos theta_i| / pdf.
    pub weight: Spectrum,
    /// Solid-angle pdf of `wi`, or for a delta lobe the probability of having chosen it.
    pub pdf: f32,
    /// The lobe that produced the sample.
    pub flags: LobeFlags,
    /// Relative index of refraction n_other / n_wo crossed (1 for reflection and thin walls).
    pub eta: f32,
}

impl BsdfSample {
    /// Whether the sample came from a delta lobe.
    pub fn is_specular(&self) -> bool {
        self.flags.contains(LobeFlags::SPECULAR)
    }

    /// The sample, if its pdf is positive and finite and its weight finite and not zero.
    pub fn checked(self) -> Option<Self> {
        let valid =
            self.pdf > 0.0 && self.pdf.is_finite() && self.weight.is_finite() && self.weight.max_element() > 0.0;
        valid.then_some(self)
    }

    /// Whether the sample crosses the surface.
    pub fn is_transmission(&self) -> bool {
        self.flags.contains(LobeFlags::TRANSMISSION)
    }
}

/// The reflection models this renderer knows; measured ones borrow their table from the
/// scene for `'a`.
#[derive(Clone, Copy, Debug)]
pub enum Bsdf<'a> {
    /// Ideal diffuse reflection.
    Lambert(Lambert),
    /// glTF metallic-roughness BSDF (spec Appendix B, with KHR_materials_specular and the
    /// layering extensions).
    MetalRough(MetalRough),
    /// A measured isotropic BRDF (MERL table).
    Measured(&'a measured::MerlTable),
}

impl Bsdf<'_> {
    /// The lobes this BSDF has.
    pub fn flags(&self) -> LobeFlags {
        match self {
            Bsdf::Lambert(_) => LobeFlags::REFLECTION | LobeFlags::DIFFUSE,
            Bsdf::MetalRough(b) => b.flags(),
            Bsdf::Measured(_) => LobeFlags::REFLECTION | LobeFlags::GLOSSY,
        }
    }

    /// Approximate reflectance in [0, 1], independent of the lighting: the denoiser's albedo
    /// feature (Open Image Denoise, RT filter, "Albedos"). The Lambertian albedo; for the glTF
    /// BSDF its base colour (diffuse colour, a metal's F0, a transmission's tint) under its
    /// sheen; for a measured table its directional albedo at normal incidence.
    pub fn albedo(&self, wo: Vec3) -> Spectrum {
        match self {
            Bsdf::Lambert(b) => b.albedo,
            Bsdf::MetalRough(b) => b.albedo(wo),
            Bsdf::Measured(t) => Spectrum::from_rgb(t.albedo()),
        }
    }

    /// Whether light can pass through to the other side (wi below the surface).
    pub fn transmits(&self) -> bool {
        match self {
            Bsdf::MetalRough(b) => b.transmits(),
            Bsdf::Lambert(_) | Bsdf::Measured(_) => false,
        }
    }

    /// Relative index of refraction crossed by transmitted light (1 for thin walls and
    /// for BSDFs that only reflect).
    pub fn eta(&self) -> f32 {
        match self {
            Bsdf::MetalRough(b) if b.transmits() => b.crossed_eta(),
            _ => 1.0,
        }
    }

    /// Whether `wi` lies where this BSDF can be non-zero for a wo above the surface.
    pub fn reaches(&self, wo: Vec3, wi: Vec3) -> bool {
        wo.z > 0.0 && (wi.z > 0.0 || (wi.z < 0.0 && self.transmits()))
    }

    /// f(wo, wi) |cos theta_i| of the non-delta lobes; zero unless wo is above the surface
    /// and wi above it too, or below it for a transmitting BSDF.
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Spectrum {
        self.eval_pdf(wo, wi, mode).0
    }

    /// Solid-angle pdf with which `sample` returns `wi` from a non-delta lobe.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !self.reaches(wo, wi) {
            return 0.0;
        }
        match self {
            Bsdf::Lambert(_) => crate::math::warp::cos_hemisphere_pdf(wi.z),
            Bsdf::MetalRough(b) => b.pdf(wo, wi),
            Bsdf::Measured(t) => t.pdf(wo, wi),
        }
    }

    /// `eval` and `pdf` together, sharing the work they have in common (Mitsuba 3's `eval_pdf`).
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Spectrum, f32) {
        if !self.reaches(wo, wi) {
            return (Spectrum::ZERO, 0.0);
        }
        match self {
            Bsdf::Lambert(b) => (b.eval(wi), crate::math::warp::cos_hemisphere_pdf(wi.z)),
            Bsdf::MetalRough(b) => b.eval_pdf(wo, wi, mode),
            Bsdf::Measured(t) => (Spectrum::from_rgb(t.eval(wo, wi) * wi.z), t.pdf(wo, wi)),
        }
    }

    /// What passes straight through towards `-wo` (f |cos| of the null lobe, integrated over
    /// its delta), if the BSDF has a null lobe: the transmittance a shadow ray picks up
    /// crossing the surface.
    pub fn null_transmission(&self, wo: Vec3) -> Option<Spectrum> {
        match self {
            Bsdf::MetalRough(b) if wo.z > 0.0 => b.null_transmission(wo),
            _ => None,
        }
    }

    /// Probability that `sample` chooses a delta lobe at `wo`. `sample` chooses one exactly
    /// when `u_lobe` is below it, so an integrator can sample the other lobes its own way.
    pub fn specular_probability(&self, wo: Vec3) -> f32 {
        match self {
            Bsdf::MetalRough(b) if wo.z > 0.0 => b.specular_probability(wo),
            _ => 0.0,
        }
    }

    /// Samples an incident direction for outgoing `wo` from the uniforms `u_lobe` (which
    /// lobe) and `u` (where in it). None for directions with zero pdf or a zero or
    /// non-finite weight.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let sample = match self {
            Bsdf::Lambert(_) => {
                let wi = crate::math::warp::cos_hemisphere(u);
                self.continuous_sample(wo, wi, LobeFlags::REFLECTION | LobeFlags::DIFFUSE, mode)
            }
            Bsdf::MetalRough(b) => b.sample(wo, u_lobe, u, mode)?,
            Bsdf::Measured(t) => {
                let wi = t.sample_direction(wo, u_lobe, u)?;
                self.continuous_sample(wo, wi, LobeFlags::REFLECTION | LobeFlags::GLOSSY, mode)
            }
        };
        sample.checked()
    }

    /// A sample of a continuous lobe towards `wi`, weighted by the whole mixture.
    fn continuous_sample(&self, wo: Vec3, wi: Vec3, flags: LobeFlags, mode: TransportMode) -> BsdfSample {
        let (f, pdf) = self.eval_pdf(wo, wi, mode);
        BsdfSample { wi, weight: f / pdf, pdf, flags, eta: 1.0 }
    }
}

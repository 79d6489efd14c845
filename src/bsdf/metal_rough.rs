//! The glTF metallic-roughness BSDF (glTF 2.0 spec Appendix B) with the extensions that add
//! lobes: KHR_materials_specular, _transmission, _volume (through `thin` and `eta`),
//! _clearcoat and _sheen. Layered top to bottom:
//!
//!   sheen  over  clearcoat  over  mix(dielectric, metal, metallic),
//!   dielectric = mix(diffuse base under a GGX specular layer, rough interface, transmission)
//!
//! Energy: the spec's `fresnel_mix` weights the base by 1 - F(v.h), which creates energy at
//! grazing incidence. Instead:
//! - The diffuse base is weighted by the energy the specular layer leaves to it, in the
//!   reciprocal form of Kelemen and Szirmay-Kalos (2001): (1 - E(wo)) (1 - E(wi)) / (1 - E_avg),
//!   with E the layer's directional albedo (`albedo.rs`). Its albedo then adds up to 1 exactly.
//! - Single-scattering GGX loses the light that bounces between microfacets (up to ~60% of a
//!   white metal at roughness 1). Both GGX reflection lobes get Kulla and Conty's (2017)
//!   compensation lobe F_ms (1 - A(wo)) (1 - A(wi)) / (pi (1 - A_avg)), A being the albedo
//!   at F = 1, so that a white metal reflects everything at every roughness.
//! - Sheen and clearcoat weight what lies under them by 1 - s max(E(wo), E(wi)): symmetric,
//!   and never more than the energy they leave.

use super::albedo::{ggx_albedo, ggx_average_albedo};
use super::dielectric::Interface;
use super::microfacet::{Ggx, reflect};
use super::sheen::Sheen;
use crate::math::{luminance, warp};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Fresnel reflectance at normal incidence of a clearcoat (ior 1.5, per the extension).
const CLEARCOAT_F0: f32 = 0.04;

/// Parameters of the glTF BSDF at one surface point.
#[derive(Clone, Copy, Debug)]
pub struct MetalRough {
    /// Base colour (diffuse albedo for dielectrics, F0 for metals, transmission tint).
    pub base: Vec3,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// GGX alpha = roughness^2.
    pub alpha: f32,
    /// Dielectric F0: ((ior - 1) / (ior + 1))^2 x specularColor, clamped to 1.
    pub dielectric_f0: Vec3,
    /// KHR_materials_specular specularFactor: weight of the dielectric layer.
    pub specular: f32,
    /// KHR_materials_specular specularColorFactor, tinting the interface's reflection.
    pub specular_tint: Vec3,
    /// KHR_materials_transmission: share of the dielectric that is a transmitting interface.
    pub transmission: f32,
    /// Relative index of refraction n_other / n_wo at the interface.
    pub eta: f32,
    /// Thin-walled transmission (no KHR_materials_volume): no bending.
    pub thin: bool,
    /// KHR_materials_clearcoat factor.
    pub clearcoat: f32,
    /// GGX alpha of the clearcoat.
    pub clearcoat_alpha: f32,
    /// KHR_materials_sheen colour (zero: no sheen).
    pub sheen: Vec3,
    /// Sheen alpha (sheenRoughness^2).
    pub sheen_alpha: f32,
}

impl Default for MetalRough {
    /// A white, rough, opaque dielectric with no optional layers.
    fn default() -> Self {
        Self {
            base: Vec3::ONE,
            metallic: 0.0,
            alpha: 1.0,
            dielectric_f0: Vec3::splat(CLEARCOAT_F0),
            specular: 1.0,
            specular_tint: Vec3::ONE,
            transmission: 0.0,
            eta: 1.5,
            thin: true,
            clearcoat: 0.0,
            clearcoat_alpha: 1.0,
            sheen: Vec3::ZERO,
            sheen_alpha: 0.25,
        }
    }
}

fn schlick_weight(cos: f32) -> f32 {
    (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    f0 + (Vec3::ONE - f0) * schlick_weight(cos)
}

/// Kulla-Conty: the colour of the multiple-scattering lobe, F_avg^2 A_avg / (1 - F_avg (1 - A_avg)),
/// with F_avg = f0 + (1 - f0) / 21 the hemispherical average of Schlick's Fresnel.
fn multiple_scattering_fresnel(f0: Vec3, a_avg: f32) -> Vec3 {
    let f_avg = f0 + (Vec3::ONE - f0) / 21.0;
    f_avg * f_avg * a_avg / (Vec3::ONE - f_avg * (1.0 - a_avg))
}

/// Probabilities of the sampling techniques at one wo, summing to 1.
struct Lobes {
    /// VNDF reflection with the base alpha (metal and dielectric specular).
    specular: f32,
    /// Cosine hemisphere (diffuse, sheen, multiple scattering).
    cosine: f32,
    /// VNDF reflection with the clearcoat's alpha.
    clearcoat: f32,
    /// The transmitting interface.
    interface: f32,
}

impl MetalRough {
    fn ggx(&self) -> Ggx {
        Ggx { alpha: self.alpha }
    }

    fn roughness(&self) -> f32 {
        self.alpha.sqrt()
    }

    /// The transmitting interface. Between equal indices (eta 1) light goes straight through
    /// whatever the microfacets, which is the thin wall's lobe; the refraction lobe's half
    /// vector would be undefined there.
    fn interface(&self) -> Interface {
        let thin = self.thin || (self.eta - 1.0).abs() < 1e-3;
        Interface { alpha: self.alpha, eta: self.eta, thin, specular: self.specular }
    }

    fn sheen_lobe(&self) -> Sheen {
        Sheen { color: self.sheen, alpha: self.sheen_alpha }
    }

    /// Whether any light passes to the other side.
    pub fn transmits(&self) -> bool {
        self.transmission > 0.0 && self.metallic < 1.0
    }

    /// Albedo of the sheen layer at cosine `mu` (0 without sheen).
    fn sheen_albedo(&self, mu: f32) -> f32 {
        let s = self.sheen.max_element();
        if s > 0.0 { s * self.sheen_lobe().albedo(mu) } else { 0.0 }
    }

    /// Albedo of the clearcoat at cosine `mu` (0 without clearcoat).
    fn clearcoat_albedo(&self, mu: f32) -> f32 {
        if self.clearcoat > 0.0 {
            self.clearcoat * ggx_albedo(mu, self.clearcoat_alpha.sqrt(), CLEARCOAT_F0)
        } else {
            0.0
        }
    }

    /// The shares of (wo, wi) that reach below sheen and below clearcoat.
    fn layer_weights(&self, mu_o: f32, mu_i: f32) -> (f32, f32) {
        let sheen = 1.0 - self.sheen_albedo(mu_o).max(self.sheen_albedo(mu_i));
        let coat = 1.0 - self.clearcoat_albedo(mu_o).max(self.clearcoat_albedo(mu_i));
        (sheen, coat)
    }

    /// Kulla-Conty lobe for (mu_o, mu_i) without its colour: (1 - A(o)) (1 - A(i)) / (pi (1 - A_avg)),
    /// and A_avg.
    fn multiple_scattering(&self, mu_o: f32, mu_i: f32) -> (f32, f32) {
        let r = self.roughness();
        let a_avg = ggx_average_albedo(r, 1.0);
        if 1.0 - a_avg < 1e-6 {
            return (0.0, a_avg);
        }
        let lobe = (1.0 - ggx_albedo(mu_o, r, 1.0)) * (1.0 - ggx_albedo(mu_i, r, 1.0)) * FRAC_1_PI / (1.0 - a_avg);
        (lobe, a_avg)
    }

    /// Directional albedo of the dielectric specular layer (single and multiple scattering)
    /// at cosine `mu`, and its cosine-weighted average, for the scalar F0 `f0`.
    fn layer_albedo(&self, mu: f32, f0: f32) -> (f32, f32) {
        let r = self.roughness();
        let a_avg = ggx_average_albedo(r, 1.0);
        let f_ms = multiple_scattering_fresnel(Vec3::splat(f0), a_avg).x;
        let e = ggx_albedo(mu, r, f0) + f_ms * (1.0 - ggx_albedo(mu, r, 1.0));
        let e_avg = ggx_average_albedo(r, f0) + f_ms * (1.0 - a_avg);
        (self.specular * e, self.specular * e_avg)
    }

    /// Share of the energy the specular layer leaves to the diffuse base, for the pair.
    fn base_weight(&self, mu_o: f32, mu_i: f32) -> f32 {
        if self.specular <= 0.0 {
            return 1.0;
        }
        let f0 = self.dielectric_f0.max_element();
        let (e_o, avg) = self.layer_albedo(mu_o, f0);
        let (e_i, _) = self.layer_albedo(mu_i, f0);
        if 1.0 - avg <= 1e-6 {
            return 0.0;
        }
        ((1.0 - e_o) * (1.0 - e_i) / (1.0 - avg)).max(0.0)
    }

    /// The opaque core's reflection (metal and dielectric-over-diffuse), f |cos theta_i|.
    fn opaque_core(&self, wo: Vec3, wi: Vec3, h: Vec3) -> Vec3 {
        let ggx = self.ggx();
        let voh = wo.dot(h);
        let single = ggx.d(h) * ggx.g2(wo, wi) / (4.0 * wo.z);
        let (ms, a_avg) = self.multiple_scattering(wo.z, wi.z);
        let ms = ms * wi.z;
        let metal = if self.metallic > 0.0 {
            schlick(self.base, voh) * single + multiple_scattering_fresnel(self.base, a_avg) * ms
        } else {
            Vec3::ZERO
        };
        let dielectric = if self.metallic < 1.0 && self.transmission < 1.0 {
            let specular = self.specular
                * (schlick(self.dielectric_f0, voh) * single
                    + multiple_scattering_fresnel(self.dielectric_f0, a_avg) * ms);
            let diffuse = self.base * (FRAC_1_PI * wi.z * self.base_weight(wo.z, wi.z));
            (diffuse + specular) * (1.0 - self.transmission)
        } else {
            Vec3::ZERO
        };
        dielectric * (1.0 - self.metallic) + metal * self.metallic
    }

    /// f |cos theta_i| for wo above the surface and wi on either side.
    pub fn eval_cos(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (sheen_w, coat_w) = self.layer_weights(wo.z, wi.z.abs());
        let interface = if self.transmits() {
            let tint = if wi.z > 0.0 { self.specular_tint } else { self.base };
            tint * (self.interface().eval_cos(wo, wi) * self.transmission * (1.0 - self.metallic))
        } else {
            Vec3::ZERO
        };
        if wi.z <= 0.0 {
            return interface * (sheen_w * coat_w);
        }
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let mut f = (self.opaque_core(wo, wi, h) + interface) * coat_w;
        if self.clearcoat > 0.0 {
            let coat = Ggx { alpha: self.clearcoat_alpha };
            let fresnel = CLEARCOAT_F0 + (1.0 - CLEARCOAT_F0) * schlick_weight(wo.dot(h));
            f += Vec3::splat(self.clearcoat * fresnel * coat.d(h) * coat.g2(wo, wi) / (4.0 * wo.z));
        }
        f *= sheen_w;
        if self.sheen.max_element() > 0.0 {
            f += self.sheen_lobe().eval_cos(wo, wi);
        }
        f
    }

    /// Probabilities of the sampling techniques, from each lobe's albedo estimated at wo.
    fn lobes(&self, wo: Vec3) -> Lobes {
        let mu = wo.z;
        let sheen = self.sheen_albedo(mu);
        let coat = self.clearcoat_albedo(mu);
        let below = (1.0 - sheen) * (1.0 - coat);
        let (m, tr) = (self.metallic, if self.transmits() { self.transmission } else { 0.0 });
        let (ms, a_avg) = self.multiple_scattering(mu, mu);
        let ms_albedo = if ms > 0.0 { 1.0 - ggx_albedo(mu, self.roughness(), 1.0) } else { 0.0 };
        let metal = luminance(schlick(self.base, mu));
        let metal_ms = luminance(multiple_scattering_fresnel(self.base, a_avg)) * ms_albedo;
        let f_d = self.specular * schlick(self.dielectric_f0, mu).max_element();
        let (layer, _) = self.layer_albedo(mu, self.dielectric_f0.max_element());
        let diffuse = (1.0 - layer).max(0.0) * luminance(self.base);
        let specular = below * (m * metal + (1.0 - m) * (1.0 - tr) * f_d);
        let cosine = sheen + below * (m * metal_ms + (1.0 - m) * (1.0 - tr) * diffuse);
        let clearcoat = (1.0 - sheen) * coat;
        let interface = below * (1.0 - m) * tr * luminance(self.base).max(f_d);
        let total = specular + cosine + clearcoat + interface;
        if total > 0.0 && total.is_finite() {
            Lobes {
                specular: specular / total,
                cosine: cosine / total,
                clearcoat: clearcoat / total,
                interface: interface / total,
            }
        } else {
            Lobes { specular: 0.0, cosine: 1.0, clearcoat: 0.0, interface: 0.0 }
        }
    }

    /// Chooses a technique with `u_lobe`, then a direction.
    pub fn sample_direction(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        let p = self.lobes(wo);
        let mut x = u_lobe;
        if x < p.interface {
            return self.interface().sample(wo, x / p.interface, u);
        }
        x -= p.interface;
        let wi = if x < p.specular {
            reflect(wo, self.ggx().sample_visible_normal(wo, u))
        } else if x < p.specular + p.clearcoat {
            reflect(wo, Ggx { alpha: self.clearcoat_alpha }.sample_visible_normal(wo, u))
        } else {
            warp::cos_hemisphere(u)
        };
        (wi.z > 0.0).then_some(wi)
    }

    /// Mixture pdf of `sample_direction`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let p = self.lobes(wo);
        let interface = if p.interface > 0.0 { p.interface * self.interface().pdf(wo, wi) } else { 0.0 };
        if wi.z <= 0.0 {
            return interface;
        }
        let coat =
            if p.clearcoat > 0.0 { p.clearcoat * Ggx { alpha: self.clearcoat_alpha }.pdf_reflect(wo, wi) } else { 0.0 };
        interface + coat + p.specular * self.ggx().pdf_reflect(wo, wi) + p.cosine * warp::cos_hemisphere_pdf(wi.z)
    }
}

//! The glTF metallic-roughness BSDF (glTF 2.0 spec Appendix B) with the extensions that add
//! lobes: KHR_materials_specular, _transmission, _volume (through `thin` and `eta`),
//! _clearcoat, _sheen, _anisotropy and _iridescence. Layered top to bottom:
//!
//!   sheen  over  clearcoat  over  mix(dielectric, metal, metallic),
//!   dielectric = mix(diffuse base under a GGX specular layer, rough interface, transmission),
//!   diffuse base = mix(Lambert reflection, Lambert transmission, diffuseTransmission)
//!
//! (KHR_materials_diffuse_transmission: the base's diffuse lobe transmits its share to the
//! other side, cosine-distributed, tinted by diffuseTransmissionColor.)
//!
//! Below `SMOOTH_ALPHA` the base's GGX lobes (metal, dielectric specular, the interface)
//! and, separately, the clearcoat are delta lobes. Their sampling aggregates what leaves in
//! the one mirror direction (and the one transmitted direction), so coinciding deltas are
//! weighted together, like the balance heuristic does for the continuous lobes.
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
//! - KHR_materials_iridescence: the metal's and the dielectric specular's Fresnel term
//!   becomes mix(Schlick, thin film, iridescence) (`thin_film.rs`, RGB), the film over a base
//!   of the index their F0 implies; the diffuse base's weight reads the tables at the
//!   film's reflectance at normal incidence mixed in the same way.
//! - Sheen and clearcoat weight what lies under them by 1 - s max(E(wo), E(wi)): symmetric,
//!   and never more than the energy they leave.
//!
//! The clearcoat has its own normal (KHR_materials_clearcoat's clearcoatNormalTexture), in
//! the local frame: its GGX lobe is the microfacet BRDF about that normal, D and G with the
//! directions' cosines to it, Fresnel at v.h, times the cosine to it (as the Khronos sample
//! renderer weights it); zero where wo or wi is below it, or wi below the base. Tilted and
//! smooth, its delta leaves in its own mirror direction, a delta of its own.

use super::albedo::{GgxAlbedo, ggx_albedo, ggx_average_albedo};
use super::dielectric::Interface;
use super::microfacet::{Ggx, reflect};
use super::sheen::Sheen;
use super::thin_film;
use super::{BsdfSample, LobeFlags, SMOOTH_ALPHA, TransportMode, is_index_matched, is_smooth};
use crate::math::{frame::Frame, warp};
use crate::spectrum::Spectrum;
use crate::spectrum::sampled::basis_at;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Fresnel reflectance at normal incidence of a clearcoat (ior 1.5, per the extension).
const CLEARCOAT_F0: f32 = 0.04;

/// Parameters of the glTF BSDF at one surface point.
#[derive(Clone, Copy, Debug)]
pub struct MetalRough {
    /// Base colour (diffuse albedo for dielectrics, F0 for metals, transmission tint).
    pub base: Spectrum,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// GGX alpha = roughness^2 (below `SMOOTH_ALPHA`: a delta lobe); with anisotropy, the
    /// width across the anisotropy direction (local y).
    pub alpha: f32,
    /// KHR_materials_anisotropy strength s in [0, 1]: along local x, the anisotropy
    /// direction, the base's GGX lobes (metal, dielectric specular, interface) have width
    /// mix(alpha, 1, s^2). The caller aligns the local frame's x with that direction.
    pub anisotropy: f32,
    /// Dielectric F0: ((ior - 1) / (ior + 1))^2 x specularColor, clamped to 1.
    pub dielectric_f0: Spectrum,
    /// KHR_materials_specular specularFactor: weight of the dielectric layer.
    pub specular: f32,
    /// KHR_materials_specular specularColorFactor, tinting the interface's reflection.
    pub specular_tint: Spectrum,
    /// KHR_materials_transmission: share of the dielectric that is a transmitting interface.
    pub transmission: f32,
    /// Relative index of refraction n_other / n_wo at the interface.
    pub eta: f32,
    /// Thin-walled transmission (no KHR_materials_volume): no bending.
    pub thin: bool,
    /// KHR_materials_clearcoat factor.
    pub clearcoat: f32,
    /// GGX alpha of the clearcoat (below `SMOOTH_ALPHA`: a delta lobe).
    pub clearcoat_alpha: f32,
    /// The clearcoat's unit normal in the local frame, above it (+z: the base's normal).
    pub clearcoat_normal: Vec3,
    /// KHR_materials_iridescence factor in [0, 1] (0: no thin film).
    pub iridescence: f32,
    /// Index of refraction of the thin film.
    pub film_ior: f32,
    /// Thickness of the thin film, nm.
    pub film_thickness: f32,
    /// The wavelength (nm) at which the spectral kernel evaluates the film exactly (the
    /// path's hero, its other wavelengths ended); None in the RGB kernel, which integrates
    /// the film to RGB.
    pub film_wavelength: Option<f32>,
    /// KHR_materials_sheen colour (zero: no sheen).
    pub sheen: Spectrum,
    /// Sheen alpha (sheenRoughness^2).
    pub sheen_alpha: f32,
    /// KHR_materials_diffuse_transmission factor: share of the diffuse base transmitted.
    pub diffuse_transmission: f32,
    /// KHR_materials_diffuse_transmission colour tinting the transmitted diffuse light.
    pub diffuse_transmission_color: Spectrum,
}

impl Default for MetalRough {
    /// A white, rough, opaque dielectric with no optional layers.
    fn default() -> Self {
        Self {
            base: Spectrum::ONE,
            metallic: 0.0,
            alpha: 1.0,
            anisotropy: 0.0,
            dielectric_f0: Spectrum::splat(CLEARCOAT_F0),
            specular: 1.0,
            specular_tint: Spectrum::ONE,
            transmission: 0.0,
            eta: 1.5,
            thin: true,
            clearcoat: 0.0,
            clearcoat_alpha: 1.0,
            clearcoat_normal: Vec3::Z,
            iridescence: 0.0,
            film_ior: 1.3,
            film_thickness: 400.0,
            film_wavelength: None,
            sheen: Spectrum::ZERO,
            sheen_alpha: 0.25,
            diffuse_transmission: 0.0,
            diffuse_transmission_color: Spectrum::ONE,
        }
    }
}

fn schlick_weight(cos: f32) -> f32 {
    (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

fn schlick(f0: Spectrum, cos: f32) -> Spectrum {
    f0 + (Spectrum::ONE - f0) * schlick_weight(cos)
}

/// Kulla-Conty: the colour of the multiple-scattering lobe, F_avg^2 A_avg / (1 - F_avg (1 - A_avg)),
/// with F_avg = f0 + (1 - f0) / 21 the hemispherical average of Schlick's Fresnel.
fn multiple_scattering_fresnel(f0: Spectrum, a_avg: f32) -> Spectrum {
    let f_avg = f0 + (Spectrum::ONE - f0) / 21.0;
    f_avg * f_avg * a_avg / (Spectrum::ONE - f_avg * (1.0 - a_avg))
}

/// Mirror image of `wo` about the normal.
fn mirror(wo: Vec3) -> Vec3 {
    Vec3::new(-wo.x, -wo.y, wo.z)
}

/// Probabilities of the sampling techniques at one wo, summing to 1.
struct Lobes {
    /// Reflection with the base alpha (metal and dielectric specular): VNDF, or a delta.
    specular: f32,
    /// Cosine hemisphere (diffuse, sheen, multiple scattering).
    cosine: f32,
    /// Reflection with the clearcoat's alpha: VNDF, or a delta.
    clearcoat: f32,
    /// The transmitting interface.
    interface: f32,
    /// Cosine hemisphere on the other side (diffuse transmission).
    diffuse_transmission: f32,
}

/// The delta lobes at one wo: the probabilities that `sample` picks the mirror direction
/// and the transmitted one, and the interface's reflectance there.
struct Deltas {
    reflection: f32,
    transmission: f32,
    interface_reflectance: f32,
    /// The probability of a smooth clearcoat's mirror direction about its tilted normal.
    coat: f32,
}

impl MetalRough {
    /// Width of the base's lobes along the anisotropy direction (local x): alpha without
    /// anisotropy.
    fn alpha_x(&self) -> f32 {
        self.alpha + (1.0 - self.alpha) * (self.anisotropy * self.anisotropy)
    }

    /// Width of the base's lobes across the anisotropy direction (local y): alpha, but at
    /// least `SMOOTH_ALPHA` where anisotropy widens the lobe along x, so that a smooth
    /// material brushed into a rough lobe is not a GGX of zero width, which divides by zero
    /// (pbrt-v4 clamps both widths likewise).
    fn alpha_y(&self) -> f32 {
        if self.anisotropy > 0.0 { self.alpha.max(SMOOTH_ALPHA) } else { self.alpha }
    }

    fn ggx(&self) -> Ggx {
        Ggx { alpha_x: self.alpha_x(), alpha_y: self.alpha_y() }
    }

    /// Roughness of the energy-compensation tables, which are isotropic: an anisotropic
    /// lobe reads them at the roughness of the isotropic lobe with the same
    /// alpha_x alpha_y (the same D(n) at normal incidence), an approximation that is
    /// exact at strength 0 and whose error grows with the aspect ratio alpha_x / alpha_y.
    fn roughness(&self) -> f32 {
        if self.anisotropy == 0.0 { self.alpha.sqrt() } else { (self.alpha_x() * self.alpha_y()).sqrt().sqrt() }
    }

    /// Whether the base's GGX lobes are deltas (narrow in both directions).
    fn smooth(&self) -> bool {
        is_smooth(self.alpha_x())
    }

    /// Whether the interface's lobes are deltas: it is smooth, or index-matched (between
    /// equal indices nothing bends and Fresnel reflects nothing, whatever the microfacets).
    fn smooth_interface(&self) -> bool {
        self.smooth() || is_index_matched(self.eta)
    }

    /// Whether the interface's transmission leaves straight through (a null lobe): a smooth
    /// thin wall, or an index-matched interface.
    fn straight(&self) -> bool {
        self.smooth_interface() && self.interface().thin
    }

    /// Whether the clearcoat is present and a delta.
    fn smooth_coat(&self) -> bool {
        self.clearcoat > 0.0 && is_smooth(self.clearcoat_alpha)
    }

    /// Whether the clearcoat's normal is not the base's.
    fn coat_tilted(&self) -> bool {
        self.clearcoat_normal != Vec3::Z
    }

    /// Whether the clearcoat can reflect light arriving from `wo`: it is not tilted, or wo
    /// is above it and, if smooth, its mirror direction above the base.
    fn coat_reflects(&self, wo: Vec3) -> bool {
        let n = self.clearcoat_normal;
        !self.coat_tilted() || (wo.dot(n) > 0.0 && (!self.smooth_coat() || reflect(wo, n).z > 0.0))
    }

    /// Cosine of `w` to the clearcoat's normal.
    fn coat_cos(&self, w: Vec3) -> f32 {
        if self.coat_tilted() { w.dot(self.clearcoat_normal) } else { w.z }
    }

    /// The smooth clearcoat's delta about its tilted normal, chosen with probability `p`:
    /// f |cos| integrated over it (Fresnel at the cosine to the normal, under the sheen),
    /// None where the mirror direction is below the base or wo below the coat.
    #[cold]
    #[inline(never)]
    fn tilted_coat_delta(&self, wo: Vec3, p: f32) -> Option<BsdfSample> {
        let n = self.clearcoat_normal;
        let cos = wo.dot(n);
        let wi = reflect(wo, n);
        if cos <= 0.0 || wi.z <= 0.0 {
            return None;
        }
        let (sheen_w, _) = self.layer_weights(wo, wi);
        let f = self.clearcoat * (CLEARCOAT_F0 + (1.0 - CLEARCOAT_F0) * schlick_weight(cos)) * sheen_w;
        let flags = LobeFlags::REFLECTION | LobeFlags::SPECULAR;
        Some(BsdfSample { wi, weight: Spectrum::splat(f / p), pdf: p, flags, eta: 1.0 })
    }

    /// The rough clearcoat's f |cos| (cosine to its normal) at (wo, wi) with half vector
    /// `h`, and the density of its VNDF sampling there.
    fn coat_eval_pdf(&self, wo: Vec3, wi: Vec3, h: Vec3) -> (f32, f32) {
        let coat = Ggx::isotropic(self.clearcoat_alpha);
        let (wo_c, wi_c, h_c) = if self.coat_tilted() {
            let frame = Frame::from_normal(self.clearcoat_normal);
            (frame.to_local(wo), frame.to_local(wi), frame.to_local(h))
        } else {
            (wo, wi, h)
        };
        if wo_c.z <= 0.0 || wi_c.z <= 0.0 {
            return (0.0, 0.0);
        }
        let dc = coat.d(h_c);
        let fresnel = CLEARCOAT_F0 + (1.0 - CLEARCOAT_F0) * schlick_weight(wo.dot(h));
        (self.clearcoat * fresnel * dc * coat.g2(wo_c, wi_c) / (4.0 * wo_c.z), coat.reflection_pdf(wo_c, dc))
    }

    /// A direction reflected about a visible normal of the rough clearcoat, above the base
    /// and the coat.
    fn sample_coat(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        if self.coat_tilted() {
            return self.sample_tilted_coat(wo, u);
        }
        Some(reflect(wo, Ggx::isotropic(self.clearcoat_alpha).sample_visible_normal(wo, u))).filter(|w| w.z > 0.0)
    }

    /// `sample_coat` about a tilted normal (kept out of line: most coats are not tilted).
    #[cold]
    #[inline(never)]
    fn sample_tilted_coat(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let coat = Ggx::isotropic(self.clearcoat_alpha);
        let frame = Frame::from_normal(self.clearcoat_normal);
        let wo_c = frame.to_local(wo);
        if wo_c.z <= 0.0 {
            return None;
        }
        let wi = reflect(wo, frame.to_world(coat.sample_visible_normal(wo_c, u)));
        (wi.z > 0.0 && wi.dot(self.clearcoat_normal) > 0.0).then_some(wi)
    }

    /// The transmitting interface. Between equal indices (eta 1) light goes straight through
    /// whatever the microfacets, which is the thin wall's lobe; the refraction lobe's half
    /// vector would be undefined there.
    fn interface(&self) -> Interface {
        let thin = self.thin || is_index_matched(self.eta);
        Interface { ggx: self.ggx(), eta: self.eta, thin, specular: self.specular }
    }

    fn sheen_lobe(&self) -> Sheen {
        Sheen { color: self.sheen, alpha: self.sheen_alpha }
    }

    /// Fresnel reflectance at cosine `cos` of a layer with normal-incidence reflectance
    /// `f0`: Schlick's, mixed with the thin film's by the iridescence factor.
    fn fresnel(&self, f0: Spectrum, cos: f32) -> Spectrum {
        let schlick = schlick(f0, cos);
        if self.iridescence > 0.0 {
            schlick * (1.0 - self.iridescence) + self.film(f0, cos) * self.iridescence
        } else {
            schlick
        }
    }

    /// The thin film's RGB reflectance at cosine `cos` over a base whose F0 is `f0`, each
    /// channel over the index its F0 implies (one evaluation when `f0` is grey). At the
    /// spectral kernel's wavelength it is the exact reflectance there, over the index of
    /// `f0`'s value at that wavelength, as grey: the integrator's upsampling is linear and
    /// turns grey into a flat spectrum, so mixed with the Schlick term it is exact at the
    /// hero wavelength, the only one the path still carries.
    fn film(&self, f0: Spectrum, cos: f32) -> Spectrum {
        let rgb = f0.to_rgb();
        if let Some(lambda) = self.film_wavelength {
            let base = thin_film::f0_to_ior(basis_at(lambda).dot(rgb).clamp(0.0, 1.0));
            return Spectrum::splat(thin_film::reflectance(cos, self.film_ior, base, self.film_thickness, lambda));
        }
        let over =
            |f: f32| thin_film::reflectance_rgb(cos, self.film_ior, thin_film::f0_to_ior(f), self.film_thickness);
        if rgb.x == rgb.y && rgb.y == rgb.z {
            return Spectrum::from_rgb(over(rgb.x));
        }
        Spectrum::from_rgb(Vec3::new(over(rgb.x).x, over(rgb.y).y, over(rgb.z).z))
    }

    /// Whether any light passes to the other side.
    pub fn transmits(&self) -> bool {
        self.refracts() || self.diffuse_transmits()
    }

    /// Whether the specular interface transmits (KHR_materials_transmission).
    fn refracts(&self) -> bool {
        self.transmission > 0.0 && self.metallic < 1.0
    }

    /// Whether the diffuse base transmits (KHR_materials_diffuse_transmission).
    fn diffuse_transmits(&self) -> bool {
        self.diffuse_transmission > 0.0 && self.transmission < 1.0 && self.metallic < 1.0
    }

    /// Relative index crossed by light the interface transmits (1 through a thin wall).
    pub fn crossed_eta(&self) -> f32 {
        if self.refracts() { self.interface().crossed_eta() } else { 1.0 }
    }

    /// The lobes present: a delta where a GGX lobe is smooth, glossy otherwise.
    pub fn flags(&self) -> LobeFlags {
        let mut flags = LobeFlags::REFLECTION;
        if self.transmits() {
            flags |= LobeFlags::TRANSMISSION;
        }
        if self.diffuse_transmits() {
            flags |= LobeFlags::DIFFUSE;
        }
        let diffuse_base = self.metallic < 1.0 && self.transmission < 1.0;
        let opaque_specular = self.metallic > 0.0 || (self.specular > 0.0 && self.transmission < 1.0);
        let interface = self.refracts();
        if diffuse_base || self.sheen.max_element() > 0.0 || (opaque_specular && !self.smooth()) {
            flags |= LobeFlags::DIFFUSE;
        }
        let rough_coat = self.clearcoat > 0.0 && !self.smooth_coat();
        if (opaque_specular && !self.smooth()) || (interface && !self.smooth_interface()) || rough_coat {
            flags |= LobeFlags::GLOSSY;
        }
        if (opaque_specular && self.smooth()) || (interface && self.smooth_interface()) || self.smooth_coat() {
            flags |= LobeFlags::SPECULAR;
        }
        if interface && self.straight() {
            flags |= LobeFlags::NULL;
        }
        flags
    }

    /// The denoiser's albedo (see `Bsdf::albedo`): the base colour, which is the diffuse
    /// colour, a metal's F0 and the transmission tint alike, its diffusely transmitted share
    /// tinted by diffuseTransmissionColor, under the sheen weighted by its albedo at `wo`
    /// (layers add up as Open Image Denoise advises; the clearcoat absorbs nothing and is left out).
    pub fn albedo(&self, wo: Vec3) -> Spectrum {
        let dt = self.diffuse_transmission * (1.0 - self.transmission) * (1.0 - self.metallic);
        let core = self.base * (1.0 - dt) + self.diffuse_transmission_color * dt;
        let s = self.sheen_albedo(wo.z);
        let sheen = if s > 0.0 { self.sheen * self.sheen_lobe().albedo(wo.z) } else { Spectrum::ZERO };
        core * (1.0 - s) + sheen
    }

    /// Albedo of the sheen layer at cosine `mu` (0 without sheen).
    fn sheen_albedo(&self, mu: f32) -> f32 {
        let s = self.sheen.max_element();
        if s > 0.0 { s * self.sheen_lobe().albedo(mu) } else { 0.0 }
    }

    /// Albedo of the clearcoat at cosine `mu` to its normal (0 without clearcoat).
    fn clearcoat_albedo(&self, mu: f32) -> f32 {
        if self.clearcoat > 0.0 {
            self.clearcoat * ggx_albedo(mu, self.clearcoat_alpha.sqrt(), CLEARCOAT_F0)
        } else {
            0.0
        }
    }

    /// The shares of (wo, wi) that reach below sheen and below clearcoat (each at the
    /// directions' cosines to its normal, wi's on either side).
    fn layer_weights(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        let sheen = 1.0 - self.sheen_albedo(wo.z).max(self.sheen_albedo(wi.z.abs()));
        let coat = if self.clearcoat > 0.0 {
            1.0 - self.clearcoat_albedo(self.coat_cos(wo)).max(self.clearcoat_albedo(self.coat_cos(wi).abs()))
        } else {
            1.0
        };
        (sheen, coat)
    }

    /// The base's GGX albedo tables at cosine `mu`, read once per direction: multiple
    /// scattering, the specular layer's albedo and the lobe probabilities all blend them
    /// (up to five times per direction otherwise).
    fn tables(&self, mu: f32) -> GgxAlbedo {
        GgxAlbedo::new(mu, self.roughness())
    }

    /// Kulla-Conty lobe for wo and wi (their `tables`) without its colour: (1 - A(o)) (1 -
    /// A(i)) / (pi (1 - A_avg)), and A_avg. A smooth lobe scatters once: no compensation.
    fn multiple_scattering(&self, t_o: GgxAlbedo, t_i: GgxAlbedo) -> (f32, f32) {
        let a_avg = ggx_average_albedo(self.roughness(), 1.0);
        if 1.0 - a_avg < 1e-6 || self.smooth() {
            return (0.0, a_avg);
        }
        let lobe = (1.0 - t_o.at(1.0)) * (1.0 - t_i.at(1.0)) * FRAC_1_PI / (1.0 - a_avg);
        (lobe, a_avg)
    }

    /// Directional albedo of the dielectric specular layer (single and multiple scattering)
    /// for a direction's `tables`, and its cosine-weighted average, for the scalar F0 `f0`.
    fn layer_albedo(&self, tables: GgxAlbedo, f0: f32) -> (f32, f32) {
        let r = self.roughness();
        let a_avg = ggx_average_albedo(r, 1.0);
        let f_ms =
            if self.smooth() { 0.0 } else { multiple_scattering_fresnel(Spectrum::splat(f0), a_avg).max_element() };
        let e = tables.at(f0) + f_ms * (1.0 - tables.at(1.0));
        let e_avg = ggx_average_albedo(r, f0) + f_ms * (1.0 - a_avg);
        (self.specular * e, self.specular * e_avg)
    }

    /// Share of the energy the specular layer leaves to the diffuse base, for the pair (their
    /// `tables`).
    fn base_weight(&self, t_o: GgxAlbedo, t_i: GgxAlbedo) -> f32 {
        if self.specular <= 0.0 {
            return 1.0;
        }
        let mut f0 = self.dielectric_f0.max_element();
        if self.iridescence > 0.0 {
            f0 += (self.film(self.dielectric_f0, 1.0).max_element() - f0) * self.iridescence;
        }
        let (e_o, avg) = self.layer_albedo(t_o, f0);
        let (e_i, _) = self.layer_albedo(t_i, f0);
        if 1.0 - avg <= 1e-6 {
            return 0.0;
        }
        ((1.0 - e_o) * (1.0 - e_i) / (1.0 - avg)).max(0.0)
    }

    /// The opaque core's continuous reflection (rough metal and dielectric specular, their
    /// multiple scattering, the diffuse base), f |cos theta_i|, with D(h) of the base.
    fn opaque_core(&self, wo: Vec3, wi: Vec3, h: Vec3, d: f32) -> Spectrum {
        let voh = wo.dot(h);
        let single = if self.smooth() { 0.0 } else { d * self.ggx().g2(wo, wi) / (4.0 * wo.z) };
        let (t_o, t_i) = (self.tables(wo.z), self.tables(wi.z));
        let (ms, a_avg) = self.multiple_scattering(t_o, t_i);
        let ms = ms * wi.z;
        let metal = if self.metallic > 0.0 {
            self.fresnel(self.base, voh) * single + multiple_scattering_fresnel(self.base, a_avg) * ms
        } else {
            Spectrum::ZERO
        };
        let dielectric = if self.metallic < 1.0 && self.transmission < 1.0 {
            let specular = (self.fresnel(self.dielectric_f0, voh) * single
                + multiple_scattering_fresnel(self.dielectric_f0, a_avg) * ms)
                * self.specular;
            let reflected = 1.0 - self.diffuse_transmission;
            let diffuse = self.base * (FRAC_1_PI * wi.z * self.base_weight(t_o, t_i) * reflected);
            (diffuse + specular) * (1.0 - self.transmission)
        } else {
            Spectrum::ZERO
        };
        dielectric * (1.0 - self.metallic) + metal * self.metallic
    }

    /// The diffuse base's transmission towards `wi` below the surface (before the layers
    /// above it), f |cos theta_i|, and the density of `sample` choosing it.
    fn diffuse_transmitted(&self, p: &Lobes, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        if !self.diffuse_transmits() {
            return (Spectrum::ZERO, 0.0);
        }
        let mu_i = -wi.z;
        let share = self.diffuse_transmission * (1.0 - self.transmission) * (1.0 - self.metallic);
        let weight = self.base_weight(self.tables(wo.z), self.tables(mu_i));
        let f = self.diffuse_transmission_color * (FRAC_1_PI * mu_i * weight * share);
        (f, p.diffuse_transmission * warp::cos_hemisphere_pdf(mu_i))
    }

    /// f |cos theta_i| of the continuous lobes and the density of `sample` choosing them,
    /// for wo above the surface and wi on either side.
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Spectrum, f32) {
        self.eval_pdf_with(&self.lobes(wo), wo, wi, mode)
    }

    /// Density with which `sample` returns `wi` from a continuous lobe.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_pdf(wo, wi, TransportMode::Radiance).1
    }

    fn eval_pdf_with(&self, p: &Lobes, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Spectrum, f32) {
        let (sheen_w, coat_w) = self.layer_weights(wo, wi);
        let (interface, interface_pdf) = if self.refracts() && !self.smooth_interface() {
            let tint = if wi.z > 0.0 { self.specular_tint } else { self.base };
            let (f, pdf) = self.interface().eval_pdf(wo, wi, mode);
            (tint * (f * self.transmission * (1.0 - self.metallic)), p.interface * pdf)
        } else {
            (Spectrum::ZERO, 0.0)
        };
        if wi.z <= 0.0 {
            let (diffuse, diffuse_pdf) = self.diffuse_transmitted(p, wo, wi);
            return ((interface + diffuse) * (sheen_w * coat_w), interface_pdf + diffuse_pdf);
        }
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3::ZERO {
            return (Spectrum::ZERO, 0.0);
        }
        let ggx = self.ggx();
        let d = if self.smooth() { 0.0 } else { ggx.d(h) };
        let mut f = (self.opaque_core(wo, wi, h, d) + interface) * coat_w;
        let mut pdf =
            interface_pdf + p.cosine * warp::cos_hemisphere_pdf(wi.z) + p.specular * ggx.reflection_pdf(wo, d);
        if self.clearcoat > 0.0 && !self.smooth_coat() {
            let (coat, coat_pdf) = self.coat_eval_pdf(wo, wi, h);
            f += Spectrum::splat(coat);
            pdf += p.clearcoat * coat_pdf;
        }
        f *= sheen_w;
        if self.sheen.max_element() > 0.0 {
            f += self.sheen_lobe().eval_cos(wo, wi);
        }
        (f, pdf)
    }

    /// Probabilities of the sampling techniques, from each lobe's albedo estimated at wo.
    fn lobes(&self, wo: Vec3) -> Lobes {
        let mu = wo.z;
        let sheen = self.sheen_albedo(mu);
        let coat =
            if self.clearcoat > 0.0 && self.coat_reflects(wo) { self.clearcoat_albedo(self.coat_cos(wo)) } else { 0.0 };
        let below = (1.0 - sheen) * (1.0 - coat);
        let (m, tr) = (self.metallic, if self.refracts() { self.transmission } else { 0.0 });
        let dt = if self.diffuse_transmits() { self.diffuse_transmission } else { 0.0 };
        let tables = self.tables(mu);
        let (ms, a_avg) = self.multiple_scattering(tables, tables);
        let ms_albedo = if ms > 0.0 { 1.0 - tables.at(1.0) } else { 0.0 };
        let metal = schlick(self.base, mu).luminance();
        let metal_ms = multiple_scattering_fresnel(self.base, a_avg).luminance() * ms_albedo;
        let f_d = self.specular * schlick(self.dielectric_f0, mu).max_element();
        let (layer, _) = self.layer_albedo(tables, self.dielectric_f0.max_element());
        let diffuse = (1.0 - layer).max(0.0) * self.base.luminance();
        let specular = below * (m * metal + (1.0 - m) * (1.0 - tr) * f_d);
        let cosine = sheen + below * (m * metal_ms + (1.0 - m) * (1.0 - tr) * diffuse * (1.0 - dt));
        let diffuse_transmission =
            below * (1.0 - m) * (1.0 - tr) * dt * (1.0 - layer).max(0.0) * self.diffuse_transmission_color.luminance();
        let clearcoat = (1.0 - sheen) * coat;
        let interface = below * (1.0 - m) * tr * self.base.luminance().max(f_d);
        let total = specular + cosine + clearcoat + interface + diffuse_transmission;
        if total > 0.0 && total.is_finite() {
            Lobes {
                specular: specular / total,
                cosine: cosine / total,
                clearcoat: clearcoat / total,
                interface: interface / total,
                diffuse_transmission: diffuse_transmission / total,
            }
        } else {
            Lobes { specular: 0.0, cosine: 1.0, clearcoat: 0.0, interface: 0.0, diffuse_transmission: 0.0 }
        }
    }

    /// The delta lobes' probabilities at wo under the technique probabilities `p`.
    fn deltas(&self, p: &Lobes, wo: Vec3) -> Deltas {
        let mut d = Deltas { reflection: 0.0, transmission: 0.0, interface_reflectance: 0.0, coat: 0.0 };
        if self.smooth() {
            d.reflection += p.specular;
        }
        if self.smooth_interface() && p.interface > 0.0 {
            let r = self.interface().reflectance(wo.z);
            d.interface_reflectance = r;
            d.reflection += p.interface * r;
            d.transmission = p.interface * (1.0 - r);
        }
        if self.smooth_coat() {
            if self.coat_tilted() {
                d.coat = p.clearcoat;
            } else {
                d.reflection += p.clearcoat;
            }
        }
        d
    }

    /// Probability that `sample` picks a delta lobe at wo.
    pub fn specular_probability(&self, wo: Vec3) -> f32 {
        let p = self.lobes(wo);
        let d = self.deltas(&p, wo);
        d.reflection + d.transmission + d.coat
    }

    /// f |cos| integrated over the mirror direction's delta: what the smooth lobes reflect.
    fn delta_reflection(&self, wo: Vec3, r: f32) -> Spectrum {
        let mu = wo.z;
        let (sheen_w, coat_w) = self.layer_weights(wo, mirror(wo));
        let mut base = Spectrum::ZERO;
        let (m, tr) = (self.metallic, if self.refracts() { self.transmission } else { 0.0 });
        if self.smooth() {
            let dielectric = self.fresnel(self.dielectric_f0, mu) * (self.specular * (1.0 - tr));
            base = self.fresnel(self.base, mu) * m + dielectric * (1.0 - m);
        }
        if self.smooth_interface() && tr > 0.0 {
            base += self.specular_tint * (r * tr * (1.0 - m));
        }
        let mut f = base * coat_w;
        if self.smooth_coat() && !self.coat_tilted() {
            f += Spectrum::splat(self.clearcoat * (CLEARCOAT_F0 + (1.0 - CLEARCOAT_F0) * schlick_weight(mu)));
        }
        f * sheen_w
    }

    /// f |cos| integrated over the transmitted direction `wi`'s delta.
    fn delta_transmission(&self, wo: Vec3, wi: Vec3, r: f32, mode: TransportMode) -> Spectrum {
        let (sheen_w, coat_w) = self.layer_weights(wo, wi);
        let share = (1.0 - r) * self.transmission * (1.0 - self.metallic) * self.interface().transmission_scale(mode);
        self.base * (share * sheen_w * coat_w)
    }

    /// What the null lobe passes straight through towards -wo, if there is one.
    pub fn null_transmission(&self, wo: Vec3) -> Option<Spectrum> {
        (self.refracts() && self.straight()).then(|| {
            let r = self.interface().reflectance(wo.z);
            self.delta_transmission(wo, -wo, r, TransportMode::Radiance)
        })
    }

    /// Chooses a technique with `u_lobe` (the deltas first: `u_lobe` below
    /// `specular_probability` picks one), then a direction from `u`.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let p = self.lobes(wo);
        let deltas = self.deltas(&p, wo);
        let mut x = u_lobe;
        if x < deltas.reflection {
            let weight = self.delta_reflection(wo, deltas.interface_reflectance) / deltas.reflection;
            let flags = LobeFlags::REFLECTION | LobeFlags::SPECULAR;
            return Some(BsdfSample { wi: mirror(wo), weight, pdf: deltas.reflection, flags, eta: 1.0 });
        }
        x -= deltas.reflection;
        if x < deltas.transmission {
            let interface = self.interface();
            let wi = interface.smooth_transmission(wo)?;
            let weight = self.delta_transmission(wo, wi, deltas.interface_reflectance, mode) / deltas.transmission;
            let mut flags = LobeFlags::TRANSMISSION | LobeFlags::SPECULAR;
            if self.straight() {
                flags |= LobeFlags::NULL;
            }
            return Some(BsdfSample { wi, weight, pdf: deltas.transmission, flags, eta: interface.crossed_eta() });
        }
        x -= deltas.transmission;
        if x < deltas.coat {
            return self.tilted_coat_delta(wo, deltas.coat);
        }
        x -= deltas.coat;
        let p_interface = if self.smooth_interface() { 0.0 } else { p.interface };
        let p_specular = if self.smooth() { 0.0 } else { p.specular };
        let p_coat = if self.smooth_coat() { 0.0 } else { p.clearcoat };
        let above = |w: Vec3| (w.z > 0.0).then_some(w);
        let (wi, glossy) = if x < p_interface {
            (self.interface().sample(wo, x / p_interface, u)?, true)
        } else if x < p_interface + p_specular {
            (above(reflect(wo, self.ggx().sample_visible_normal(wo, u)))?, true)
        } else if x < p_interface + p_specular + p_coat {
            (self.sample_coat(wo, u)?, true)
        } else if x < p_interface + p_specular + p_coat + p.diffuse_transmission {
            let w = warp::cos_hemisphere(u);
            ((w.z > 0.0).then_some(Vec3::new(w.x, w.y, -w.z))?, false)
        } else {
            (above(warp::cos_hemisphere(u))?, false)
        };
        let transmitted = wi.z < 0.0;
        let (f, pdf) = self.eval_pdf_with(&p, wo, wi, mode);
        let side = if transmitted { LobeFlags::TRANSMISSION } else { LobeFlags::REFLECTION };
        let flags = side | if glossy { LobeFlags::GLOSSY } else { LobeFlags::DIFFUSE };
        let eta = if transmitted && glossy { self.interface().crossed_eta() } else { 1.0 };
        Some(BsdfSample { wi, weight: f / pdf, pdf, flags, eta })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampler::Sampler;
    use glam::{DVec3, UVec2};
    use statrs::distribution::{ContinuousCDF, Normal};

    /// What the energy compensation can add beyond 1 per GGX layer it weights (the base
    /// under its specular layer, and under the clearcoat): the error of the albedo tables,
    /// as `albedo.rs`'s test bounds it against direct integration.
    const GGX_TABLE_ERROR: f32 = 5e-3;
    /// The same for the sheen, per unit of sheen colour: `sheen.rs`'s test bound on its table.
    const SHEEN_TABLE_ERROR: f32 = 3e-2;

    /// The direction at polar angle `theta` from the normal and azimuth `phi`.
    fn direction(theta: f32, phi: f32) -> Vec3 {
        Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    }

    /// Directions above the surface from normal incidence to 85 degrees, at azimuths that
    /// put pairs on the same side, across and opposite (mirror configurations included).
    fn upper_directions() -> Vec<Vec3> {
        let thetas = [0.0f32, 0.3, 0.7, 1.0, 1.3, 1.48];
        let phis = [0.0f32, 1.1, 2.6, std::f32::consts::PI];
        thetas.iter().flat_map(|&t| phis.iter().map(move |&p| direction(t, p))).collect()
    }

    /// The glTF BSDF over a grid of its reflecting layers, with labels: white and coloured
    /// bases, metallic, roughness (smooth to 1), specular, sheen, clearcoat (on the base's
    /// normal), anisotropy (on smooth materials too) and a refracting interface.
    fn layered() -> Vec<(String, MetalRough)> {
        let mut out = Vec::new();
        for base in [Vec3::ONE, Vec3::new(0.9, 0.5, 0.2)] {
            for metallic in [0.0f32, 0.5, 1.0] {
                for roughness in [0.0f32, 0.05, 0.3, 0.7, 1.0] {
                    for specular in [0.0f32, 0.5, 1.0] {
                        for (sheen, clearcoat) in [(0.0f32, 0.0f32), (0.8, 0.0), (0.0, 1.0), (0.8, 1.0)] {
                            for (anisotropy, transmission) in [(0.0f32, 0.0f32), (0.7, 0.0), (0.0, 0.6)] {
                                let m = MetalRough {
                                    base: Spectrum::from_rgb(base),
                                    metallic,
                                    alpha: roughness * roughness,
                                    anisotropy,
                                    specular,
                                    transmission,
                                    thin: false,
                                    clearcoat,
                                    clearcoat_alpha: 0.2,
                                    sheen: Spectrum::splat(sheen),
                                    sheen_alpha: 0.3,
                                    ..MetalRough::default()
                                };
                                let label = format!(
                                    "base {base}, metallic {metallic}, roughness {roughness}, specular {specular}, \
                                     sheen {sheen}, clearcoat {clearcoat}, anisotropy {anisotropy}, \
                                     transmission {transmission}"
                                );
                                out.push((label, m));
                            }
                        }
                    }
                }
            }
        }
        out
    }

    /// White materials that transmit (refracting from either side, thin, index-matched,
    /// diffusely) or stack every layer, at each roughness, with labels.
    fn transmitting() -> Vec<(String, MetalRough)> {
        let mut out = Vec::new();
        for roughness in [0.0f32, 0.05, 0.3, 0.7, 1.0] {
            let rough = MetalRough { alpha: roughness * roughness, thin: false, ..MetalRough::default() };
            let variants = [
                ("glass", MetalRough { transmission: 1.0, ..rough }),
                ("glass from inside", MetalRough { transmission: 1.0, eta: 1.0 / 1.5, ..rough }),
                ("thin glass", MetalRough { transmission: 1.0, thin: true, ..rough }),
                ("index-matched", MetalRough { transmission: 1.0, eta: 1.0, ..rough }),
                ("half glass", MetalRough { transmission: 0.5, ..rough }),
                ("diffuse transmission", MetalRough { diffuse_transmission: 1.0, ..rough }),
                ("half diffuse transmission", MetalRough { diffuse_transmission: 0.5, ..rough }),
                ("thin sheen", MetalRough { sheen: Spectrum::ONE, sheen_alpha: 0.01, ..rough }),
                (
                    "every layer",
                    MetalRough {
                        transmission: 0.3,
                        diffuse_transmission: 0.5,
                        clearcoat: 1.0,
                        clearcoat_alpha: 0.05,
                        sheen: Spectrum::ONE,
                        ..rough
                    },
                ),
            ];
            out.extend(variants.into_iter().map(|(name, m)| (format!("{name}, roughness {roughness}"), m)));
        }
        out
    }

    /// f(wo, wi) of the continuous lobes (eval without the cosine), radiance transport.
    fn f(m: &MetalRough, wo: Vec3, wi: Vec3) -> Vec3 {
        m.eval_pdf(wo, wi, TransportMode::Radiance).0.to_rgb() / wi.z.abs()
    }

    #[test]
    fn reflection_is_reciprocal() {
        // Every term of the reflection is symmetric in (wo, wi) by construction: D(h), G2,
        // Fresnel at v.h = l.h, the diffuse base's Kelemen weight (1 - E(wo)) (1 - E(wi)), the
        // Kulla-Conty lobe (1 - A(wo)) (1 - A(wi)), the layers' 1 - s max(E(wo), E(wi)) and the
        // sheen's 1 / max(1, E(wo), E(wi)). Only the f32 rounding of the two orders of
        // evaluation differs (v.h against l.h, the Lambdas summed the other way round, the
        // other cosine divided by): a few dozen roundings of 2^-24 each, below 1e-5 of f.
        for (label, m) in layered() {
            for &wo in &upper_directions() {
                for &wi in &upper_directions() {
                    let (fab, fba) = (f(&m, wo, wi), f(&m, wi, wo));
                    let scale = fab.max_element().max(fba.max_element());
                    assert!(
                        (fab - fba).abs().max_element() <= 1e-5 * scale,
                        "{label}: f({wo}, {wi}) = {fab}, f({wi}, {wo}) = {fba}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_tilted_clearcoat_is_the_one_layer_that_is_not_reciprocal() {
        // The coat's lobe is weighted by the cosine to its own normal (as the Khronos sample
        // renderer weights it) and f divides by the cosine to the base's, which differ once
        // the coat's normal is tilted: f(wo, wi) / f(wi, wo) = (wi.n_c wo.z) / (wo.n_c wi.z).
        let m = MetalRough {
            base: Spectrum::ZERO,
            specular: 0.0,
            clearcoat: 1.0,
            clearcoat_alpha: 0.3,
            clearcoat_normal: Vec3::new(0.5, 0.0, 1.0).normalize(),
            ..MetalRough::default()
        };
        let (wo, wi) = (direction(0.2, 0.0), direction(1.0, std::f32::consts::PI));
        let (fab, fba) = (f(&m, wo, wi).x, f(&m, wi, wo).x);
        let n = m.clearcoat_normal;
        let want = (wi.dot(n) * wo.z) / (wo.dot(n) * wi.z);
        assert!((fab / fba - want).abs() < 1e-5 * want, "f ratio {} against {want}", fab / fba);
        assert!((want - 1.0).abs() > 0.1, "the example is not reciprocal: {want}");
    }

    /// Directional albedo at `wo` per channel by `n` BSDF samples (their mean weight), and the
    /// standard error of each mean. Transmitted samples count energy: their weight carries
    /// the 1/eta^2 of radiance crossing into a denser medium, which is undone.
    fn albedo(m: &MetalRough, wo: Vec3, n: usize, sampler: &mut Sampler) -> (DVec3, DVec3) {
        let (mut sum, mut sum_sq) = (DVec3::ZERO, DVec3::ZERO);
        for _ in 0..n {
            let s = m.sample(wo, sampler.next_1d(), sampler.next_2d(), TransportMode::Radiance);
            let w = s.and_then(BsdfSample::checked).map_or(DVec3::ZERO, |s| {
                let energy = if s.wi.z < 0.0 { s.eta * s.eta } else { 1.0 };
                (s.weight.to_rgb() * energy).as_dvec3()
            });
            sum += w;
            sum_sq += w * w;
        }
        let mean = sum / n as f64;
        let var = (sum_sq / n as f64 - mean * mean).max(DVec3::ZERO) / n as f64;
        (mean, DVec3::new(var.x.sqrt(), var.y.sqrt(), var.z.sqrt()))
    }

    #[test]
    fn no_material_reflects_and_transmits_more_than_it_receives() {
        // Anisotropy and iridescence are left out: the compensation tables are read at an
        // isotropic roughness and at the film's reflectance at normal incidence,
        // approximations without a bound (a white anisotropic metal of roughness 0.3 at 86
        // degrees reflects about 1.02, a smooth iridescent dielectric at 75 degrees 1.015).
        let materials: Vec<_> =
            layered().into_iter().filter(|(_, m)| m.anisotropy == 0.0).chain(transmitting()).collect();
        let angles = [0.0f32, 0.5, 1.0, 1.3, 1.5];
        // One-sided z-tests at family-wise significance 1e-3 (Sidak) over every material,
        // angle and channel.
        let tests = materials.len() * angles.len() * 3;
        let per_test = 1.0 - (1.0 - 1e-3f64).powf(1.0 / tests as f64);
        let z_max = Normal::new(0.0, 1.0).unwrap().inverse_cdf(1.0 - per_test);
        let mut sampler = Sampler::new(UVec2::new(7, 3), 0, 11);
        for (label, m) in &materials {
            let coats = if m.clearcoat > 0.0 { 2.0 } else { 1.0 };
            let allowance = (GGX_TABLE_ERROR * coats + SHEEN_TABLE_ERROR * m.sheen.max_element()) as f64;
            for theta in angles {
                let (mean, se) = albedo(m, direction(theta, 0.4), 4000, &mut sampler);
                for c in 0..3 {
                    assert!(
                        mean[c] <= 1.0 + allowance + z_max * se[c],
                        "{label}, theta_o {theta}, channel {c}: albedo {:.5} (se {:.1e}, allowance {allowance:.3})",
                        mean[c],
                        se[c]
                    );
                }
            }
        }
    }

    #[test]
    fn a_sample_weighs_what_eval_and_pdf_say_at_its_direction() {
        // sample() evaluates the lobes with the same technique probabilities as eval_pdf():
        // the same f32 arithmetic, so 1e-5 (some 80 roundings of 2^-24) leaves room only for
        // a different order of it.
        let tilted = MetalRough {
            clearcoat: 1.0,
            clearcoat_alpha: 0.3,
            clearcoat_normal: Vec3::new(0.3, 0.2, 1.0).normalize(),
            ..MetalRough::default()
        };
        let iridescent = MetalRough { iridescence: 1.0, alpha: 0.2, ..MetalRough::default() };
        let mut materials = layered();
        materials.extend(transmitting());
        materials.push(("tilted clearcoat".into(), tilted));
        materials.push(("iridescent".into(), iridescent));
        materials.push(("iridescent metal".into(), MetalRough { metallic: 1.0, ..iridescent }));
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * a.abs().max(b.abs());
        let mut sampler = Sampler::new(UVec2::new(2, 9), 0, 5);
        let mut checked = 0;
        for (label, m) in materials {
            for &wo in &upper_directions() {
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    for _ in 0..8 {
                        let Some(s) = m.sample(wo, sampler.next_1d(), sampler.next_2d(), mode) else { continue };
                        if s.is_specular() {
                            continue;
                        }
                        let (f, pdf) = m.eval_pdf(wo, s.wi, mode);
                        let at = || format!("{label}, {mode:?}: wo {wo}, wi {}", s.wi);
                        assert!(close(s.pdf, pdf), "{}: sampled pdf {} against pdf {pdf}", at(), s.pdf);
                        let (weight, want) = (s.weight.to_rgb(), f.to_rgb() / pdf);
                        for c in 0..3 {
                            assert!(close(weight[c], want[c]), "{}: weight {weight} against f / pdf {want}", at());
                        }
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 100_000, "{checked} samples checked");
    }
}

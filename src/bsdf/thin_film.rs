//! Thin-film interference (Belcour and Barla 2017, "A Practical Extension to Microfacet
//! Theory for the Modeling of Varying Iridescence"): the Airy reflectance of a dielectric film
//! over a base (their eqs. 2-4, per polarisation, averaged), and its integration against the
//! CIE 1931 matching functions in Fourier space (their section 4: the reflectance as a
//! Fourier series in the optical path difference, each term integrated through their Gaussian
//! fit of the matching functions), to linear Rec. 709 RGB. Light arrives from index 1.

use crate::spectrum::upsample::XYZ_TO_RGB;
use glam::{Mat3, Vec3};
use std::f32::consts::PI;

/// Below this thickness (nm) the film's index fades to the outside's (1), so that a film of
/// thickness 0 is no film and its reflectance the base's plain Fresnel reflectance (as the
/// Khronos sample renderer does).
const FADE: f32 = 30.0;

/// Terms of the Fourier series kept beyond the constant one. Term m is scaled by
/// (r21 r23)^m, at most 0.12 for a white metal under a film of index 1.3: the tail after
/// three terms is below 2e-4.
const TERMS: usize = 3;

/// Fresnel amplitude reflection coefficients (s, p) from index `n1` at cosine `c1` into `n2`
/// at cosine `c2` (real, signed: negative means a phase shift of pi).
fn amplitudes(n1: f32, c1: f32, n2: f32, c2: f32) -> [f32; 2] {
    [(n1 * c1 - n2 * c2) / (n1 * c1 + n2 * c2), (n2 * c1 - n1 * c2) / (n2 * c1 + n1 * c2)]
}

/// The film at cosine `cos1` (from the outside): amplitudes at its top (r12) and bottom (r23)
/// per polarisation, and the optical path difference (nm) of one round trip through it.
fn film(cos1: f32, film_ior: f32, base_ior: f32, thickness: f32) -> ([f32; 2], [f32; 2], f32) {
    let fade = (thickness / FADE).clamp(0.0, 1.0);
    let n2 = 1.0 + (film_ior - 1.0) * fade * fade * (3.0 - 2.0 * fade);
    let cos1 = cos1.clamp(0.0, 1.0);
    let sin2 = 1.0 - cos1 * cos1;
    let cos2 = (1.0 - sin2 / (n2 * n2)).max(0.0).sqrt();
    let cos3 = (1.0 - sin2 / (base_ior * base_ior)).max(0.0).sqrt();
    let r12 = amplitudes(1.0, cos1, n2, cos2);
    let r23 = amplitudes(n2, cos2, base_ior, cos3);
    (r12, r23, 2.0 * n2 * thickness * cos2)
}

/// Reflectance at wavelength `lambda` (nm) of a film of index `film_ior` and `thickness` (nm)
/// over a base of index `base_ior` (>= 1), at cosine `cos1`: the Airy sum
/// |r12 + r23 e^(i delta)|^2 / |1 + r12 r23 e^(i delta)|^2 with delta = 2 pi OPD / lambda,
/// averaged over the two polarisations.
pub fn reflectance(cos1: f32, film_ior: f32, base_ior: f32, thickness: f32, lambda: f32) -> f32 {
    let (r12, r23, opd) = film(cos1, film_ior, base_ior, thickness);
    let cos_delta = (2.0 * PI * opd / lambda).cos();
    let mut sum = 0.0;
    for k in 0..2 {
        let (a, b) = (r12[k], r23[k]);
        sum += (a * a + b * b + 2.0 * a * b * cos_delta) / (1.0 + a * a * b * b + 2.0 * a * b * cos_delta);
    }
    0.5 * sum
}

/// Linear Rec. 709 RGB of cos(2 pi `opd` / lambda + `shift`) integrated against the CIE 1931
/// matching functions over the integral of y-bar (Belcour and Barla's eq. 15: the matching
/// functions fitted by Gaussians in wavenumber, whose Fourier transforms are Gaussians).
pub fn sensitivity(opd: f32, shift: f32) -> Vec3 {
    let phase = 2.0 * PI * opd * 1e-9;
    let gaussian = |val: f32, pos: f32, var: f32| {
        val * (2.0 * PI * var).sqrt() * (pos * phase + shift).cos() * (-phase * phase * var).exp()
    };
    let xyz = Vec3::new(
        gaussian(5.4856e-13, 1.6810e6, 4.3278e9) + gaussian(9.7470e-14, 2.2399e6, 4.5282e9),
        gaussian(4.4201e-13, 1.7953e6, 9.3046e9),
        gaussian(5.2481e-13, 2.2084e6, 6.6121e9),
    ) / 1.0685e-7;
    Mat3::from_cols_array_2d(&XYZ_TO_RGB).transpose() * xyz
}

/// The film's reflectance integrated over the spectrum, as linear RGB: the Airy sum's
/// Fourier series C0 + sum over m of 2 C_m cos(m (delta + phi)), with C0 = R12 + T^2 R23 /
/// (1 - R12 R23), C_m = (T^2 R23 / (1 - R12 R23) - T) |r21 r23|^m and phi the phase of
/// r21 r23 (0 or pi); the constant term stays grey, each cosine becomes `sensitivity`.
pub fn reflectance_rgb(cos1: f32, film_ior: f32, base_ior: f32, thickness: f32) -> Vec3 {
    let (r12, r23, opd) = film(cos1, film_ior, base_ior, thickness);
    let mut rgb = Vec3::ZERO;
    for k in 0..2 {
        let (r12_2, r23_2) = (r12[k] * r12[k], r23[k] * r23[k]);
        let t = 1.0 - r12_2;
        let q = -r12[k] * r23[k];
        let shift = if q < 0.0 { PI } else { 0.0 };
        let rs = t * t * r23_2 / (1.0 - r12_2 * r23_2);
        rgb += Vec3::splat(r12_2 + rs);
        let mut c = rs - t;
        for m in 1..=TERMS {
            c *= q.abs();
            rgb += 2.0 * c * sensitivity(m as f32 * opd, m as f32 * shift);
        }
    }
    (0.5 * rgb).max(Vec3::ZERO)
}

/// Index of refraction whose Fresnel reflectance at normal incidence from index 1 is `f0`
/// (a metal's, too, as if it had no extinction: the KHR_materials_iridescence reference).
pub fn f0_to_ior(f0: f32) -> f32 {
    let s = f0.clamp(0.0, 1.0).sqrt().min(0.99);
    (1.0 + s) / (1.0 - s)
}

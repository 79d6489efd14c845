//! Hero-wavelength spectral sampling (Wilkie et al. 2014, "Hero Wavelength Spectral
//! Sampling"): each path carries `Spectrum::CHANNELS` wavelengths, the hero drawn by
//! importance over the visible range and the others at equal offsets of the sampling
//! variable, so that every wavelength is distributed alike and their estimates combine by
//! the balance heuristic. The visible-range density is pbrt-v4's
//! (`SampleVisibleWavelengths`: p(l) proportional to 1 / cosh^2(0.0072 (l - 538)) on 360 to
//! 830 nm). The film turns the wavelengths' radiance into XYZ through the CIE 1931
//! matching functions and then into linear sRGB (`to_rgb`).

use super::Spectrum;
use super::cie::{CMF, D65, LAMBDA_MAX, LAMBDA_MIN};
use super::upsample::{BASIS, XYZ_TO_RGB};
use glam::{Mat3, Vec3};

/// Wavelengths per path.
pub const N: usize = Spectrum::CHANNELS;

/// Density of `sample_visible` at wavelength `lambda` (nm), per nm; 0 outside 360 to 830.
pub fn visible_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    0.003_939_804 / (0.0072 * (lambda - 538.0)).cosh().powi(2)
}

/// A wavelength drawn from `visible_pdf` by inverting its CDF at `u` in [0, 1).
pub fn sample_visible(u: f32) -> f32 {
    (538.0 - 138.888_89 * (0.856_910_6 - 1.827_502 * u).atanh()).clamp(LAMBDA_MIN, LAMBDA_MAX)
}

/// Index and fraction of `lambda` in a table of `len` values every `step` nm from 360 nm.
fn locate(len: usize, step: f32, lambda: f32) -> (usize, f32) {
    let x = ((lambda - LAMBDA_MIN) / step).clamp(0.0, (len - 1) as f32);
    let i = (x as usize).min(len - 2);
    (i, x - i as f32)
}

/// Linear interpolation in a table of triples every `step` nm from 360 nm.
pub(crate) fn lerp3(values: &[[f32; 3]], step: f32, lambda: f32) -> Vec3 {
    let (i, t) = locate(values.len(), step, lambda);
    Vec3::from(values[i]) * (1.0 - t) + Vec3::from(values[i + 1]) * t
}

/// Linear interpolation in a table of values every `step` nm from 360 nm.
fn lerp1(values: &[f32], step: f32, lambda: f32) -> f32 {
    let (i, t) = locate(values.len(), step, lambda);
    values[i] * (1.0 - t) + values[i + 1] * t
}

/// The CIE 1931 matching functions (x-bar, y-bar, z-bar) at `lambda`.
pub fn cmf(lambda: f32) -> Vec3 {
    lerp3(&CMF, 1.0, lambda)
}

/// D65 scaled so that its luminance under the matching functions is 1: the spectral shape
/// of an emitter whose linear sRGB is white (1, 1, 1).
pub fn d65(lambda: f32) -> f32 {
    lerp1(&D65, 5.0, lambda) / super::upsample::D65_Y
}

/// The upsampling basis at `lambda` nm: the reflectance spectrum of linear sRGB `rgb` takes
/// the value `basis_at(lambda).dot(rgb)` there.
pub fn basis_at(lambda: f32) -> Vec3 {
    lerp3(&BASIS, 5.0, lambda)
}

/// The wavelengths of one path, their densities, and what colours become at them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampled {
    /// Wavelengths, nm; the first is the hero.
    pub lambda: [f32; N],
    /// Density of each (0 once a secondary wavelength has been terminated).
    pub pdf: [f32; N],
    /// The upsampling basis at each wavelength (reflectance = basis . rgb).
    basis: [Vec3; N],
    /// The white illuminant at each wavelength.
    illuminant: Spectrum,
}

impl Sampled {
    /// Wavelengths for the sample `u` in [0, 1): the hero at `u`, the others at `u + i / N`
    /// (mod 1) of the sampling variable.
    pub fn new(u: f32) -> Self {
        let mut lambda = [0.0; N];
        let mut pdf = [0.0; N];
        let mut basis = [Vec3::ZERO; N];
        let mut illuminant = [0.0; N];
        for i in 0..N {
            let ui = (u + i as f32 / N as f32).fract();
            lambda[i] = sample_visible(ui);
            pdf[i] = visible_pdf(lambda[i]);
            basis[i] = basis_at(lambda[i]);
            illuminant[i] = d65(lambda[i]);
        }
        Self { lambda, pdf, basis, illuminant: Spectrum::from_rgb(Vec3::from(illuminant)) }
    }

    /// Reflectance (or any coefficient) of linear sRGB `rgb` at the wavelengths.
    #[inline]
    pub fn reflectance(&self, rgb: Vec3) -> Spectrum {
        Spectrum::from_rgb(Vec3::new(self.basis[0].dot(rgb), self.basis[1].dot(rgb), self.basis[2].dot(rgb)))
    }

    /// Emitted light of linear sRGB `rgb` at the wavelengths: the colour's reflectance
    /// spectrum times the white illuminant (pbrt-v4's RGBIlluminantSpectrum).
    #[inline]
    pub fn illuminant(&self, rgb: Vec3) -> Spectrum {
        self.reflectance(rgb) * self.illuminant
    }

    /// Ends every wavelength but the hero, which then stands for all of them (at a
    /// dispersive interface, where the wavelengths would part ways).
    pub fn terminate_secondary(&mut self) {
        if self.secondary_terminated() {
            return;
        }
        for p in &mut self.pdf[1..] {
            *p = 0.0;
        }
        self.pdf[0] /= N as f32;
    }

    /// Whether only the hero wavelength is left.
    pub fn secondary_terminated(&self) -> bool {
        self.pdf[1..].iter().all(|&p| p == 0.0)
    }

    /// Linear sRGB of the radiance `l` carried at the wavelengths: the Monte Carlo estimate
    /// of XYZ = integral of L cmf, each wavelength weighted 1 / (N pdf), normalised so that
    /// the white illuminant has Y = 1, then the colour space's XYZ-to-RGB matrix.
    pub fn to_rgb(&self, l: Spectrum) -> Vec3 {
        let mut xyz = Vec3::ZERO;
        for i in 0..N {
            if self.pdf[i] > 0.0 {
                xyz += cmf(self.lambda[i]) * (l.get(i) / (N as f32 * self.pdf[i]));
            }
        }
        Mat3::from_cols_array_2d(&XYZ_TO_RGB).transpose() * (xyz / super::upsample::CMF_Y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_visible_pdf_integrates_to_one_and_the_sampler_inverts_its_cdf() {
        let n = 47_000;
        let h = (LAMBDA_MAX - LAMBDA_MIN) / n as f32;
        let total: f32 = (0..n).map(|i| visible_pdf(LAMBDA_MIN + (i as f32 + 0.5) * h) * h).sum();
        assert!((total - 1.0).abs() < 1e-3, "{total}");
        let mut cdf = 0.0;
        for i in 0..n {
            let l = LAMBDA_MIN + (i as f32 + 0.5) * h;
            cdf += visible_pdf(l) * h;
            if i % 4700 == 0 {
                assert!((sample_visible(cdf) - (l + 0.5 * h)).abs() < 0.5, "at {l}");
            }
        }
    }

    #[test]
    fn terminating_the_secondary_wavelengths_gives_the_hero_all_the_weight() {
        let mut s = Sampled::new(0.3);
        let white = s.to_rgb(s.illuminant(Vec3::ONE));
        let hero = s.pdf[0];
        s.terminate_secondary();
        assert_eq!(s.pdf[0], hero / N as f32);
        assert!(s.secondary_terminated());
        s.terminate_secondary();
        assert_eq!(s.pdf[0], hero / N as f32, "terminating twice changes nothing");
        assert!(s.to_rgb(s.illuminant(Vec3::ONE)).is_finite() && white.is_finite());
    }
}

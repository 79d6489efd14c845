//! The quantity light transport carries: what a BSDF returns, a light emits, a path's
//! throughput holds and the film receives, in linear Rec. 709 RGB or at a path's sampled
//! wavelengths (`Wavelengths`, `sampled`: hero-wavelength sampling; `upsample`: RGB to
//! spectrum; `cie`: the CIE 1931 observer and D65).

pub mod cie;
pub mod sampled;
pub mod upsample;

use glam::Vec3;
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Sub};

/// What a path's spectra hold: linear sRGB channels, or the radiance at the path's sampled
/// wavelengths. Scene parts (BSDFs, lights, the environment, media coefficients) return
/// RGB; the integrator turns what they return into the path's spectra through `reflectance`
/// and `illuminant`. Because the upsampling (`upsample`) is linear and turns 1 into 1, that
/// equals upsampling their inputs for every quantity affine in each colour, which covers
/// the BSDFs' lobes (the multiple-scattering Fresnel compensation excepted, a few percent
/// of rough metals' energy) and tabulated RGB data; extinction is upsampled before it is
/// exponentiated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Wavelengths {
    /// The RGB kernel: spectra are linear sRGB and conversions do nothing.
    Rgb,
    /// The spectral kernel's wavelengths for this path.
    Sampled(sampled::Sampled),
}

impl Wavelengths {
    /// A reflectance, transmittance, BSDF value or coefficient returned as RGB, on this path.
    #[inline]
    pub fn reflectance(&self, rgb: Spectrum) -> Spectrum {
        match self {
            Wavelengths::Rgb => rgb,
            Wavelengths::Sampled(s) => s.reflectance(rgb.0),
        }
    }

    /// Emitted radiance returned as RGB, on this path.
    #[inline]
    pub fn illuminant(&self, rgb: Spectrum) -> Spectrum {
        match self {
            Wavelengths::Rgb => rgb,
            Wavelengths::Sampled(s) => s.illuminant(rgb.0),
        }
    }

    /// The hero wavelength (nm) of a spectral path.
    pub fn hero(&self) -> Option<f32> {
        match self {
            Wavelengths::Rgb => None,
            Wavelengths::Sampled(s) => Some(s.lambda[0]),
        }
    }

    /// Ends all wavelengths but the hero (a no-op for RGB).
    pub fn terminate_secondary(&mut self) {
        if let Wavelengths::Sampled(s) = self {
            s.terminate_secondary();
        }
    }

    /// Whether a spectral path kept only its hero wavelength.
    pub fn secondary_terminated(&self) -> bool {
        matches!(self, Wavelengths::Sampled(s) if s.secondary_terminated())
    }

    /// Radiance `l` that only the hero wavelength carries (its other wavelengths were
    /// terminated on a path joined to this one), expressed on this path: `to_rgb` of the
    /// result is what the terminated wavelengths would make of `l`.
    pub fn hero_only(&self, l: Spectrum) -> Spectrum {
        match self {
            Wavelengths::Sampled(s) if !s.secondary_terminated() => {
                Spectrum::from_rgb(glam::Vec3::new(l.get(0) * sampled::N as f32, 0.0, 0.0))
            }
            _ => l,
        }
    }

    /// Linear sRGB of the radiance `l` carried on this path.
    #[inline]
    pub fn to_rgb(&self, l: Spectrum) -> Spectrum {
        match self {
            Wavelengths::Rgb => l,
            Wavelengths::Sampled(s) => Spectrum(s.to_rgb(l)),
        }
    }
}

/// Radiance, reflectance or throughput, per colour channel (linear Rec. 709 RGB) or per
/// sampled wavelength (see `Wavelengths`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spectrum(Vec3);

impl Spectrum {
    /// Number of channels (wavelength samples) a spectrum holds.
    pub const CHANNELS: usize = 3;

    /// No light.
    pub const ZERO: Self = Self(Vec3::ZERO);
    /// A white of 1 in every channel.
    pub const ONE: Self = Self(Vec3::ONE);

    /// The same value in every channel.
    pub const fn splat(v: f32) -> Self {
        Self(Vec3::splat(v))
    }

    /// A reflectance, transmittance or coefficient given as linear RGB.
    pub const fn from_rgb(rgb: Vec3) -> Self {
        Self(rgb)
    }

    /// Emitted light given as linear RGB (radiance or intensity).
    pub const fn from_illuminant_rgb(rgb: Vec3) -> Self {
        Self(rgb)
    }

    /// Linear RGB of this spectrum, for the film and for tests.
    pub const fn to_rgb(self) -> Vec3 {
        self.0
    }

    /// Channel `i` (0..CHANNELS).
    pub fn get(self, i: usize) -> f32 {
        self.0[i]
    }

    /// Mean over the channels.
    pub fn average(self) -> f32 {
        (self.0.x + self.0.y + self.0.z) / 3.0
    }

    /// Largest channel.
    pub fn max_element(self) -> f32 {
        self.0.max_element()
    }

    /// Smallest channel.
    pub fn min_element(self) -> f32 {
        self.0.min_element()
    }

    /// Whether every channel is finite.
    pub fn is_finite(self) -> bool {
        self.0.is_finite()
    }

    /// Whether every channel is exactly zero.
    pub fn is_black(self) -> bool {
        self.0 == Vec3::ZERO
    }

    /// Luminance (ITU-R BT.709 weights), for choosing among lobes and lights.
    pub fn luminance(self) -> f32 {
        crate::math::luminance(self.0)
    }

    /// Channel-wise exponential, for transmittance.
    pub fn exp(self) -> Self {
        Self(Vec3::new(self.0.x.exp(), self.0.y.exp(), self.0.z.exp()))
    }

    /// Channel-wise minimum.
    pub fn min(self, other: Self) -> Self {
        Self(self.0.min(other.0))
    }

    /// Channel-wise maximum.
    pub fn max(self, other: Self) -> Self {
        Self(self.0.max(other.0))
    }

    /// Each channel clamped to [lo, hi].
    pub fn clamp(self, lo: f32, hi: f32) -> Self {
        Self(self.0.clamp(Vec3::splat(lo), Vec3::splat(hi)))
    }

    /// Channel-wise map.
    pub fn map(self, f: impl Fn(f32) -> f32) -> Self {
        Self(Vec3::new(f(self.0.x), f(self.0.y), f(self.0.z)))
    }
}

impl Add for Spectrum {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self(self.0 + o.0)
    }
}

impl AddAssign for Spectrum {
    fn add_assign(&mut self, o: Self) {
        self.0 += o.0;
    }
}

impl Sub for Spectrum {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self(self.0 - o.0)
    }
}

impl Mul for Spectrum {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        Self(self.0 * o.0)
    }
}

impl MulAssign for Spectrum {
    fn mul_assign(&mut self, o: Self) {
        self.0 *= o.0;
    }
}

impl Mul<f32> for Spectrum {
    type Output = Self;
    fn mul(self, s: f32) -> Self {
        Self(self.0 * s)
    }
}

impl Mul<Spectrum> for f32 {
    type Output = Spectrum;
    fn mul(self, s: Spectrum) -> Spectrum {
        Spectrum(self * s.0)
    }
}

impl MulAssign<f32> for Spectrum {
    fn mul_assign(&mut self, s: f32) {
        self.0 *= s;
    }
}

impl Div for Spectrum {
    type Output = Self;
    fn div(self, o: Self) -> Self {
        Self(self.0 / o.0)
    }
}

impl Div<f32> for Spectrum {
    type Output = Self;
    fn div(self, s: f32) -> Self {
        Self(self.0 / s)
    }
}

impl DivAssign<f32> for Spectrum {
    fn div_assign(&mut self, s: f32) {
        self.0 /= s;
    }
}

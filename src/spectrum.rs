//! The quantity light transport carries: what a BSDF returns, a light emits, a path's
//! throughput holds and the film receives. Today it is linear Rec. 709 RGB; spectral
//! rendering changes what a `Spectrum` is here, and the two places where colours enter
//! (`from_rgb`, `from_illuminant_rgb`) and leave (`to_rgb`) transport.

use glam::Vec3;
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Sub};

/// Radiance, reflectance or throughput, per colour channel (linear Rec. 709 RGB).
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

//! Display transform: exposure, a tone curve and the sRGB encoding; the accumulated data
//! is never touched.

use crate::params::Domain;
use glam::Vec3;
use serde::{Deserialize, Serialize};

crate::choice_enum! {
    /// Tone curves mapping scene-linear radiance to display-linear [0, 1]: a clamp
    /// (radiometrically faithful below 1, clipping highlights), Narkowicz's fit of the ACES
    /// filmic curve (2015), or Khronos PBR Neutral (2024), which keeps base colours faithful
    /// and compresses highlights instead of clipping them, the default as in the Khronos
    /// glTF Sample Viewer.
    pub enum Tonemap {
        Linear = "linear": "clamp to [0, 1]",
        Aces = "aces": "Narkowicz's fit of the ACES filmic curve",
        #[default]
        PbrNeutral = "pbr-neutral": "Khronos PBR Neutral",
    }
}

impl Tonemap {
    /// Applies the curve to one linear colour.
    pub fn apply(self, c: Vec3) -> Vec3 {
        match self {
            Tonemap::Linear => c,
            Tonemap::Aces => (c * (2.51 * c + 0.03)) / (c * (2.43 * c + 0.59) + 0.14),
            Tonemap::PbrNeutral => pbr_neutral(c),
        }
        .clamp(Vec3::ZERO, Vec3::ONE)
    }
}

/// Khronos PBR Neutral tone mapping, from the reference implementation of the spec.
fn pbr_neutral(mut c: Vec3) -> Vec3 {
    const START: f32 = 0.8 - 0.04;
    const DESATURATION: f32 = 0.15;
    let x = c.min_element();
    let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
    c -= offset;
    let peak = c.max_element();
    if peak < START {
        return c;
    }
    let d = 1.0 - START;
    let new_peak = 1.0 - d * d / (peak + d - START);
    c *= new_peak / peak;
    let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    c.lerp(Vec3::splat(new_peak), g)
}

/// sRGB opto-electronic transfer function (IEC 61966-2-1) for a linear value in [0, 1].
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

/// Entries of the sRGB encoding table over display-linear [0, 1].
const SRGB_LUT_SIZE: usize = 4096;

/// 8-bit sRGB codes for display-linear values i / (SRGB_LUT_SIZE - 1): the encoding costs a
/// lookup instead of a `powf` per channel (within one code of the exact encoding).
static SRGB_LUT: std::sync::LazyLock<Vec<u8>> = std::sync::LazyLock::new(|| {
    (0..SRGB_LUT_SIZE).map(|i| (linear_to_srgb(i as f32 / (SRGB_LUT_SIZE - 1) as f32) * 255.0 + 0.5) as u8).collect()
});

crate::params! {
    /// How linear radiance is shown: exposure in EV, then a tone curve, then sRGB.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    #[serde(default)]
    pub struct Display, table DISPLAY {
        /// Exposure in stops for display and PNG output (radiance is scaled by 2^exposure).
        exposure: f32 = 0.0, ["exposure", "exposure (EV)", Display, Domain::Float { min: -20.0, max: 20.0, optional: false }, |_| true],
        /// Tone curve for display and PNG output.
        tonemap: Tonemap = Tonemap::PbrNeutral, ["tonemap", "tone curve", Display, Domain::Choice(Tonemap::CHOICES), |_| true],
    }
}

impl Display {
    /// Linear radiance to 8-bit sRGB; non-finite values show as black.
    pub fn to_srgb8(&self, radiance: Vec3) -> [u8; 3] {
        let scaled = radiance * self.exposure.exp2();
        let scaled = if scaled.is_finite() { scaled } else { Vec3::ZERO };
        let lut = &*SRGB_LUT;
        self.tonemap.apply(scaled).to_array().map(|c| lut[(c * (SRGB_LUT_SIZE - 1) as f32 + 0.5) as usize])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encodes_black_white_and_mid_grey() {
        let d = Display { tonemap: Tonemap::Linear, ..Display::default() };
        assert_eq!(d.to_srgb8(Vec3::ZERO), [0, 0, 0]);
        assert_eq!(d.to_srgb8(Vec3::ONE), [255, 255, 255]);
        assert_eq!(d.to_srgb8(Vec3::splat(0.2158605)), [128, 128, 128]);
        let brighter = Display { exposure: 1.0, ..d };
        assert_eq!(brighter.to_srgb8(Vec3::splat(0.2158605 / 2.0)), [128, 128, 128]);
        assert_eq!(d.to_srgb8(Vec3::NAN), [0, 0, 0]);
        for i in 0..=1000 {
            let c = i as f32 / 1000.0;
            let exact = linear_to_srgb(c) * 255.0;
            assert!((d.to_srgb8(Vec3::splat(c))[0] as f32 - exact).abs() <= 1.0, "within one code at {c}");
        }
    }

    #[test]
    fn tone_curves_are_monotonic_and_bounded() {
        for op in [Tonemap::Linear, Tonemap::Aces, Tonemap::PbrNeutral] {
            let mut last = -1.0f32;
            for i in 0..2000 {
                let v = op.apply(Vec3::splat(i as f32 * 0.01)).x;
                assert!((0.0..=1.0).contains(&v) && v >= last, "{op:?} at {i}");
                last = v;
            }
        }
        assert!(Tonemap::PbrNeutral.apply(Vec3::splat(100.0)).x > 0.99, "highlights approach white");
        let dark = Vec3::new(0.3, 0.2, 0.1);
        assert!((Tonemap::PbrNeutral.apply(dark) - (dark - 0.04)).abs().max_element() < 1e-6, "base colours kept");
    }
}

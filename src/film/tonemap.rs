//! Display transform: exposure, clamp and the sRGB encoding; the accumulated data is never touched.

use glam::Vec3;

/// sRGB opto-electronic transfer function (IEC 61966-2-1) for a linear value in [0, 1].
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

/// Linear radiance to 8-bit sRGB after scaling by 2^`exposure_ev` and clamping to [0, 1].
pub fn to_srgb8(radiance: Vec3, exposure_ev: f32) -> [u8; 3] {
    let scaled = radiance * exposure_ev.exp2();
    scaled.to_array().map(|c| {
        let c = if c.is_finite() { c.clamp(0.0, 1.0) } else { 0.0 };
        (linear_to_srgb(c) * 255.0 + 0.5) as u8
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encodes_black_white_and_mid_grey() {
        assert_eq!(to_srgb8(Vec3::ZERO, 0.0), [0, 0, 0]);
        assert_eq!(to_srgb8(Vec3::ONE, 0.0), [255, 255, 255]);
        assert_eq!(to_srgb8(Vec3::splat(0.2158605), 0.0), [128, 128, 128]);
        assert_eq!(to_srgb8(Vec3::splat(0.2158605 / 2.0), 1.0), [128, 128, 128]);
    }
}

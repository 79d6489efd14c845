//! Environment texels stored as Radiance RGBE (Ward, "Real Pixels", Graphics Gems II, 1991):
//! three 8-bit mantissas sharing an exponent, 4 bytes a texel instead of 12. A map decoded
//! from an .hdr file holds exactly such values, so they are kept bit for bit; a map whose
//! texels are not all RGBE values (an .exr, say) keeps them as floats.

use glam::Vec3;

/// `SCALE[e]` = 2^(e - 136), the value of a mantissa step at exponent byte `e`, and 0 for
/// `e` = 0: the factor the `image` crate's .hdr decoder multiplies each mantissa by. Built
/// from its bits (exact powers of two, subnormal below `e` = 10), so a texel decodes to the
/// same float the file decoded to.
const SCALE: [f32; 256] = {
    let mut scale = [0.0f32; 256];
    let mut e = 1;
    while e < 256 {
        scale[e] = f32::from_bits(if e >= 10 { (e as u32 - 9) << 23 } else { 1 << (e + 13) });
        e += 1;
    }
    scale
};

/// A map's texels, row-major.
pub(super) enum Texels {
    /// Mantissas (r, g, b) and the shared exponent byte.
    Rgbe(Vec<[u8; 4]>),
    /// Floats, for maps that RGBE cannot hold exactly.
    Linear(Vec<Vec3>),
}

impl Texels {
    /// The texels as RGBE if every one of them is an RGBE value exactly, else as they are.
    pub(super) fn new(texels: Vec<Vec3>) -> Self {
        match texels.iter().map(|&t| encode(t)).collect::<Option<Vec<_>>>() {
            Some(rgbe) => Self::Rgbe(rgbe),
            None => Self::Linear(texels),
        }
    }

    /// Texel `i`.
    #[inline]
    pub(super) fn get(&self, i: usize) -> Vec3 {
        match self {
            Self::Rgbe(t) => decode(t[i]),
            Self::Linear(t) => t[i],
        }
    }
}

/// The texel's RGB value, each mantissa times its exponent's step (the decoder's product).
#[inline]
fn decode([r, g, b, e]: [u8; 4]) -> Vec3 {
    let scale = SCALE[e as usize];
    Vec3::new(scale * r as f32, scale * g as f32, scale * b as f32)
}

/// `t` as RGBE if `decode` gives it back bit for bit, the only test needed: a mantissa that
/// is not a whole number of steps, beyond 255, negative, a -0 or not a number does not
/// come back. The exponent is the one that puts the largest component's mantissa in
/// [128, 256): for a float of biased exponent B, e = B + 2.
fn encode(t: Vec3) -> Option<[u8; 4]> {
    let e = u8::try_from((t.max_element().to_bits() >> 23 & 0xff) + 2).ok()?;
    let scale = SCALE[e as usize];
    let [r, g, b] = t.to_array().map(|v| (v / scale) as u8);
    let rgbe = [r, g, b, e];
    (decode(rgbe).to_array().map(f32::to_bits) == t.to_array().map(f32::to_bits)).then_some(rgbe)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The value the `image` crate decodes RGBE bytes to (`Rgbe8Pixel::to_hdr`).
    fn reference([r, g, b, e]: [u8; 4]) -> Vec3 {
        let exp = f32::from_bits(if e > 1 { ((e - 1) as u32) << 23 } else { (e as u32) << 22 }) * 0.00390625;
        Vec3::new(exp * r as f32, exp * g as f32, exp * b as f32)
    }

    #[test]
    fn every_rgbe_value_is_kept_bit_for_bit() {
        // Every exponent, with normalised and unnormalised mantissas.
        for e in 1..=255u8 {
            for (r, g, b) in [(128, 0, 7), (255, 255, 255), (200, 129, 1), (3, 64, 2), (0, 0, 1)] {
                let v = reference([r, g, b, e]);
                let texels = Texels::new(vec![v]);
                assert!(matches!(texels, Texels::Rgbe(_)) || v.max_element() < f32::MIN_POSITIVE, "e {e}: {v}");
                assert_eq!(texels.get(0).to_array().map(f32::to_bits), v.to_array().map(f32::to_bits), "e {e}: {v}");
            }
        }
    }

    #[test]
    fn maps_rgbe_cannot_hold_stay_floats() {
        let exact = reference([200, 10, 3, 130]);
        assert!(matches!(Texels::new(vec![exact, Vec3::ZERO]), Texels::Rgbe(_)));
        // A half float's 11 bits do not fit 8: one such texel keeps the whole map as floats.
        let texels = Texels::new(vec![exact, Vec3::new(1.0 + 1.0 / 1024.0, 0.5, 0.25)]);
        assert!(matches!(texels, Texels::Linear(_)));
        assert_eq!(texels.get(1), Vec3::new(1.0 + 1.0 / 1024.0, 0.5, 0.25));
        // Components too far apart for one exponent; a negative zero, which RGBE lacks.
        assert!(matches!(Texels::new(vec![Vec3::new(1000.0, 1e-6, 0.0)]), Texels::Linear(_)));
        assert!(matches!(Texels::new(vec![Vec3::new(0.0, -0.0, 0.0)]), Texels::Linear(_)));
    }
}

//! Shared maths: orthonormal frames, sample warps with their pdfs, samplers, discrete and
//! piecewise-constant distributions, and float error bounds.

pub mod distribution;
pub mod float;
pub mod frame;
pub mod sampler;
pub mod warp;

use glam::Vec3;

/// Luminance of a linear Rec. 709 colour (the weights of ITU-R BT.709).
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// `i` wrapped into 0..n (`rem_euclid`), without its 64-bit division when `i` is already
/// inside, as texel coordinates almost always are (a bilinear lookup wraps four to eight).
#[inline]
pub fn wrap_index(i: i64, n: i64) -> i64 {
    if (0..n).contains(&i) { i } else { i.rem_euclid(n) }
}

#[cfg(test)]
mod tests {
    #[test]
    fn wrap_index_is_rem_euclid() {
        for n in [1i64, 3, 1024] {
            for i in -3 * n - 2..3 * n + 2 {
                assert_eq!(super::wrap_index(i, n), i.rem_euclid(n), "{i} mod {n}");
            }
        }
    }
}

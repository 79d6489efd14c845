//! Deterministic per-sample random numbers: every value is a pure function of
//! (pixel, sample index, seed), so images do not depend on the thread count
//! (pbrt-v4's `IndependentSampler`: a PCG32 stream per pixel, advanced to the sample).

use glam::{UVec2, Vec2};
use rand_core::RngCore;
use rand_pcg::Pcg32;

/// Dimensions reserved per sample; a path never draws this many numbers, so streams
/// of consecutive samples never overlap.
const DIMENSIONS_PER_SAMPLE: u64 = 1 << 16;

/// Source of uniform numbers in [0, 1) for one pixel sample.
pub struct Sampler {
    rng: Pcg32,
}

impl Sampler {
    /// Starts the stream of sample `index` of `pixel` for `seed`.
    pub fn new(pixel: UVec2, index: u64, seed: u64) -> Self {
        let stream = hash3(pixel.x as u64, pixel.y as u64, seed);
        let mut rng = Pcg32::new(mix64(stream ^ 0x9e37_79b9_7f4a_7c15), stream);
        rng.advance(index.wrapping_mul(DIMENSIONS_PER_SAMPLE));
        Self { rng }
    }

    /// Next uniform number in [0, 1), with 24 bits of precision (exactly representable).
    pub fn next_1d(&mut self) -> f32 {
        (self.rng.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Next pair of uniform numbers in [0, 1)^2.
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }
}

/// A 64-bit finaliser (the one of SplitMix64, Steele et al. 2014): avalanches every bit.
pub fn mix64(mut v: u64) -> u64 {
    v = (v ^ (v >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    v = (v ^ (v >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    v ^ (v >> 31)
}

/// Hash of three words, for seeding per-pixel streams and permutations.
pub fn hash3(a: u64, b: u64, c: u64) -> u64 {
    mix64(mix64(mix64(a) ^ b) ^ c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_pure_functions_of_pixel_index_and_seed() {
        let draw = |p, i, s| {
            let mut r = Sampler::new(p, i, s);
            [r.next_1d(), r.next_1d(), r.next_1d()]
        };
        let p = UVec2::new(3, 7);
        assert_eq!(draw(p, 5, 1), draw(p, 5, 1));
        assert_ne!(draw(p, 5, 1), draw(p, 6, 1));
        assert_ne!(draw(p, 5, 1), draw(p, 5, 2));
        assert_ne!(draw(p, 5, 1), draw(UVec2::new(7, 3), 5, 1));
        assert!(draw(p, 5, 1).iter().all(|&x| (0.0..1.0).contains(&x)));
    }

    #[test]
    fn stream_of_sample_i_continues_where_the_index_says() {
        let p = UVec2::new(1, 2);
        let mut a = Sampler::new(p, 0, 9);
        for _ in 0..DIMENSIONS_PER_SAMPLE {
            a.next_1d();
        }
        let mut b = Sampler::new(p, 1, 9);
        assert_eq!(a.next_1d(), b.next_1d());
    }
}

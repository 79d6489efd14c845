//! Deterministic per-sample numbers: every value is a pure function of (pixel, sample
//! index, seed, dimension), so images do not depend on the thread count. Two kinds:
//! independent (pbrt-v4's `IndependentSampler`: a PCG32 stream per pixel, advanced to the
//! sample) and low-discrepancy (Owen-scrambled Sobol, Burley 2020, from the building
//! blocks of `sobol_burley::parts`).

use glam::{UVec2, Vec2};
use rand_core::RngCore;
use rand_pcg::Pcg32;
use sobol_burley::parts::{hash, owen_scramble_rev, sobol_rev, u32_to_f32_norm};
use std::sync::LazyLock;

crate::choice_enum! {
    /// Which sequence pixel samples draw their numbers from. Owen-scrambled Sobol points are
    /// scrambled per pixel and per draw: each pixel's samples are stratified in every 1D or
    /// 2D draw (the pixel position, then each bounce's choices), and every single sample is
    /// still uniform, so the estimate stays unbiased.
    pub enum SamplerKind {
        Independent = "independent": "independent uniform numbers (PCG32)",
        #[default]
        Sobol = "sobol": "Owen-scrambled Sobol points, stratified per pixel and draw",
    }
}

/// Sample indices per Sobol sequence (the crate's maximum); later samples continue in
/// an independently scrambled sequence.
const SOBOL_LENGTH: u64 = 1 << 16;

/// Dimensions reserved per sample; a path never draws this many numbers, so streams
/// of consecutive samples never overlap.
const DIMENSIONS_PER_SAMPLE: u64 = 1 << 16;

/// Source of uniform numbers in [0, 1) for one pixel sample.
pub struct Sampler {
    inner: Inner,
}

enum Inner {
    /// The stream, and where this sample's part of it starts (for `fork`).
    Independent(Pcg32, Pcg32),
    /// Sample `index` of the pixel's sequences, its bits reversed (scrambled from
    /// `scramble`); `dimension` counts the draws made so far.
    Sobol { index_rev: u32, scramble: u64, dimension: u32 },
}

impl Sampler {
    /// Starts the independent stream of sample `index` of `pixel` for `seed`.
    pub fn new(pixel: UVec2, index: u64, seed: u64) -> Self {
        Self::independent(hash3(pixel.x as u64, pixel.y as u64, seed), index)
    }

    /// Sample `index` of the independent stream `stream` (a pixel's hashed seed).
    fn independent(stream: u64, index: u64) -> Self {
        let mut rng = Pcg32::new(mix64(stream ^ 0x9e37_79b9_7f4a_7c15), stream);
        rng.advance(index.wrapping_mul(DIMENSIONS_PER_SAMPLE));
        Self { inner: Inner::Independent(rng.clone(), rng) }
    }

    /// Starts sample `index` of `pixel` for `seed` from the sequence of `kind`.
    pub fn of_kind(kind: SamplerKind, pixel: UVec2, index: u64, seed: u64) -> Self {
        Self::replicated(kind, 1, pixel, index, seed)
    }

    /// Starts sample `index` of `pixel` for `seed`, the pixel's samples split among
    /// `replicates` independent randomisations (R >= 1): for Sobol, sample i is point i / R
    /// of a sequence scrambled for (pixel, seed, i mod R), so the R replicate means are
    /// independent and their spread estimates the error of the pixel's mean honestly
    /// (randomised QMC, Owen 1997; L'Ecuyer and Lemieux 2002). One replicate is the single
    /// sequence of `of_kind`. Independent samples are independent already: R changes nothing.
    pub fn replicated(kind: SamplerKind, replicates: u32, pixel: UVec2, index: u64, seed: u64) -> Self {
        PixelSequence::new(kind, replicates, pixel, seed).sampler(index)
    }

    /// Next uniform number in [0, 1), with 24 bits of precision (exactly representable).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        match &mut self.inner {
            Inner::Independent(rng, _) => (rng.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32),
            Inner::Sobol { index_rev, scramble, dimension } => {
                *dimension += 1;
                sobol_1d(*index_rev, draw_seed(*scramble, *dimension))
            }
        }
    }

    /// Next pair of uniform numbers in [0, 1)^2. For Sobol, the first two dimensions of a
    /// sequence scrambled for this draw (pbrt-v4's padded Sobol), so that the pairs of
    /// one pixel's samples are stratified in 2D, and different draws are independent.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        match &mut self.inner {
            Inner::Independent(..) => {
                let x = self.next_1d();
                Vec2::new(x, self.next_1d())
            }
            Inner::Sobol { index_rev, scramble, dimension } => {
                *dimension += 1;
                Vec2::from(sobol_2d(*index_rev, draw_seed(*scramble, *dimension)))
            }
        }
    }
}

impl Sampler {
    /// The same sample's numbers from draw `dimension` on, whatever this one has drawn: a
    /// fixed place in the sample's stream for draws that follow a variable number of others
    /// so that each is stratified over the pixel's samples. `dimension` stays below `DIMENSIONS_PER_SAMPLE` / 2.
    pub fn fork(&self, dimension: u32) -> Sampler {
        debug_assert!((dimension as u64) < DIMENSIONS_PER_SAMPLE / 2);
        let inner = match &self.inner {
            Inner::Independent(_, start) => {
                let mut rng = start.clone();
                rng.advance(2 * dimension as u64);
                Inner::Independent(rng, start.clone())
            }
            Inner::Sobol { index_rev, scramble, .. } => {
                Inner::Sobol { index_rev: *index_rev, scramble: *scramble, dimension }
            }
        };
        Sampler { inner }
    }
}

/// What the samples of one pixel share for a seed, computed once for all of them: the
/// pixel's hashed seed and the scramble of its first Sobol sequence (six 64-bit mixes that
/// starting each sample on its own, `Sampler::replicated`, computes again every time).
#[derive(Clone, Copy, Debug)]
pub struct PixelSequence {
    kind: SamplerKind,
    replicates: u64,
    pixel_seed: u64,
    /// `scramble(pixel_seed, 0, 0)`: replicate 0's first `SOBOL_LENGTH` points.
    first: u64,
}

impl PixelSequence {
    /// The samples of `pixel` for `seed` from the sequence of `kind`, split among
    /// `replicates` randomisations as `Sampler::replicated` describes.
    pub fn new(kind: SamplerKind, replicates: u32, pixel: UVec2, seed: u64) -> Self {
        let pixel_seed = hash3(pixel.x as u64, pixel.y as u64, seed);
        Self { kind, replicates: replicates.max(1) as u64, pixel_seed, first: scramble(pixel_seed, 0, 0) }
    }

    /// Starts sample `index`: the same numbers as `Sampler::replicated` gives.
    #[inline]
    pub fn sampler(&self, index: u64) -> Sampler {
        match self.kind {
            SamplerKind::Independent => Sampler::independent(self.pixel_seed, index),
            SamplerKind::Sobol => {
                let r = self.replicates;
                let (replicate, point) = if r == 1 { (0, index) } else { (index % r, index / r) };
                let block = point / SOBOL_LENGTH;
                let scramble =
                    if (replicate, block) == (0, 0) { self.first } else { scramble(self.pixel_seed, block, replicate) };
                let index_rev = ((point % SOBOL_LENGTH) as u32).reverse_bits();
                Sampler { inner: Inner::Sobol { index_rev, scramble, dimension: 0 } }
            }
        }
    }
}

/// The scramble of the Sobol sequence of a pixel (its hashed seed) for its `block`-th run
/// of `SOBOL_LENGTH` points of `replicate`.
fn scramble(pixel_seed: u64, block: u64, replicate: u64) -> u64 {
    hash3(pixel_seed, block, 0x50b0 ^ replicate << 16)
}

/// Sobol dimensions 0 and 1 (low and high half) of the 16 leading bits of a bit-reversed
/// index, one table per byte. The points are linear over GF(2) in the index's bits, so a
/// byte's entry is the XOR of `sobol_rev` of its set bits taken alone. `sobol_rev` itself
/// loops over the set bits, a chain of dependent shifts ending in a mispredicted branch.
struct SobolTables {
    high: [u64; 256],
    low: [u64; 256],
}

static SOBOL_TABLES: LazyLock<SobolTables> = LazyLock::new(|| {
    let basis = |bit: u32| {
        let x = 1u32 << bit;
        sobol_rev(x, 0) as u64 | (sobol_rev(x, 1) as u64) << 32
    };
    let table =
        |shift: u32| std::array::from_fn(|b| (0..8).filter(|k| b >> k & 1 == 1).fold(0, |t, k| t ^ basis(shift + k)));
    SobolTables { high: table(24), low: table(16) }
});

/// Sobol dimensions 0 (low half) and 1 (high half) of the index whose reversed bits are
/// `index_rev`, shuffled by a nested uniform scramble (Burley 2020) keyed by the low half
/// of the draw's `seed`.
#[inline]
fn sobol_bits(index_rev: u32, seed: u64) -> u64 {
    let t = &*SOBOL_TABLES;
    let shuffled = owen_scramble_rev(index_rev, seed as u32);
    t.high[(shuffled >> 24) as usize] ^ t.low[(shuffled >> 16 & 0xff) as usize]
}

/// Point `index` (bits reversed in `index_rev`) of the 2D Sobol sequence for `seed`: the
/// shuffled point with each coordinate Owen-scrambled on its own, so the points of any 2^k
/// prefix stay a (0, k, 2)-net. The 64 bits of `seed` key the shuffle (low half) and the
/// first coordinate's scramble (high half); a hash of the latter keys the second's. One
/// 64-bit reversal turns both back.
#[inline]
fn sobol_2d(index_rev: u32, seed: u64) -> [f32; 2] {
    let bits = sobol_bits(index_rev, seed);
    let x = owen_scramble_rev(bits as u32, (seed >> 32) as u32);
    let y = owen_scramble_rev((bits >> 32) as u32, hash((seed >> 32) as u32 ^ 0x2545_f491));
    let both = (x as u64 | (y as u64) << 32).reverse_bits();
    [u32_to_f32_norm((both >> 32) as u32), u32_to_f32_norm(both as u32)]
}

/// The first coordinate of `sobol_2d`, alone.
#[inline]
fn sobol_1d(index_rev: u32, seed: u64) -> f32 {
    let x = owen_scramble_rev(sobol_bits(index_rev, seed) as u32, (seed >> 32) as u32);
    u32_to_f32_norm(x.reverse_bits())
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

/// Scrambling seeds of draw number `draw` of a pixel's sequence: 64 mixed bits, split
/// between the scrambles (two hashes per draw fewer than keying each scramble by a hash).
fn draw_seed(scramble: u64, draw: u32) -> u64 {
    mix64(scramble ^ draw as u64)
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
    fn a_fork_draws_what_a_fresh_sample_draws_there_whatever_was_drawn_before() {
        let p = UVec2::new(2, 6);
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            for index in [0, 9] {
                let mut fresh = Sampler::of_kind(kind, p, index, 5);
                for _ in 0..40 {
                    fresh.next_2d();
                }
                let expected = [fresh.next_2d(), fresh.next_2d()];
                for drawn in [0, 3, 57] {
                    let mut s = Sampler::of_kind(kind, p, index, 5);
                    for _ in 0..drawn {
                        s.next_1d();
                    }
                    let mut f = s.fork(40);
                    assert_eq!([f.next_2d(), f.next_2d()], expected, "{kind:?}, sample {index}, {drawn} drawn");
                }
            }
        }
    }

    #[test]
    fn sobol_points_of_a_pixel_are_stratified_in_every_2d_draw() {
        // 256 samples: in each 2D draw, one point per cell of a 16x16 grid, and in each
        // coordinate one point per 1/256 interval (the (0, 2)-net property).
        let p = UVec2::new(5, 9);
        let draws: Vec<Vec<f32>> = (0..256u64)
            .map(|i| {
                let mut s = Sampler::of_kind(SamplerKind::Sobol, p, i, 3);
                let mut v = Vec::new();
                for _ in 0..5 {
                    let q = s.next_2d();
                    v.extend([q.x, q.y]);
                }
                v
            })
            .collect();
        for pair in 0..5 {
            let mut cells = [0u32; 256];
            let mut bins = [0u32; 256];
            for d in &draws {
                let (x, y) = (d[2 * pair], d[2 * pair + 1]);
                cells[(y * 16.0) as usize * 16 + (x * 16.0) as usize] += 1;
                bins[(x * 256.0) as usize] += 1;
            }
            assert!(cells.iter().all(|&c| c == 1), "pair {pair}: {cells:?}");
            assert!(bins.iter().all(|&c| c == 1), "pair {pair}: 1D");
        }
    }

    #[test]
    fn the_tables_give_the_sobol_points_of_every_index() {
        for i in 0..(1u32 << 16) {
            let rev = i.reverse_bits();
            let t = &*SOBOL_TABLES;
            let bits = t.high[(rev >> 24) as usize] ^ t.low[(rev >> 16 & 0xff) as usize];
            assert_eq!((bits as u32, (bits >> 32) as u32), (sobol_rev(rev, 0), sobol_rev(rev, 1)), "index {i}");
        }
    }

    #[test]
    fn sobol_samples_are_pure_functions_and_differ_between_pixels_and_seeds() {
        let draw = |p, i, s| {
            let mut r = Sampler::of_kind(SamplerKind::Sobol, p, i, s);
            [r.next_1d(), r.next_1d(), r.next_1d()]
        };
        let p = UVec2::new(3, 7);
        assert_eq!(draw(p, 5, 1), draw(p, 5, 1));
        assert_ne!(draw(p, 5, 1), draw(p, 5, 2));
        assert_ne!(draw(p, 5, 1), draw(UVec2::new(7, 3), 5, 1));
        assert_ne!(draw(p, 5, 1), draw(p, 5 + SOBOL_LENGTH, 1));
    }

    #[test]
    fn each_replicate_is_a_stratified_sequence_of_its_own() {
        // Two replicates: samples 0, 2, 4, ... are the points of one scrambled sequence and
        // 1, 3, 5, ... of another, each stratified (one point per 1/64 of the first draw's
        // x), and different (independent scrambles). One replicate is the single sequence;
        // the independent sampler ignores replicates.
        let p = UVec2::new(2, 5);
        let first = |r: u32, i: u64| Sampler::replicated(SamplerKind::Sobol, r, p, i, 7).next_2d();
        for replicate in 0..2 {
            let mut bins = [0u32; 64];
            for i in (replicate..128).step_by(2) {
                bins[(first(2, i).x * 64.0) as usize] += 1;
            }
            assert!(bins.iter().all(|&c| c == 1), "replicate {replicate}: {bins:?}");
        }
        assert_ne!(first(2, 0), first(2, 1));
        for i in [0, 5, 70_000] {
            assert_eq!(first(1, i), Sampler::of_kind(SamplerKind::Sobol, p, i, 7).next_2d());
        }
        let independent = |r: u32| Sampler::replicated(SamplerKind::Independent, r, p, 6, 7).next_2d();
        assert_eq!(independent(2), independent(1), "independent samples need no replicates");
    }

    #[test]
    fn a_pixels_sequences_are_keyed_by_pixel_seed_block_and_replicate() {
        let p = UVec2::new(4, 11);
        for (replicates, index) in [(1, 3), (1, 70_000), (2, 0), (2, 7), (2, 131_075)] {
            let Inner::Sobol { index_rev, scramble, .. } =
                PixelSequence::new(SamplerKind::Sobol, replicates, p, 7).sampler(index).inner
            else {
                panic!("a Sobol sampler")
            };
            let (replicate, point) = (index % replicates as u64, index / replicates as u64);
            let key = hash3(hash3(4, 11, 7), point / SOBOL_LENGTH, 0x50b0 ^ replicate << 16);
            assert_eq!((scramble, index_rev), (key, ((point % SOBOL_LENGTH) as u32).reverse_bits()), "{index}");
        }
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

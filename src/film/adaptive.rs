//! Adaptive sampling to a noise threshold, as Cycles' (Blender manual, "Sampling: Adaptive
//! Sampling"; its error test follows Dammertz et al. 2010): a pixel stops taking samples
//! once the estimated relative standard error of its luminance, with an absolute floor for
//! near-black pixels, is below the threshold, while the others keep going.
//!
//! The estimate must be honest for the sampler. For independent samples the sample variance
//! over n is. For Owen-scrambled Sobol it is not: the samples are stratified, so their mean
//! is better than their spread says. Such renders draw from two independently scrambled
//! replicates (`Sampler::replicated`), and the variance of the mean of two independent,
//! identically distributed replicate means m0 and m1 is estimated without bias by
//! (m0 - m1)^2 / 4 (randomised QMC: Owen 1997; L'Ecuyer and Lemieux 2002, section 4). That
//! has one degree of freedom, and where rare paths carry the light (a caustic seen through
//! a diffuse bounce) it is often exactly 0: both replicates met the same number of them.
//! So a pixel's variance is its sample variance over n (n - 1 degrees of freedom, which see
//! every outlier among its samples) times the sampler's local gain over independent
//! sampling, the ratio of the replicate variances to the sample variances summed over its
//! neighbours (`gains`), which leave its own samples out so that the product stays unbiased.
//!
//! A pixel stops when both its own relative error and its neighbourhood's (the mean
//! per-sample relative variance of its 3x3 neighbourhood, over its sample count) are below
//! the threshold: its own keeps a pixel with an outlier going, the neighbourhood's keeps
//! going one that has not met the rare paths its neighbours met. This is biased, as any
//! stop decided from the pixel's own samples: a pixel that has not met the rare paths yet
//! looks both darker and converged. On the glass Cornell box (32x32, at most 256 spp, 12
//! seeds) the image mean is 1.1% low at 5% with 16 spp first, 0.7% with 64 (the default),
//! and not measurably at 2%. Deciding from the neighbours alone removed the bias (+0.2%,
//! z = 0.75) but froze the outliers: a pixel that met a rare path among quiet neighbours
//! stopped with it, and the relative MSE at equal time was 10 times uniform sampling's.
//!
//! Decisions are deterministic: pixels are checked only at fixed sample counts (4, 6, 8,
//! 12, 16, 24, ...: 2^k and 3 2^(k-1) from the minimum on, so that every check sees whole
//! aligned blocks of each replicate's Sobol sequence), from the sums of the pixel and its
//! neighbours at that count, and the neighbourhood is cut at the tile's edges, so that a
//! tile decides alone: whatever the thread count, the pass sizes, or which window of the
//! frame a piece renders (windows on the tile grid).

use super::accum::{ErrorSums, PixelSums, Tile};
use crate::math::sampler::SamplerKind;
use glam::DVec3;

/// Luminance weights of linear sRGB (Rec. 709).
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Luminance under which the error is taken relative to this floor instead (radiance
/// 1e-3, about 10 stops below white): near-black pixels stop on their absolute error.
pub const LUMINANCE_FLOOR: f64 = 1e-3;

/// The smallest sample count at which a pixel may stop.
pub const FIRST_CHECK: u32 = 4;

/// Luminance of a linear sRGB colour.
pub fn luminance(rgb: DVec3) -> f64 {
    LUMINANCE[0] * rgb.x + LUMINANCE[1] * rgb.y + LUMINANCE[2] * rgb.z
}

/// How a pixel's error is estimated, and whether the estimate is honest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorEstimate {
    /// Sample variance over n, of independent samples: unbiased.
    Samples,
    /// Sample variance over n times the sampler's local gain, from two independently
    /// scrambled Sobol replicates (`gains`): unbiased.
    Replicates,
    /// Sample variance over n of one Owen-scrambled Sobol sequence: its samples are
    /// stratified, so this overstates the error of their mean (the variance tenfold on the
    /// Cornell box at 64 spp, tests/adaptive.rs).
    Overstated,
}

impl ErrorEstimate {
    /// The estimate a render with `sampler` makes, drawing from two replicates or not.
    pub fn of(sampler: SamplerKind, replicates: bool) -> Self {
        match (sampler, replicates) {
            (SamplerKind::Independent, _) => ErrorEstimate::Samples,
            (SamplerKind::Sobol, true) => ErrorEstimate::Replicates,
            (SamplerKind::Sobol, false) => ErrorEstimate::Overstated,
        }
    }

    /// Whether the estimate is unbiased (not an overstatement).
    pub fn honest(self) -> bool {
        self != ErrorEstimate::Overstated
    }
}

/// The means of a pixel's two replicates (samples of even and of odd index), if both
/// have samples.
fn replicate_means(px: &PixelSums, e: &ErrorSums) -> Option<(DVec3, DVec3)> {
    let odd = px.count.checked_sub(e.half_count).filter(|&n| n > 0)?;
    (e.half_count > 0).then(|| (e.half / e.half_count as f64, (px.total() - e.half) / odd as f64))
}

/// Variance of a pixel's mean luminance from its replicates, (L0 - L1)^2 / 4: unbiased,
/// one degree of freedom; infinite until both replicates have samples.
pub fn replicate_variance(px: &PixelSums, e: &ErrorSums) -> f64 {
    replicate_means(px, e).map_or(f64::INFINITY, |(m0, m1)| (luminance(m0) - luminance(m1)).powi(2) / 4.0)
}

/// Sample variance of a pixel's luminance over n (covariance between channels included):
/// the variance of the mean of independent samples; infinite under two samples.
pub fn sample_variance(px: &PixelSums, e: &ErrorSums) -> f64 {
    if px.count < 2 {
        return f64::INFINITY;
    }
    let n = px.count as f64;
    let sum = luminance(px.total());
    ((e.luminance_sq - sum * sum / n) / (n - 1.0)).max(0.0) / n
}

/// Per pixel of a tile, the sampler's local gain over independent sampling: the ratio of
/// the summed replicate variances to the summed sample variances over the other pixels of
/// its 3x3 neighbourhood inside the tile (a ratio estimator from up to eight replicate
/// pairs, each of one degree of freedom; independent of the pixel's own samples, so that
/// its own sample variance, scaled by it, stays an unbiased estimate); 1 without
/// replicates, where the samples are independent, and where the neighbours' samples do not
/// vary.
pub fn gains(tile: &Tile, replicates: bool) -> Vec<f64> {
    let (w, h) = (tile.size.x as usize, tile.size.y as usize);
    if !replicates {
        return vec![1.0; w * h];
    }
    let pairs: Vec<(f64, f64)> = (0..w * h)
        .map(|i| {
            (replicate_variance(&tile.pixels[i], &tile.errors[i]), sample_variance(&tile.pixels[i], &tile.errors[i]))
        })
        .collect();
    (0..w * h)
        .map(|i| {
            let (replicate, sample) = neighbourhood(i, w, h)
                .filter(|&j| j != i)
                .fold((0.0, 0.0), |(r, s), j| (r + pairs[j].0, s + pairs[j].1));
            if sample > 0.0 { replicate / sample } else { 1.0 }
        })
        .collect()
}

/// The pixels of the 3x3 neighbourhood of pixel `i` of a `w` x `h` tile, itself included.
fn neighbourhood(i: usize, w: usize, h: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (i % w, i / w);
    (y.saturating_sub(1)..(y + 2).min(h))
        .flat_map(move |ny| (x.saturating_sub(1)..(x + 2).min(w)).map(move |nx| ny * w + nx))
}

/// Per pixel of a tile, the estimated variance of its mean luminance: its sample variance
/// over n times the local gain (`gains`). The sample variance has n - 1 degrees of freedom
/// and sees every outlier among the pixel's samples; the gain corrects it for the
/// stratification of Sobol samples, which it overstates.
pub fn luminance_variances(tile: &Tile, gains: &[f64]) -> Vec<f64> {
    (0..tile.pixels.len()).map(|i| gains[i] * sample_variance(&tile.pixels[i], &tile.errors[i])).collect()
}

/// Variance of a pixel's mean per channel, as `luminance_variances`: the sample variance
/// over n times the local gain.
pub fn channel_variance(px: &PixelSums, gain: f64) -> DVec3 {
    px.variance_of_mean() * gain
}

/// The next sample count above `n` at which pixels are checked, with `min_spp` the least:
/// 2^k and 3 2^(k-1), from `FIRST_CHECK` (4, 6, 8, 12, 16, 24, ...).
pub fn next_check(n: u64, min_spp: u32) -> u64 {
    let mut c = FIRST_CHECK as u64;
    while c <= n || c < min_spp as u64 {
        c += 1 << (c.ilog2() - 1);
    }
    c
}

/// Checks the tile's pixels that are still taking samples, which have just reached `n`
/// samples (a check count): each stops where its squared relative error
/// (`luminance_variances` over the squared luminance, or `LUMINANCE_FLOOR` squared) and
/// its neighbourhood's (the mean per-sample relative variance over its 3x3 neighbourhood
/// inside the tile, over its own sample count) are both below `threshold`^2. Decisions read
/// the tile's state before any of them is applied.
pub fn check(tile: &mut Tile, n: u32, threshold: f64, replicates: bool) {
    let (w, h) = (tile.size.x as usize, tile.size.y as usize);
    let variances = luminance_variances(tile, &gains(tile, replicates));
    let relative: Vec<f64> =
        (0..w * h).map(|i| variances[i] / luminance(tile.pixels[i].mean()).max(LUMINANCE_FLOOR).powi(2)).collect();
    let per_sample: Vec<f64> = (0..w * h).map(|i| relative[i] * tile.pixels[i].count as f64).collect();
    let target = threshold * threshold;
    let stopping: Vec<usize> = (0..w * h)
        .filter(|&i| tile.stopped_at[i] == 0 && relative[i] < target)
        .filter(|&i| {
            let (sum, count) = neighbourhood(i, w, h).fold((0.0, 0.0), |(s, c), j| (s + per_sample[j], c + 1.0));
            sum / count / (tile.pixels[i].count as f64) < target
        })
        .collect();
    for i in stopping {
        tile.stopped_at[i] = n;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Film;
    use crate::spectrum::Spectrum;
    use glam::UVec2;

    #[test]
    fn checks_come_at_powers_of_two_and_halfway_between_from_the_minimum_on() {
        let mut checks = vec![next_check(0, 1)];
        while checks.len() < 9 {
            checks.push(next_check(*checks.last().unwrap(), 1));
        }
        assert_eq!(checks, [4, 6, 8, 12, 16, 24, 32, 48, 64]);
        assert_eq!(next_check(0, 16), 16);
        assert_eq!(next_check(16, 16), 24);
        assert_eq!(next_check(17, 20), 24);
        assert_eq!(next_check(100, 16), 128);
    }

    #[test]
    fn replicate_variance_is_a_quarter_of_the_squared_difference_of_the_replicate_means() {
        let mut film = Film::new(1, 1).with_threshold();
        let tile = &mut film.tiles[0];
        for (i, v) in [1.0f32, 5.0, 3.0, 7.0].into_iter().enumerate() {
            let r = Spectrum::splat(v);
            tile.add(UVec2::ZERO, r);
            tile.add_error(UVec2::ZERO, i as u64, r);
        }
        // Even samples 1, 3 (mean 2), odd 5, 7 (mean 6): (2 - 6)^2 / 4 = 4.
        let (px, e) = (&tile.pixels[0], &tile.errors[0]);
        assert!((replicate_variance(px, e) - 4.0).abs() < 1e-9);
        // The samples' luminance variance: s^2 = 20 / 3 over n = 4.
        assert!((sample_variance(px, e) - 20.0 / 12.0).abs() < 1e-9);
        assert_eq!(channel_variance(px, 2.0), DVec3::splat(2.0 * 20.0 / 12.0));
    }

    /// A 1-row tile of pixels whose 8 samples alternate by `spread` (relative) about 1.
    fn row(spreads: &[f32]) -> Film {
        let mut film = Film::new(spreads.len() as u32, 1).with_threshold();
        let tile = &mut film.tiles[0];
        for i in 0..8u64 {
            for (x, spread) in spreads.iter().enumerate() {
                let v = Spectrum::splat(1.0 + if i % 2 == 0 { -spread } else { *spread });
                tile.add(UVec2::new(x as u32, 0), v);
                tile.add_error(UVec2::new(x as u32, 0), i, v);
            }
        }
        film
    }

    #[test]
    fn a_pixel_stops_where_it_and_its_neighbourhood_are_below_the_threshold() {
        // Flat, flat, flat, noisy, flat: the first two stop; the third has a noisy
        // neighbour, the fourth is noisy, the fifth has a noisy neighbour.
        let mut film = row(&[0.0, 0.001, 0.0, 0.5, 0.0]);
        check(&mut film.tiles[0], 8, 0.01, false);
        assert_eq!(film.tiles[0].stopped_at, [8, 8, 0, 0, 0]);
        assert!(!film.tiles[0].active(UVec2::new(0, 0)) && film.tiles[0].active(UVec2::new(2, 0)));
        // Threshold 0 stops nothing; neither does an error not known yet (one sample).
        let mut film = row(&[0.0, 0.0]);
        check(&mut film.tiles[0], 8, 0.0, false);
        assert_eq!(film.tiles[0].stopped_at, [0, 0]);
        let mut film = Film::new(2, 1).with_threshold();
        film.tiles[0].add(UVec2::ZERO, Spectrum::splat(1.0));
        check(&mut film.tiles[0], 4, 0.5, false);
        assert_eq!(film.tiles[0].stopped_at, [0, 0]);
    }

    #[test]
    fn the_gain_scales_a_pixels_sample_variance_by_its_neighbours_replicates() {
        // Alternating samples 1 - s, 1 + s put the two replicates' means 2s apart: their
        // variance s^2 is 7 times the sample variance over n (s^2 8/7 / 8). The pixel's own
        // samples take no part in its gain; without neighbours it is 1.
        let film = row(&[0.1, 0.1, 0.2]);
        let tile = &film.tiles[0];
        let g = gains(tile, true);
        assert!((g[0] - 7.0).abs() < 1e-9 && (g[1] - 7.0).abs() < 1e-9, "{g:?}");
        assert_eq!(gains(tile, false), [1.0; 3]);
        assert_eq!(gains(&row(&[0.1]).tiles[0], true), [1.0]);
        let v = luminance_variances(tile, &g);
        let sample = sample_variance(&tile.pixels[0], &tile.errors[0]);
        assert!((v[0] - 7.0 * sample).abs() < 1e-12);
    }
}

//! Adaptive sampling to a noise threshold, as Cycles' (Blender manual, "Sampling: Adaptive
//! Sampling"; its error test follows Dammertz et al. 2010): a pixel stops taking samples
//! once the estimated relative standard error of its luminance, with an absolute floor for
//! near-black pixels, is below the threshold, while the others keep going.
//!
//! The estimate must be honest for the sampler. For independent samples the sample variance
//! over n is. For Owen-scrambled Sobol it is not: the samples are stratified, so their mean
//! is better than their spread says. Such renders draw from two independently scrambled
//! replicates instead (`Sampler::replicated`), and the variance of the mean of two
//! independent, identically distributed replicate means m0 and m1 is estimated without bias
//! by (m0 - m1)^2 / 4 (randomised QMC: Owen 1997; L'Ecuyer and Lemieux 2002, section 4).
//!
//! Whether a pixel stops is decided from its neighbours' samples, not its own: the mean
//! per-sample relative variance of the other pixels of its 3x3 neighbourhood, over the
//! pixel's sample count. A decision from the pixel's own samples correlates with its own
//! mean where rare paths carry much of the light (a caustic seen through a diffuse
//! bounce): a pixel that has not met them yet looks both darker and converged, and stops
//! there. On the glass Cornell box (32x32, 5%, 12 seeds) that made the image mean 1.1% low
//! (z = -8.6), and still 1.2% with the pixel's own error only allowed to veto the stop at
//! twice or four times the threshold; from the neighbours alone it is +0.2% (z = 0.75),
//! with fewer samples. The price: noise confined to one pixel whose neighbours are all
//! quiet goes unseen (a structure two pixels wide is seen). Eight neighbours also give the
//! replicates' estimate, one degree of freedom per pixel, eight to decide on, as Cycles
//! filters its convergence over a window.
//!
//! Decisions are deterministic: pixels are checked only at fixed sample counts (4, 6, 8,
//! 12, 16, 24, ...: 2^k and 3 2^(k-1) from the minimum on, so that every check sees whole
//! aligned blocks of each replicate's Sobol sequence), from the sums of the neighbours at
//! that count, and the neighbourhood is cut at the tile's edges, so that a tile decides
//! alone: whatever the thread count, the pass sizes, or which window of the frame a piece
//! renders (windows on the tile grid).

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
    /// From the means of two independently scrambled Sobol replicates: unbiased.
    Replicates,
    /// Sample variance over n of one Owen-scrambled Sobol sequence: its samples are
    /// stratified, so this overstates the error of their mean (a bound, not an estimate).
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

/// Variance of a pixel's mean per channel from its replicates, (m0 - m1)^2 / 4 (zero until
/// both have samples).
pub fn replicate_variance(px: &PixelSums, e: &ErrorSums) -> DVec3 {
    replicate_means(px, e).map_or(DVec3::ZERO, |(m0, m1)| (m0 - m1) * (m0 - m1) / 4.0)
}

/// Variance of a pixel's mean luminance (covariance between channels included): from its
/// replicates, or from its samples' luminance; infinite while it cannot be estimated.
pub fn luminance_variance(px: &PixelSums, e: &ErrorSums, replicates: bool) -> f64 {
    if replicates {
        return replicate_means(px, e).map_or(f64::INFINITY, |(m0, m1)| (luminance(m0) - luminance(m1)).powi(2) / 4.0);
    }
    if px.count < 2 {
        return f64::INFINITY;
    }
    let n = px.count as f64;
    let sum = luminance(px.total());
    ((e.luminance_sq - sum * sum / n) / (n - 1.0)).max(0.0) / n
}

/// Squared relative standard error of a pixel's mean luminance, relative to the luminance
/// or `LUMINANCE_FLOOR`, whichever is larger.
pub fn relative_variance(px: &PixelSums, e: &ErrorSums, replicates: bool) -> f64 {
    luminance_variance(px, e, replicates) / luminance(px.mean()).max(LUMINANCE_FLOOR).powi(2)
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
/// samples (a check count): each stops where its neighbourhood's squared relative error is
/// below `threshold`^2, estimated as the mean per-sample relative variance of the other
/// pixels of its 3x3 neighbourhood inside the tile, over the pixel's own sample count. The
/// pixel's own samples take no part: see the module's documentation. Decisions read the
/// tile's state before any of them is applied.
pub fn check(tile: &mut Tile, n: u32, threshold: f64, replicates: bool) {
    let (w, h) = (tile.size.x as usize, tile.size.y as usize);
    let per_sample: Vec<f64> = (0..w * h)
        .map(|i| match relative_variance(&tile.pixels[i], &tile.errors[i], replicates) {
            v if v.is_finite() => v * tile.pixels[i].count as f64,
            _ => f64::INFINITY,
        })
        .collect();
    let target = threshold * threshold;
    let stopping: Vec<usize> = (0..w * h)
        .filter(|&i| tile.stopped_at[i] == 0)
        .filter(|&i| {
            let (x, y) = (i % w, i / w);
            let (mut sum, mut count) = (0.0, 0.0);
            for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in (x.saturating_sub(1)..(x + 2).min(w)).filter(|&nx| (nx, ny) != (x, y)) {
                    sum += per_sample[ny * w + nx];
                    count += 1.0;
                }
            }
            count > 0.0 && sum / count / (tile.pixels[i].count as f64) < target
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
        let min_spp = crate::integrator::Settings::table().iter().find(|p| p.name == "min-spp").unwrap();
        assert_eq!(min_spp.range(), format!("at least {FIRST_CHECK}"), "the table's least min-spp is the first check");
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
        assert_eq!(replicate_variance(px, e), DVec3::splat(4.0));
        assert!((luminance_variance(px, e, true) - 4.0).abs() < 1e-9);
        // The samples' luminance variance: s^2 = 20 / 3 over n = 4.
        assert!((luminance_variance(px, e, false) - 20.0 / 12.0).abs() < 1e-9);
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
    fn a_pixel_stops_where_its_neighbours_are_below_the_threshold() {
        // Flat, flat, noisy, noisy: the first stops; the second has a noisy neighbour.
        let mut film = row(&[0.0, 0.001, 0.5, 0.5]);
        check(&mut film.tiles[0], 8, 0.01, false);
        assert_eq!(film.tiles[0].stopped_at, [8, 0, 0, 0]);
        assert!(!film.tiles[0].active(UVec2::new(0, 0)) && film.tiles[0].active(UVec2::new(1, 0)));
        // The same with the replicates' estimate, whose alternating samples differ most.
        let mut film = row(&[0.0, 0.001, 0.5, 0.5]);
        check(&mut film.tiles[0], 8, 0.01, true);
        assert_eq!(film.tiles[0].stopped_at, [8, 0, 0, 0]);
        // Its own samples take no part: a noisy pixel between flat ones stops with them.
        let mut film = row(&[0.0, 0.5, 0.0]);
        check(&mut film.tiles[0], 8, 0.01, false);
        assert_eq!(film.tiles[0].stopped_at, [0, 8, 0]);
        // Threshold 0 stops nothing; neither does an error not known yet (one sample), nor
        // having no neighbour.
        let mut film = row(&[0.0, 0.0]);
        check(&mut film.tiles[0], 8, 0.0, false);
        assert_eq!(film.tiles[0].stopped_at, [0, 0]);
        let mut film = Film::new(2, 1).with_threshold();
        film.tiles[0].add(UVec2::ZERO, Spectrum::splat(1.0));
        check(&mut film.tiles[0], 4, 0.5, true);
        assert_eq!(film.tiles[0].stopped_at, [0, 0]);
        let mut film = row(&[0.0]);
        check(&mut film.tiles[0], 8, 0.5, false);
        assert_eq!(film.tiles[0].stopped_at, [0]);
    }
}

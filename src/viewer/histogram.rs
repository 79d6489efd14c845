//! The histogram of displayed luminance and auto-exposure.
//!
//! The histogram counts the BT.709 luminance of each pixel after exposure and before the
//! tone curve, in bins of a quarter stop (log2), the photographer's axis on which every
//! stop is as wide as the next; the tone curve's clipping points (where a grey leaves
//! black and reaches white in 8-bit sRGB) are marked on the same axis, so what lies beyond
//! them is what the display loses. Auto-exposure sets the exposure (a display setting:
//! the accumulated data are never touched) so that a chosen percentile of the lit pixels'
//! luminance shows as a chosen grey, e.g. the median at 18% (middle grey): the key value
//! a = 0.18 of Reinhard et al., "Photographic Tone Reproduction for Digital Images" (2002),
//! eq. 2, with a percentile in place of their log-average luminance, so that a chosen
//! highlight (the 99th percentile to white) can be exposed for as well.

use crate::film::tonemap::{Display, Tonemap};
use crate::math::luminance;
use glam::Vec3;

/// Lowest stop (log2 luminance after exposure) with a bin of its own.
pub const LOWEST: f32 = -16.0;
/// Stop at which the last bin ends.
pub const HIGHEST: f32 = 8.0;
/// Bins per stop.
pub const PER_STOP: usize = 4;
/// Number of bins.
pub const BINS: usize = (HIGHEST - LOWEST) as usize * PER_STOP;

/// Pixel counts per quarter stop of exposed luminance, from `LOWEST` to `HIGHEST`; the first
/// bin also holds black and everything darker, the last everything brighter.
#[derive(Clone, Debug, PartialEq)]
pub struct Histogram {
    /// Count per bin.
    pub counts: Vec<u32>,
}

impl Histogram {
    /// The histogram of `pixels` (linear radiance) at `exposure` EV.
    pub fn of(pixels: &[Vec3], exposure: f32) -> Self {
        let mut counts = vec![0u32; BINS];
        for &p in pixels {
            counts[bin(luminance(p) * exposure.exp2())] += 1;
        }
        Self { counts }
    }

    /// The stop at which bin `i` starts.
    pub fn start(i: usize) -> f32 {
        LOWEST + i as f32 / PER_STOP as f32
    }
}

/// The bin of exposed luminance `l`.
fn bin(l: f32) -> usize {
    if l > 0.0 { (((l.log2() - LOWEST) * PER_STOP as f32).floor().max(0.0) as usize).min(BINS - 1) } else { 0 }
}

/// Where `tonemap` clips a grey, in stops of exposed luminance: the brightest input still
/// shown as black (code 0) and the darkest shown as white (code 255); None where it never
/// does within `LOWEST - 16` to `HIGHEST + 16` stops.
pub fn clip_points(tonemap: Tonemap) -> (Option<f32>, Option<f32>) {
    let display = Display { exposure: 0.0, tonemap };
    let code = |stops: f32| display.to_srgb8(Vec3::splat(stops.exp2()))[0];
    let (low, high) = (LOWEST - 16.0, HIGHEST + 16.0);
    // The first stop at which `reached` holds, by bisection on a monotonic curve.
    let boundary = |reached: &dyn Fn(f32) -> bool| {
        if !reached(high) || reached(low) {
            return None;
        }
        let (mut a, mut b) = (low, high);
        for _ in 0..40 {
            let m = 0.5 * (a + b);
            if reached(m) { b = m } else { a = m }
        }
        Some(b)
    };
    (boundary(&|s| code(s) > 0), boundary(&|s| code(s) == 255))
}

/// The exposure (EV, within the display's -20..=20) at which the `percentile` (0 to 100,
/// nearest rank) of the lit pixels' luminance shows as `grey` (linear, before the tone
/// curve); None if no pixel is lit.
pub fn auto_exposure(pixels: &[Vec3], percentile: f32, grey: f32) -> Option<f32> {
    let mut lit: Vec<f32> = pixels.iter().map(|&p| luminance(p)).filter(|&l| l > 0.0 && l.is_finite()).collect();
    if lit.is_empty() || grey.is_nan() || grey <= 0.0 {
        return None;
    }
    let rank = ((percentile.clamp(0.0, 100.0) / 100.0 * lit.len() as f32).ceil() as usize).clamp(1, lit.len());
    let (_, &mut value, _) = lit.select_nth_unstable_by(rank - 1, f32::total_cmp);
    Some((grey / value).log2().clamp(-20.0, 20.0))
}

/// Stops within which a continuous auto-exposure leaves the exposure alone, so that the
/// noise of a converging image does not make it flicker.
const HYSTERESIS: f32 = 0.05;

/// How auto-exposure chooses the exposure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoExposure {
    /// Percentile of the lit pixels' luminance (50: the median).
    pub percentile: f32,
    /// The grey it shows as (linear; 0.18 is middle grey).
    pub grey: f32,
    /// Adjust the exposure with every new image.
    pub continuous: bool,
}

impl Default for AutoExposure {
    fn default() -> Self {
        Self { percentile: 50.0, grey: 0.18, continuous: false }
    }
}

impl AutoExposure {
    /// The exposure of `pixels` (`auto_exposure`), or `current` if that is within
    /// `HYSTERESIS` of it or nothing is lit.
    pub fn adjust(&self, current: f32, pixels: &[Vec3]) -> f32 {
        match auto_exposure(pixels, self.percentile, self.grey) {
            Some(ev) if (ev - current).abs() > HYSTERESIS => ev,
            _ => current,
        }
    }
}

//! Progress towards a target: samples per pixel, render time or estimated error, with the
//! time left at the current rate. Samples per pixel grow linearly with time; the error of
//! an unbiased Monte Carlo estimator falls as time^-1/2 (so reaching error e' from e after
//! t seconds takes t (e / e')^2 in all), the law the convergence panel also uses.

use super::convergence::time_to_error;

/// What a render runs towards.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TargetKind {
    /// The target spp of the estimator settings.
    #[default]
    Spp,
    /// Seconds of render time.
    Time,
    /// Mean relative standard error of pixel luminance.
    Error,
}

/// The target, of each kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    /// Which one applies.
    pub kind: TargetKind,
    /// Seconds of render time (pauses excluded).
    pub seconds: f64,
    /// Relative error (0.01 is 1%).
    pub error: f64,
}

/// The default target error: 20% estimated error, reached in a 1280x800 window on 2 cores
/// in about 5 s on the Cornell box (15 spp) and 14 s in the subsurface scene (23 spp), where
/// 1% took hours. It is the estimate from the sample variance, which overstates the Sobol sampler's
/// true error about threefold (tests/adaptive.rs); at that noise the denoised Cornell box
/// is already closer to a 512-spp reference on screen than the noisy image at 128 spp
/// (tests/denoise.rs, docs/accuracy.md).
pub const DEFAULT_ERROR: f64 = 0.2;

impl Default for Target {
    fn default() -> Self {
        Self { kind: TargetKind::Spp, seconds: 60.0, error: DEFAULT_ERROR }
    }
}

/// How far a render is towards its target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Done so far, 0 to 1.
    pub fraction: f64,
    /// Seconds of rendering left at the current rate (None before it can be told).
    pub remaining: Option<f64>,
    /// The target is reached: the render stops.
    pub reached: bool,
}

/// The progress of a render at `spp` after `seconds`, with estimated error `error`,
/// towards `target` (`target_spp` for the spp kind); None without a target to go to.
pub fn progress(
    target: &Target,
    target_spp: Option<u32>,
    spp: u32,
    seconds: f64,
    error: Option<f64>,
) -> Option<Progress> {
    match target.kind {
        TargetKind::Spp => {
            let goal = target_spp.filter(|&n| n > 0)?;
            let fraction = (spp as f64 / goal as f64).min(1.0);
            let remaining = (spp > 0).then(|| seconds * (goal.saturating_sub(spp)) as f64 / spp as f64);
            Some(Progress { fraction, remaining, reached: spp >= goal })
        }
        TargetKind::Time => {
            let goal = target.seconds.max(0.0);
            let reached = seconds >= goal;
            let fraction = if goal > 0.0 { (seconds / goal).min(1.0) } else { 1.0 };
            Some(Progress { fraction, remaining: Some((goal - seconds).max(0.0)), reached })
        }
        TargetKind::Error => {
            let goal = target.error;
            let Some(e) = error.filter(|e| *e > 0.0 && e.is_finite()) else {
                return Some(Progress { fraction: 0.0, remaining: None, reached: false });
            };
            let reached = e <= goal;
            let fraction = if reached { 1.0 } else { (goal / e).powi(2) };
            Some(Progress { fraction, remaining: Some(time_to_error(seconds, e, goal)), reached })
        }
    }
}

/// `seconds` in words: "42 s", "3 min 20 s", "2 h 5 min".
pub fn format_seconds(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, s % 3600 / 60),
    }
}

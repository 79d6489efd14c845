//! Counters of non-finite values per cause, so that a NaN regression names its source.
//! Compiled in debug builds and with the `nan-causes` feature; free otherwise.

use crate::spectrum::Spectrum;

/// Where in the path a non-finite value appeared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NanCause {
    /// A camera ray with a non-finite origin or direction.
    CameraRay,
    /// Emitted radiance of a surface hit by a path.
    Emission,
    /// The weight f cos / pdf of a sampled BSDF direction.
    BsdfSample,
    /// A light-sampling (next-event) contribution.
    LightSample,
}

/// Every cause, in counter order.
pub const CAUSES: [NanCause; 4] =
    [NanCause::CameraRay, NanCause::Emission, NanCause::BsdfSample, NanCause::LightSample];

/// Whether the counters are compiled in.
pub fn enabled() -> bool {
    cfg!(any(debug_assertions, feature = "nan-causes"))
}

#[cfg(any(debug_assertions, feature = "nan-causes"))]
static COUNTS: [std::sync::atomic::AtomicU64; 4] = [const { std::sync::atomic::AtomicU64::new(0) }; 4];

/// Counts `v` under `cause` if any component is NaN or infinite (no-op unless `enabled()`).
#[inline(always)]
pub fn check(cause: NanCause, v: Spectrum) {
    #[cfg(any(debug_assertions, feature = "nan-causes"))]
    if !v.is_finite() {
        COUNTS[cause as usize].fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }
    #[cfg(not(any(debug_assertions, feature = "nan-causes")))]
    let _ = (cause, v);
}

/// Non-finite values seen so far in this process, per cause (all zero unless `enabled()`).
pub fn counts() -> [(NanCause, u64); 4] {
    #[cfg(any(debug_assertions, feature = "nan-causes"))]
    return CAUSES.map(|c| (c, COUNTS[c as usize].load(std::sync::atomic::Ordering::Relaxed)));
    #[cfg(not(any(debug_assertions, feature = "nan-causes")))]
    CAUSES.map(|c| (c, 0))
}

/// "cause: n" for every cause seen, comma-separated; empty if none or not `enabled()`.
pub fn report() -> String {
    let seen: Vec<String> = counts().iter().filter(|(_, n)| *n > 0).map(|(c, n)| format!("{c:?}: {n}")).collect();
    seen.join(", ")
}

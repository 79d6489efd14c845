//! Helpers shared by the integration tests: paths to shared assets, rendering to a target,
//! and statistical thresholds.
#![allow(dead_code)]

use lucent::integrator::Settings;
use lucent::render::{Job, RenderSession, Snapshot};
use lucent::scene::{Scene, camera::Camera};
use statrs::distribution::{ContinuousCDF, Normal};
use std::path::PathBuf;
use std::sync::Arc;

/// The shared folder beside the checkout (CI clones main with shared/ next to it).
pub fn shared() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared")
}

/// A model under shared/assets.
pub fn asset(rel: &str) -> PathBuf {
    shared().join("assets").join(rel)
}

/// Renders `scene` from `camera` to `settings.target_spp` on `threads` workers.
pub fn render(scene: &Arc<Scene>, camera: Camera, settings: Settings, threads: Option<usize>) -> Arc<Snapshot> {
    assert!(settings.target_spp.is_some(), "tests render to a sample target");
    let job = Job { scene: Arc::clone(scene), camera, settings };
    RenderSession::new(job, threads).expect("valid settings").wait_until_done()
}

/// Two-sided z threshold for a family of `tests` tests at family-wise significance `alpha`,
/// with the Sidak correction: each test runs at 1 - (1 - alpha)^(1/tests).
pub fn sidak_z(alpha: f64, tests: usize) -> f64 {
    let per_test = 1.0 - (1.0 - alpha).powf(1.0 / tests as f64);
    Normal::new(0.0, 1.0).unwrap().inverse_cdf(1.0 - per_test / 2.0)
}

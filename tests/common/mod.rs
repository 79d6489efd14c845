//! Helpers shared by the integration tests: paths to shared assets, rendering to a target,
//! and statistical thresholds.
#![allow(dead_code)]

use lucent::integrator::Settings;
use lucent::render::{Job, RenderSession, Snapshot};
use lucent::scene::{Scene, camera::Camera};
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};
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

/// Chi-square p-value of observed against expected bin counts; bins expecting fewer than 5
/// samples are pooled into one (which must then be empty if it expects nothing).
pub fn chi2_p_value(observed: &[f64], expected: &[f64]) -> f64 {
    let (mut stat, mut dof, mut pooled_o, mut pooled_e) = (0.0, 0usize, 0.0, 0.0);
    for (o, e) in observed.iter().zip(expected) {
        if *e < 5.0 {
            pooled_o += o;
            pooled_e += e;
        } else {
            stat += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pooled_e > 0.0 {
        stat += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
        dof += 1;
    } else {
        assert_eq!(pooled_o, 0.0, "samples where the pdf is zero");
    }
    1.0 - ChiSquared::new((dof - 1) as f64).unwrap().cdf(stat)
}

//! Helpers shared by the integration tests: paths to the test assets, rendering to a
//! target, and statistical thresholds.
#![allow(dead_code)]

use glam::DVec3;
use lucent::integrator::Settings;
use lucent::render::{Job, RenderSession, Snapshot};
use lucent::scene::{Scene, camera::Camera};
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A file under tests/assets (see its INDEX.md).
pub fn asset(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/assets").join(rel)
}

/// The Cornell box glTF that the binary embeds as its built-in scene.
pub fn cornell_box_file() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/cornell-box.gltf")
}

/// A test's scratch folder (derefs to its path): removed on drop, kept if the test fails.
pub struct Scratch(Option<tempfile::TempDir>);

/// A new, empty scratch folder in the system's temporary folder, named `lucent-{name}-...`.
pub fn scratch(name: &str) -> Scratch {
    let dir = tempfile::Builder::new().prefix(&format!("lucent-{name}-")).tempdir();
    Scratch(Some(dir.expect("a scratch folder")))
}

impl Scratch {
    /// Writes `bytes` to the file `name` in this folder and returns its path.
    pub fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }
}

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.as_ref().expect("taken only on drop").path()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking()
            && let Some(dir) = self.0.take()
        {
            eprintln!("the failing test's files are kept in {}", dir.keep().display());
        }
    }
}

/// A file alone in a scratch folder, removed or kept with it (derefs to the file's path).
pub struct ScratchFile {
    path: PathBuf,
    _dir: Scratch,
}

/// `bytes` written to the file `file` in a new scratch folder named after `name`.
pub fn scratch_file(name: &str, file: &str, bytes: &[u8]) -> ScratchFile {
    let dir = scratch(name);
    ScratchFile { path: dir.write(file, bytes), _dir: dir }
}

impl std::ops::Deref for ScratchFile {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.path
    }
}

/// Renders `scene` from `camera` to `settings.target_spp` on `threads` workers.
pub fn render(scene: &Arc<Scene>, camera: Camera, settings: Settings, threads: Option<usize>) -> Arc<Snapshot> {
    assert!(settings.target_spp.is_some(), "tests render to a sample target");
    let job = Job { scene: Arc::clone(scene), camera, settings, window: None, aovs: false };
    RenderSession::new(job, threads).expect("valid settings").wait_until_done()
}

/// Two-sided z threshold for a family of `tests` tests at family-wise significance `alpha`,
/// with the Sidak correction: each test runs at 1 - (1 - alpha)^(1/tests).
pub fn sidak_z(alpha: f64, tests: usize) -> f64 {
    let per_test = 1.0 - (1.0 - alpha).powf(1.0 / tests as f64);
    Normal::new(0.0, 1.0).unwrap().inverse_cdf(1.0 - per_test / 2.0)
}

/// Expected sample counts of `samples` draws from a solid-angle `density(theta, phi)` in
/// each of `theta_bins` x `phi_bins` bins of size `dt` x `dp` (row-major, theta first),
/// by the midpoint rule on `sub` x `sub` points per bin, and one more bin for the mass the
/// density leaves out (samples the routine rejects).
pub fn expected_counts(
    (theta_bins, phi_bins): (usize, usize),
    (dt, dp): (f64, f64),
    sub: usize,
    samples: usize,
    density: impl Fn(f64, f64) -> f64,
) -> Vec<f64> {
    let mut expected = vec![0.0f64; theta_bins * phi_bins + 1];
    for i in 0..theta_bins {
        for j in 0..phi_bins {
            let mut integral = 0.0;
            for a in 0..sub {
                for b in 0..sub {
                    let theta = (i as f64 + (a as f64 + 0.5) / sub as f64) * dt;
                    let phi = (j as f64 + (b as f64 + 0.5) / sub as f64) * dp;
                    integral += density(theta, phi) * theta.sin();
                }
            }
            expected[i * phi_bins + j] = integral * dt * dp / (sub * sub) as f64 * samples as f64;
        }
    }
    let total: f64 = expected[..theta_bins * phi_bins].iter().sum();
    expected[theta_bins * phi_bins] = (samples as f64 - total).max(0.0);
    expected
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
    if dof < 2 {
        // One category (a BSDF that is a single delta, say): nothing to fit.
        return 1.0;
    }
    1.0 - ChiSquared::new((dof - 1) as f64).unwrap().cdf(stat)
}

/// (theta_half, theta_diff, phi_diff) at the centre of MERL cell (i, j, k).
pub fn merl_cell_centre(i: usize, j: usize, k: usize) -> (f64, f64, f64) {
    use std::f64::consts::{FRAC_PI_2, PI};
    let x = (i as f64 + 0.5) / 90.0;
    (x * x * FRAC_PI_2, (j as f64 + 0.5) / 90.0 * FRAC_PI_2, (k as f64 + 0.5) / 180.0 * PI)
}

/// A MERL .binary file tabulating `f(theta_half, theta_diff, phi_diff)` (RGB) at the centre
/// of every cell, stored with MERL's per-channel scales.
pub fn merl_bytes(f: impl Fn(f64, f64, f64) -> [f64; 3]) -> Vec<u8> {
    use lucent::bsdf::measured::{PHI_DIFF, SCALE, THETA_DIFF, THETA_HALF};
    let cells = THETA_HALF * THETA_DIFF * PHI_DIFF;
    let mut values = vec![0.0f64; 3 * cells];
    for i in 0..THETA_HALF {
        for j in 0..THETA_DIFF {
            for k in 0..PHI_DIFF {
                let (th, td, pd) = merl_cell_centre(i, j, k);
                let v = f(th, td, pd);
                let at = k + PHI_DIFF * (j + THETA_DIFF * i);
                for c in 0..3 {
                    values[c * cells + at] = v[c] / SCALE[c];
                }
            }
        }
    }
    let mut bytes: Vec<u8> = [90i32, 90, 180].iter().flat_map(|d| d.to_le_bytes()).collect();
    bytes.extend(values.iter().flat_map(|v| v.to_le_bytes()));
    bytes
}

/// A smooth analytic BRDF with a diffuse part and a glossy lobe that depends on all three
/// half/difference angles (reciprocal, and periodic in phi_diff with period pi).
pub fn analytic_brdf(theta_h: f64, theta_d: f64, phi_d: f64) -> [f64; 3] {
    let lobe =
        2.0 * (-theta_h * theta_h / 0.02).exp() * (1.0 + 0.3 * (2.0 * phi_d).cos()) * (0.5 + 0.5 * theta_d.cos());
    [0.15, 0.25, 0.35].map(|kd| kd / std::f64::consts::PI + lobe)
}

/// The direction pair (wo, wi) with half/difference angles (theta_h, theta_d, phi_d) and
/// half-vector azimuth `phi_h` (MERL's convention), in the shading frame.
pub fn from_half_diff(theta_h: f64, theta_d: f64, phi_d: f64, phi_h: f64) -> (glam::Vec3, glam::Vec3) {
    use glam::DVec3;
    let d = DVec3::new(theta_d.sin() * phi_d.cos(), theta_d.sin() * phi_d.sin(), theta_d.cos());
    let (s, c) = theta_h.sin_cos();
    let t = DVec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
    let (s, c) = phi_h.sin_cos();
    let wi = DVec3::new(c * t.x - s * t.y, s * t.x + c * t.y, t.z);
    let h = DVec3::new(theta_h.sin() * phi_h.cos(), theta_h.sin() * phi_h.sin(), theta_h.cos());
    let wo = 2.0 * wi.dot(h) * h - wi;
    (wo.as_vec3(), wi.as_vec3())
}

/// Per-block means and variances of the mean of 8x8-pixel blocks.
pub fn blocks(s: &Snapshot) -> Vec<(DVec3, DVec3)> {
    let per_side = s.width / 8;
    let mut out = vec![(DVec3::ZERO, DVec3::ZERO); (per_side * per_side) as usize];
    for y in 0..s.height {
        for x in 0..s.width {
            let i = (y * s.width + x) as usize;
            let b = &mut out[((y / 8) * per_side + x / 8) as usize];
            b.0 += s.mean[i].as_dvec3() / 64.0;
            b.1 += s.variance[i].as_dvec3() / (64.0 * 64.0);
        }
    }
    out
}

/// Asserts the block means of `test` agree with `reference` (z-tests at `z_max`).
pub fn assert_blocks_agree(test: &Snapshot, reference: &Snapshot, z_max: f64, label: &str) {
    assert_eq!(test.rejected, 0, "{label}: NaN/Inf samples");
    for (b, (t, r)) in blocks(test).iter().zip(blocks(reference)).enumerate() {
        for c in 0..3 {
            let se = (t.1[c] + r.1[c]).sqrt();
            if se == 0.0 {
                assert_eq!(t.0[c], r.0[c], "{label}: block {b} channel {c}: noiseless blocks differ");
                continue;
            }
            let z = (t.0[c] - r.0[c]) / se;
            assert!(z.abs() < z_max, "{label}: block {b} channel {c}: {:.4} vs {:.4} (z = {z:.2})", t.0[c], r.0[c]);
        }
    }
}

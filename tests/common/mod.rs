//! Helpers shared by the integration tests: paths to the test assets, rendering to a
//! target, and statistical thresholds.
#![allow(dead_code)]

use glam::DVec3;
use lucent::integrator::{LightSampling, Settings};
use lucent::loader::gltf;
use lucent::render::{Job, RenderSession, Snapshot};
use lucent::scene::{Scene, SceneDesc, camera::Camera};
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Whether Open Image Denoise is installed where Lucent finds it; if not, the test named is
/// skipped, saying so, unless LUCENT_REQUIRE_OIDN is set (as `.ci/run` sets it), which fails it.
pub fn oidn_installed(test: &str) -> bool {
    match lucent::film::denoise::available() {
        Ok(()) => true,
        Err(e) => {
            assert!(std::env::var_os("LUCENT_REQUIRE_OIDN").is_none(), "LUCENT_REQUIRE_OIDN is set: {e}");
            eprintln!("skipping {test}: {e}");
            false
        }
    }
}

/// A file under tests/assets (see its INDEX.md).
pub fn asset(rel: impl AsRef<Path>) -> PathBuf {
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

/// Significance of each of `tests` tests for family-wise significance `alpha` (Sidak): 1 - (1 - alpha)^(1/tests).
pub fn sidak_alpha(alpha: f64, tests: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / tests as f64)
}

/// Two-sided z threshold for a family of `tests` tests at family-wise significance `alpha` (Sidak).
pub fn sidak_z(alpha: f64, tests: usize) -> f64 {
    Normal::new(0.0, 1.0).unwrap().inverse_cdf(1.0 - sidak_alpha(alpha, tests) / 2.0)
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

/// Means and variances of the mean of a `width` x `height` image's `block` x `block` pixel blocks, row by row,
/// from its row-major (mean, variance) pixels; blocks at the right and bottom edges average the pixels left.
pub fn block_stats(
    width: u32,
    height: u32,
    block: u32,
    pixels: impl IntoIterator<Item = (DVec3, DVec3)>,
) -> Vec<(DVec3, DVec3)> {
    let (across, down) = (width.div_ceil(block), height.div_ceil(block));
    let mut out = vec![(DVec3::ZERO, DVec3::ZERO); (across * down) as usize];
    let mut count = 0;
    for (i, (mean, variance)) in pixels.into_iter().enumerate() {
        let (x, y) = (i as u32 % width, i as u32 / width);
        let (bx, by) = (x / block, y / block);
        let n = (block.min(width - bx * block) * block.min(height - by * block)) as f64;
        let b = &mut out[(by * across + bx) as usize];
        b.0 += mean / n;
        b.1 += variance / (n * n);
        count += 1;
    }
    assert_eq!(count, width * height, "a {width}x{height} image");
    out
}

/// `block_stats` of a render's pixel means and variances.
pub fn blocks(s: &Snapshot, block: u32) -> Vec<(DVec3, DVec3)> {
    let pixels = s.mean.iter().zip(&s.variance).map(|(m, v)| (m.as_dvec3(), v.as_dvec3()));
    block_stats(s.width, s.height, block, pixels)
}

/// Asserts each block mean of `test` in `channels` is within `z_max` standard errors (both blocks' and `floor`,
/// in quadrature) of `reference`'s, and blocks without error equal; returns the largest |z|.
pub fn assert_block_means_agree(
    test: &[(DVec3, DVec3)],
    reference: &[(DVec3, DVec3)],
    channels: Range<usize>,
    floor: f64,
    z_max: f64,
    label: &str,
) -> f64 {
    assert_eq!(test.len(), reference.len(), "{label}: block counts");
    let mut worst = 0.0f64;
    for (b, (t, r)) in test.iter().zip(reference).enumerate() {
        for c in channels.clone() {
            let se = (t.1[c] + r.1[c] + floor.powi(2)).sqrt();
            if se == 0.0 {
                assert_eq!(t.0[c], r.0[c], "{label}: block {b} channel {c}: noiseless blocks differ");
                continue;
            }
            let z = (t.0[c] - r.0[c]) / se;
            worst = worst.max(z.abs());
            assert!(
                z.abs() < z_max,
                "{label}: block {b} channel {c}: {:.5} vs {:.5} (z = {z:.2}, limit {z_max:.2})",
                t.0[c],
                r.0[c]
            );
        }
    }
    worst
}

/// `assert_block_means_agree` for two renders' `block`-pixel blocks in every channel, `test` free of NaN/Inf.
pub fn assert_blocks_agree(test: &Snapshot, reference: &Snapshot, block: u32, z_max: f64, label: &str) -> f64 {
    assert_eq!(test.rejected, 0, "{label}: NaN/Inf samples");
    assert_block_means_agree(&blocks(test, block), &blocks(reference, block), 0..3, 0.0, z_max, label)
}

/// The mean of `n` values of `draw` and its standard error, from their sample variance.
pub fn mean_and_se(n: usize, mut draw: impl FnMut() -> f64) -> (f64, f64) {
    let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let w = draw();
        sum += w;
        sum_sq += w * w;
    }
    let mean = sum / n as f64;
    (mean, ((sum_sq / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
}

/// Per-channel mean of a render's pixels and its standard error, sqrt(sum of pixel variances) / pixels.
pub fn image_mean(s: &Snapshot) -> (DVec3, DVec3) {
    let n = s.mean.len() as f64;
    let mean = s.mean.iter().map(|p| p.as_dvec3()).sum::<DVec3>() / n;
    let se = s.variance.iter().map(|v| v.as_dvec3()).sum::<DVec3>().sqrt() / n;
    (mean, se)
}

/// Asserts `mean` is within `z_max` standard errors `se` of `expected`, or within 1e-5 of it if `se` is zero.
pub fn assert_within(mean: f64, se: f64, expected: f64, z_max: f64, label: &str) {
    if se == 0.0 {
        assert!((mean - expected).abs() < 1e-5, "{label}: zero-variance mean {mean} != {expected}");
        return;
    }
    let z = (mean - expected) / se;
    assert!(z.abs() < z_max, "{label}: mean {mean:.5} vs {expected} (z = {z:.2}, se {se:.2e})");
}

/// `assert_within` for every channel of a render's `image_mean`, free of NaN/Inf; returns the mean.
pub fn assert_mean(s: &Snapshot, expected: f64, z_max: f64, label: &str) -> DVec3 {
    assert_eq!(s.rejected, 0, "{label}: NaN/Inf samples");
    let (mean, se) = image_mean(s);
    for c in 0..3 {
        assert_within(mean[c], se[c], expected, z_max, &format!("{label}, channel {c}"));
    }
    mean
}

/// The six sampling switch combinations: importance sampling on and off, each with light sampling Off, Explicit, Mis.
pub const SWITCHES: [(bool, LightSampling); 6] = [
    (true, LightSampling::Off),
    (true, LightSampling::Explicit),
    (true, LightSampling::Mis),
    (false, LightSampling::Off),
    (false, LightSampling::Explicit),
    (false, LightSampling::Mis),
];

/// `base` with each of the `SWITCHES`, labelled with the switches it sets.
pub fn switches(base: Settings) -> impl Iterator<Item = (String, Settings)> {
    SWITCHES.into_iter().map(move |(importance_sampling, light_sampling)| {
        let label = format!("importance {importance_sampling}, lights {light_sampling:?}");
        (label, Settings { importance_sampling, light_sampling, ..base })
    })
}

/// The scene of the glTF file at `path` (relative: under tests/assets), panicking with the loader's error.
pub fn load(path: impl AsRef<Path>) -> SceneDesc {
    let path = path.as_ref();
    let path = if path.is_absolute() { path.to_path_buf() } else { asset(path) };
    gltf::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

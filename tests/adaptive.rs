//! Adaptive sampling to a noise threshold: pixels stop where the error is low, the error
//! estimate is honest for both samplers (and the old per-pixel sample variance overstates
//! Sobol's), stopping does not bias the image beyond the estimator's noise, decisions do
//! not depend on the thread count or on which tile-grid window is rendered, and bad
//! thresholds and pieces are refused in one line.

mod common;

use glam::Vec3;
use lucent::film::adaptive::{ErrorEstimate, FIRST_CHECK, LUMINANCE};
use lucent::film::window::Window;
use lucent::integrator::{SamplerKind, Settings};
use lucent::loader::builtin;
use lucent::render::{Job, RenderSession, Snapshot};
use lucent::scene::{Scene, camera::Camera};
use statrs::distribution::{ContinuousCDF, FisherSnedecor};
use std::process::Command;
use std::sync::Arc;

fn glass_box() -> Arc<Scene> {
    let path = common::asset("cornell-box-glass.gltf");
    Arc::new(lucent::open::open(Some(&path), &Default::default(), &mut |_| {}).expect("the glass box loads"))
}

fn luminance(c: Vec3) -> f64 {
    (0..3).map(|k| LUMINANCE[k] * c[k] as f64).sum()
}

/// Mean samples per pixel over the pixels x0..x1 by y0..y1 of a snapshot.
fn region_spp(s: &Snapshot, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> f64 {
    let pixels: Vec<usize> = (y0..y1).flat_map(|y| (x0..x1).map(move |x| (y * s.width + x) as usize)).collect();
    pixels.iter().map(|&i| s.pixel_spp(i) as f64).sum::<f64>() / pixels.len() as f64
}

#[test]
fn pixels_stop_where_the_error_is_low_and_keep_sampling_the_caustic() {
    // The glass box at 96x48: the box fills the middle of the frame, black space (nothing
    // to hit) its sides; the caustic under the glass sphere is the noisiest part of the
    // image. Black pixels stop at the first check (min-spp), the caustic's go on.
    let scene = glass_box();
    let camera = scene.default_camera(2.0);
    let s = Settings {
        width: 96,
        height: 48,
        max_depth: 10,
        noise_threshold: Some(0.05),
        target_spp: Some(512),
        ..Settings::default()
    };
    let snap = common::render(&scene, camera, s, None);
    let black = region_spp(&snap, (0, 0, 16, 48));
    let caustic = region_spp(&snap, (54, 41, 60, 44));
    assert_eq!(black, s.min_spp as f64, "the black pixels took {black:.1} spp");
    assert!(caustic >= 4.0 * black, "the caustic took {caustic:.1} spp, the black pixels {black:.1}");
    assert_eq!(snap.pixel_spp.len(), 96 * 48);
    let (low, high) = (snap.pixel_spp.iter().min().unwrap(), snap.pixel_spp.iter().max().unwrap());
    assert_eq!((*low, *high), (s.min_spp, 512), "no pixel stops before min-spp or goes past the target");
    assert!(snap.active_share() < 1.0 && snap.mean_spp() < 512.0);
    let table = Settings::table().iter().find(|p| p.name == "min-spp").unwrap();
    assert_eq!(table.range(), format!("at least {FIRST_CHECK}"), "the least min-spp is the first check");
}

/// Per pixel: the observed variance of the luminance estimate over `seeds` renders, and
/// the mean over them of the predicted variance `predict(snapshot, pixel)`.
fn spread(settings: Settings, seeds: u64, predict: impl Fn(&Snapshot, usize) -> f64) -> (Vec<f64>, Vec<f64>) {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let pixels = (settings.width * settings.height) as usize;
    let (mut sum, mut sum_sq, mut predicted) = (vec![0.0; pixels], vec![0.0; pixels], vec![0.0; pixels]);
    for seed in 0..seeds {
        let snap = common::render(&scene, camera, Settings { seed, ..settings }, None);
        for p in 0..pixels {
            let l = luminance(snap.mean[p]);
            sum[p] += l;
            sum_sq[p] += l * l;
            predicted[p] += predict(&snap, p) / seeds as f64;
        }
    }
    let k = seeds as f64;
    let observed = (0..pixels).map(|p| (sum_sq[p] - sum[p] * sum[p] / k) / (k - 1.0)).collect();
    (observed, predicted)
}

/// The ratio of total observed to total predicted variance, and the bounds it falls
/// within with probability 1 - `alpha` if the prediction is honest: an F distribution
/// whose degrees of freedom (Satterthwaite) are those of the observed spread (`seeds` - 1
/// per pixel) and of the predictions (`seeds` x `dof(pixel)`), weighted by each pixel's
/// variance.
fn ratio_and_bounds(
    observed: &[f64],
    predicted: &[f64],
    seeds: u64,
    dof: impl Fn(usize) -> f64,
    alpha: f64,
) -> (f64, f64, f64) {
    let total: f64 = predicted.iter().sum();
    let squares: f64 = predicted.iter().map(|v| v * v).sum();
    let d1 = total * total / squares * (seeds - 1) as f64;
    let weighted: f64 = predicted.iter().enumerate().map(|(p, v)| v * v / (seeds as f64 * dof(p))).sum();
    let d2 = total * total / weighted;
    let f = FisherSnedecor::new(d1, d2).unwrap();
    (observed.iter().sum::<f64>() / total, f.inverse_cdf(alpha / 2.0), f.inverse_cdf(1.0 - alpha / 2.0))
}

#[test]
fn the_error_estimate_is_honest_for_both_samplers_and_the_old_one_overstates_sobols() {
    // The built-in Cornell box at 16x16 (one tile) and 64 spp, 48 seeds. For every pixel
    // the spread of its luminance over the seeds is the true variance of its estimate; the
    // estimate each render makes of it must match in total within the F bounds of both
    // sides' noise (family-wise 1e-3 over the three comparisons, Sidak). With a noise
    // threshold of 0 no pixel stops, but the error is estimated as for stopping: for Sobol
    // the sample variance (63 degrees of freedom) times the gain from the k neighbours'
    // replicate pairs (about k), so about 1 / (1/k + 1/63) per pixel; for independent
    // sampling the samples' luminance variance (63). Without a threshold, Sobol's readout is
    // the per-channel sample variance over n (as `pixel_relative_error` combines it): it
    // must fall below the lower bound, i.e. overstate the error (shown without the control
    // variate for seen lights' edges, which makes the edge pixels exact).
    let seeds = 48;
    let alpha = common::sidak_alpha(1e-3, 3);
    let base = Settings { width: 16, height: 16, target_spp: Some(64), ..Settings::default() };
    let honest = |s: &Snapshot, p: usize| s.luminance_variance[p] as f64;
    let readout = |s: &Snapshot, p: usize| (0..3).map(|c| LUMINANCE[c].powi(2) * s.variance[p][c] as f64).sum();
    let neighbours = |p: usize| {
        let side = |v: usize| if v == 0 || v == 15 { 2.0 } else { 3.0 };
        side(p % 16) * side(p / 16) - 1.0
    };

    let sobol = Settings { noise_threshold: Some(0.0), ..base };
    let (observed, predicted) = spread(sobol, seeds, honest);
    let (q, low, high) =
        ratio_and_bounds(&observed, &predicted, seeds, |p| 1.0 / (1.0 / neighbours(p) + 1.0 / 63.0), alpha);
    assert!(low < q && q < high, "Sobol, replicates: observed / predicted variance {q:.3}, not in {low:.3}..{high:.3}");

    let independent = Settings { sampler: SamplerKind::Independent, ..sobol };
    let (observed, predicted) = spread(independent, seeds, honest);
    let (q, low, high) = ratio_and_bounds(&observed, &predicted, seeds, |_| 63.0, alpha);
    assert!(low < q && q < high, "independent: observed / predicted variance {q:.3}, not in {low:.3}..{high:.3}");

    // Where Sobol's stratification gains most, along the light's edges, the control
    // variate for seen lights' edges leaves no variance to overstate: off for this part.
    let (observed, predicted) = spread(Settings { light_edges: false, ..base }, seeds, readout);
    let (q, low, _) = ratio_and_bounds(&observed, &predicted, seeds, |_| 63.0, alpha);
    assert!(q < low, "Sobol, sample variance: observed / predicted {q:.3}, not below {low:.3}");
}

/// Per seed, the difference between the mean luminance over `region` of an adaptive render
/// (threshold `threshold`) and of a uniform one, both to 256 spp at 32x32; and the mean of
/// the uniform one's.
fn adaptive_minus_uniform(scene: &Arc<Scene>, max_depth: u32, threshold: f32, seeds: u64) -> (Vec<f64>, f64) {
    let camera = scene.default_camera(1.0);
    let base = Settings { width: 32, height: 32, max_depth, target_spp: Some(256), ..Settings::default() };
    let mean = |s: &Snapshot| s.mean.iter().map(|&c| luminance(c)).sum::<f64>() / s.mean.len() as f64;
    let (mut differences, mut level) = (Vec::new(), 0.0);
    for seed in 0..seeds {
        let uniform = common::render(scene, camera, Settings { seed, ..base }, None);
        let adaptive = common::render(scene, camera, Settings { seed, noise_threshold: Some(threshold), ..base }, None);
        assert!(adaptive.active_share() < 0.9, "the threshold stopped too few pixels to test anything");
        differences.push(mean(&adaptive) - mean(&uniform));
        level += mean(&uniform) / seeds as f64;
    }
    (differences, level)
}

/// Mean and standard error of the mean of `d`.
fn mean_and_error(d: &[f64]) -> (f64, f64) {
    let k = d.len() as f64;
    let mean = d.iter().sum::<f64>() / k;
    (mean, (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt())
}

#[test]
fn stopping_biases_the_image_little_and_not_measurably_without_rare_paths() {
    // Adaptive (5%) against uniform sampling, 12 seeds each, the image's mean luminance
    // (z bounds: family-wise 1e-3 over the two scenes). A pixel stops on its own samples,
    // so one that has not met the rare paths its light partly comes by looks darker and
    // converged, and stops low (`film::adaptive`). The Cornell box has no such paths: no
    // bias is measurable. The glass box's caustics are such paths: its image is darker,
    // by less than a quarter of the threshold (measured: 0.7% at 5%).
    let z_max = common::sidak_z(1e-3, 2);
    let cornell = Arc::new(Scene::build(builtin::cornell_box()));
    let (d, _) = adaptive_minus_uniform(&cornell, 7, 0.05, 12);
    let (mean, error) = mean_and_error(&d);
    assert!((mean / error).abs() < z_max, "Cornell box: adaptive - uniform = {mean:.5} (z = {:.2})", mean / error);
    let (d, level) = adaptive_minus_uniform(&glass_box(), 10, 0.05, 12);
    let (mean, error) = mean_and_error(&d);
    let bound = 0.25 * 0.05 * level;
    assert!(
        mean.abs() < bound + z_max * error,
        "glass box: adaptive - uniform = {mean:.5} of {level:.4} (z = {:.2})",
        mean / error
    );
}

fn render_window(
    scene: &Arc<Scene>,
    camera: Camera,
    s: Settings,
    window: Option<Window>,
    threads: usize,
) -> Arc<Snapshot> {
    let job = Job { scene: Arc::clone(scene), camera, settings: s, window, aovs: false };
    RenderSession::new(job, Some(threads)).expect("valid job").wait_until_done()
}

#[test]
fn pixels_stop_alike_on_any_thread_count_and_in_windows_on_the_tile_grid() {
    let scene = glass_box();
    let camera = scene.default_camera(1.5);
    let s = Settings {
        width: 48,
        height: 32,
        max_depth: 10,
        noise_threshold: Some(0.05),
        target_spp: Some(128),
        ..Settings::default()
    };
    let one = render_window(&scene, camera, s, None, 1);
    let two = render_window(&scene, camera, s, None, 2);
    assert!(one.mean == two.mean && one.pixel_spp == two.pixel_spp, "1 and 2 threads differ");
    assert!(one.active_share() > 0.0 && one.active_share() < 1.0, "some pixels stopped, some did not");
    assert_eq!(one.estimate, ErrorEstimate::Replicates);
    // A window on the tile grid stops its pixels as the whole frame does.
    let w = Window { x0: 16, y0: 16, x1: 48, y1: 32 };
    let part = render_window(&scene, camera, s, Some(w), 2);
    for y in w.y0..w.y1 {
        for x in w.x0..w.x1 {
            let (i, j) = (((y - w.y0) * w.width() + x - w.x0) as usize, (y * s.width + x) as usize);
            assert_eq!((part.mean[i], part.pixel_spp[i]), (one.mean[j], one.pixel_spp[j]), "pixel {x},{y}");
        }
    }
    // Off the grid, or a range of samples, is refused.
    let job = |window, first_sample| Job {
        scene: Arc::clone(&scene),
        camera,
        settings: Settings { first_sample, ..s },
        window,
        aovs: false,
    };
    let off = Window { x0: 8, y0: 0, x1: 40, y1: 32 };
    let err = RenderSession::new(job(Some(off), 0), Some(1)).err().expect("refused").to_string();
    assert!(err.contains("tile grid") && !err.contains('\n'), "{err}");
    let err = RenderSession::new(job(None, 8), Some(1)).err().expect("refused").to_string();
    assert!(err.contains("cannot render a range of samples") && !err.contains('\n'), "{err}");
}

#[test]
fn region_pieces_with_a_threshold_merge_to_the_whole_render() {
    // Two bands on the tile grid of a 48x32 frame of the glass box (black space at the
    // sides, so pixels stop), rendered as pieces and merged: the same bytes as one render.
    let dir = common::scratch("adaptive-pieces");
    let scene = common::asset("cornell-box-glass.gltf");
    let lucent = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_lucent")).args(args).output().unwrap();
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let path = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    let render = ["render", scene.to_str().unwrap(), "--width", "48", "--height", "32", "--max-depth", "10"];
    let adaptive = ["--spp", "64", "--noise-threshold", "0.05"];
    let whole = lucent(&[&render[..], &adaptive, &["--out", &path("whole.exr")]].concat());
    assert!(whole.contains("% of pixels converged"), "{whole}");
    for (region, name) in [("0,0,48,16", "a.part"), ("0,16,48,32", "b.part")] {
        lucent(&[&render[..], &adaptive, &["--region", region, "--out", &path(name)]].concat());
    }
    lucent(&["merge", &path("a.part"), &path("b.part"), "--out", &path("merged.exr")]);
    let (a, b) = (std::fs::read(path("whole.exr")).unwrap(), std::fs::read(path("merged.exr")).unwrap());
    assert!(a == b, "the merged pieces differ from the whole render");
}

#[test]
fn bad_thresholds_and_pieces_get_one_line_errors() {
    let dir = common::scratch("adaptive");
    let (png, part) = (dir.join("x.png"), dir.join("x.part"));
    let view = dir.join("view.toml");
    std::fs::write(&view, "[settings]\nnoise_threshold = 5.0\n").unwrap();
    let (png, part, view) = (png.to_str().unwrap(), part.to_str().unwrap(), view.to_str().unwrap());
    let cases: [(&[&str], &str); 7] = [
        (&["--noise-threshold", "-0.1", "--out", png], "--noise-threshold: -0.1 is not in 0..=1 (or off)"),
        (&["--noise-threshold", "2", "--out", png], "--noise-threshold: 2 is not in 0..=1 (or off)"),
        (&["--noise-threshold", "lots", "--out", png], "--noise-threshold: 'lots' is not a number"),
        (&["--noise-threshold", "0.01", "--min-spp", "2", "--out", png], "--min-spp: 2 is not at least 4"),
        (&["--noise-threshold", "0.01", "--samples", "0..4", "--out", part], "cannot render a range of samples"),
        (&["--noise-threshold", "0.01", "--region", "3,0,20,16", "--out", png], "tile grid"),
        (&["--view", view, "--out", png], "5 is not in 0..=1 (or off)"),
    ];
    for (args, needle) in cases {
        let o = Command::new(env!("CARGO_BIN_EXE_lucent"))
            .args(["render", "--width", "32", "--height", "32"])
            .args(args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!std::path::Path::new(png).exists() && !std::path::Path::new(part).exists());
    }
    let o = Command::new(env!("CARGO_BIN_EXE_lucent"))
        .args(["bench", "adaptive", "--budget", "1", "--thresholds", "0.01,3", "--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--thresholds: 3 is not in 0..=1"), "{err}");
}

//! `lucent bench adaptive`: what the noise threshold buys and costs. In each of `--runs`
//! rounds (a seed each), uniform sampling, the threshold at 0 (replicates and checks, no
//! pixel ever stops: what the threshold costs by itself) and each threshold asked for render
//! the scene in turn for the same time budget, so that a change in the machine's load
//! touches all of them alike. After every pass the relative MSE against a reference is
//! recorded (`DIR/adaptive.csv`); the Markdown table gives per variant the medians over
//! the rounds of its ratios to uniform sampling's relative MSE at equal time and of its
//! samples/s. Each threshold's map of samples per pixel (first round) is written as
//! `DIR/spp-<threshold>.png`.
//!
//! The relative MSE is the mean over pixels and channels of (x - ref)^2 / (ref^2 + eps).
//! With eps = 1e-4 it is relative down to radiance 0.01, the error a noise threshold
//! targets; with the convergence study's eps = 0.01 it is nearly the absolute squared error
//! below radiance 0.1, which covers most of a dim scene such as the glass box.

use super::args::ConvergenceArgs;
use super::convergence;
use super::render::open_scene;
use crate::film::false_colour;
use crate::integrator::Settings;
use crate::params::Value;
use crate::render::{Job, RenderSession, Snapshot};
use crate::scene::Scene;
use glam::Vec3;
use std::fmt::Write as _;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The epsilons of the two relative MSEs reported.
const EPS: [f64; 2] = [1e-4, 1e-2];

/// A variant's state after a pass.
struct Wave {
    seconds: f64,
    spp: u32,
    mean_spp: f64,
    /// Relative MSE with each of `EPS`.
    relmse: [f64; 2],
    rmse: f64,
}

impl Wave {
    fn of(snap: &Snapshot, reference: &[Vec3]) -> Self {
        let (mut relmse, mut se) = ([0.0f64; 2], 0.0f64);
        for (x, r) in snap.mean.iter().zip(reference) {
            for c in 0..3 {
                let (d, r) = ((x[c] - r[c]) as f64, r[c] as f64);
                se += d * d;
                for (m, eps) in relmse.iter_mut().zip(EPS) {
                    *m += d * d / (r * r + eps);
                }
            }
        }
        let n = (3 * reference.len()) as f64;
        Wave {
            seconds: snap.elapsed.as_secs_f64(),
            spp: snap.spp,
            mean_spp: snap.mean_spp(),
            relmse: relmse.map(|m| m / n),
            rmse: (se / n).sqrt(),
        }
    }
}

/// One variant rendered in one round: its waves and last image.
struct Run {
    waves: Vec<Wave>,
    last: Arc<Snapshot>,
}

impl Run {
    fn last_wave(&self) -> &Wave {
        self.waves.last().expect("a wave per run")
    }
}

/// A variant: its label, threshold, and its run in every round.
struct Variant {
    label: String,
    threshold: Option<f32>,
    runs: Vec<Run>,
}

/// Runs `lucent bench adaptive`: uniform sampling, threshold 0 and `thresholds` (with
/// `min_spp`, or the default) in each of `rounds` rounds.
pub fn run(args: &ConvergenceArgs, thresholds: &[f32], min_spp: Option<u32>, rounds: u32) -> Result<(), String> {
    let table = Settings::table();
    let param = |name: &str| table.iter().find(|p| p.name == name).expect("in the table");
    for &t in thresholds {
        param("noise-threshold").check(Value::Float(t)).map_err(|e| format!("--thresholds: {e}"))?;
    }
    if let Some(n) = min_spp {
        param("min-spp").check(Value::Int(n as u64)).map_err(|e| format!("--min-spp: {e}"))?;
    }
    if !(args.budget > 0.0 && args.budget.is_finite()) {
        return Err(format!("--budget {} must be a positive number of seconds", args.budget));
    }
    std::fs::create_dir_all(&args.out).map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let scene = Arc::new(open_scene(args.scene.as_deref(), &Default::default())?);
    let defaults = Settings::default();
    let base = Settings {
        width: args.size,
        height: args.size,
        max_depth: args.max_depth,
        seed: args.seed,
        target_spp: None,
        min_spp: min_spp.unwrap_or(defaults.min_spp),
        ..defaults
    };
    base.validate().map_err(|e| e.to_string())?;
    let reference = convergence::reference(args, &scene, base)?;
    let mut variants = vec![
        Variant { label: "uniform".into(), threshold: None, runs: Vec::new() },
        Variant { label: "threshold 0 (never stops)".into(), threshold: Some(0.0), runs: Vec::new() },
    ];
    variants.extend(thresholds.iter().map(|&t| Variant {
        label: format!("threshold {}%", 100.0 * t),
        threshold: Some(t),
        runs: Vec::new(),
    }));
    for round in 0..rounds.max(1) {
        for v in &mut variants {
            let settings = Settings { noise_threshold: v.threshold, seed: base.seed + round as u64, ..base };
            let run = render_for(&scene, settings, args, &reference)?;
            let w = run.last_wave();
            eprintln!(
                "round {round}: {:<26} {:>8.1} mean spp in {:>6.2} s, relMSE {:.3e}",
                v.label, w.mean_spp, w.seconds, w.relmse[0]
            );
            if let (0, Some(t)) = (round, v.threshold.filter(|&t| t > 0.0)) {
                let path = args.out.join(format!("spp-{t}.png"));
                let map = spp_map(&run.last);
                false_colour::write_png(&path, run.last.width, run.last.height, &map).map_err(|e| e.to_string())?;
            }
            v.runs.push(run);
        }
    }
    let table = summarise(&variants, args.budget);
    write_text(&args.out.join("adaptive.csv"), &to_csv(&variants, base.seed))?;
    write_text(&args.out.join("adaptive.md"), &table)?;
    println!("{table}");
    println!("wrote {}/adaptive.{{csv,md}} and spp-*.png", args.out.display());
    Ok(())
}

/// Renders `settings` for the time budget (or until every pixel has stopped), recording a
/// wave after every pass.
fn render_for(
    scene: &Arc<Scene>,
    settings: Settings,
    args: &ConvergenceArgs,
    reference: &[Vec3],
) -> Result<Run, String> {
    let job = Job { scene: Arc::clone(scene), camera: scene.default_camera(1.0), settings, window: None, aovs: false };
    let session = RenderSession::new(job, args.threads).map_err(|e| e.to_string())?;
    let (mut waves, mut last): (Vec<Wave>, Option<Arc<Snapshot>>) = (Vec::new(), None);
    let wall = Instant::now();
    loop {
        let timeout = Duration::from_secs_f64((args.budget - wall.elapsed().as_secs_f64()).max(0.05));
        let Some(snap) = session.wait_for_update(last.as_ref(), timeout) else { continue };
        if last.as_ref().is_none_or(|l| !Arc::ptr_eq(l, &snap)) {
            waves.push(Wave::of(&snap, reference));
        }
        let over = snap.done || snap.elapsed.as_secs_f64() >= args.budget;
        last = Some(snap);
        if over {
            break;
        }
    }
    Ok(Run { waves, last: last.ok_or("no image within the budget")? })
}

/// The false-colour map of a snapshot's samples per pixel.
fn spp_map(snap: &Snapshot) -> Vec<[u8; 4]> {
    let range = false_colour::spp_range(&snap.pixel_spp, snap.spp);
    (0..snap.mean.len()).map(|i| false_colour::spp_colour(snap.pixel_spp(i), range)).collect()
}

/// The CSV: `variant,seed,seconds,spp,mean_spp,relmse,relmse_0.01,rmse`, one row per wave
/// (spp: of the pixels still sampling; relmse with eps 1e-4, then 0.01).
fn to_csv(variants: &[Variant], seed: u64) -> String {
    let mut out = String::from("variant,seed,seconds,spp,mean_spp,relmse,relmse_0.01,rmse\n");
    for v in variants {
        for (round, run) in v.runs.iter().enumerate() {
            for w in &run.waves {
                let _ = writeln!(
                    out,
                    "{},{},{:.6},{},{:.2},{:.8e},{:.8e},{:.8e}",
                    v.label,
                    seed + round as u64,
                    w.seconds,
                    w.spp,
                    w.mean_spp,
                    w.relmse[0],
                    w.relmse[1],
                    w.rmse
                );
            }
        }
    }
    out
}

/// The median, lowest and highest of `values`.
fn spread(mut values: Vec<f64>) -> (f64, f64, f64) {
    values.sort_by(f64::total_cmp);
    (values[values.len() / 2], values[0], values[values.len() - 1])
}

/// The Markdown table: per variant, medians over the rounds of the mean spp, the share of
/// pixels converged, the relative MSE (eps 1e-4) at the budget and its ratio to uniform
/// sampling's in the same round (with the lowest and highest), the same ratio with eps
/// 0.01, and the samples/s ratio.
fn summarise(variants: &[Variant], budget: f64) -> String {
    let uniform = &variants[0].runs;
    let mut out = format!(
        "| variant | mean spp | pixels converged | relMSE at {budget} s | relMSE / uniform's (lowest, highest) | with eps 0.01 | samples/s / uniform's |\n"
    );
    out.push_str("| --- | --- | --- | --- | --- | --- | --- |\n");
    for v in variants {
        let ratios = |f: &dyn Fn(&Run) -> f64| spread(v.runs.iter().zip(uniform).map(|(r, u)| f(r) / f(u)).collect());
        let (relmse, low, high) = ratios(&|r| r.last_wave().relmse[0]);
        let (coarse, _, _) = ratios(&|r| r.last_wave().relmse[1]);
        let (speed, _, _) = ratios(&|r| r.last.samples_per_second());
        let (spp, _, _) = spread(v.runs.iter().map(|r| r.last.mean_spp()).collect());
        let (error, _, _) = spread(v.runs.iter().map(|r| r.last_wave().relmse[0]).collect());
        let converged = match v.threshold {
            Some(_) => {
                format!("{:.1}%", 100.0 * (1.0 - spread(v.runs.iter().map(|r| r.last.active_share()).collect()).0))
            }
            None => "-".into(),
        };
        let _ = writeln!(
            out,
            "| {} | {spp:.0} | {converged} | {error:.3e} | {relmse:.3} ({low:.3}, {high:.3}) | {coarse:.3} | {speed:.3} |",
            v.label
        );
    }
    let _ = writeln!(
        out,
        "\nMedians over {} rounds of one seed each. relMSE: mean over pixels and channels of (x - ref)^2 / (ref^2 + eps), eps = 1e-4 (and 0.01 where said).",
        uniform.len()
    );
    out
}

fn write_text(path: &std::path::Path, text: &str) -> Result<(), String> {
    crate::film::output::replace_file(path, |tmp| std::fs::write(tmp, text)).map_err(|e| e.to_string())
}

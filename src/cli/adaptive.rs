//! `lucent bench adaptive`: what the noise threshold buys and costs. Uniform sampling, the
//! threshold at 0 (replicates and checks, no pixel ever stops) and each threshold asked for
//! render the scene for the same time budget; after every pass the relative MSE against a
//! reference is recorded (`DIR/adaptive.csv`), and a Markdown table compares them at equal
//! time. The checks' own cost is measured apart, as the samples/s of threshold 0 against
//! uniform sampling over alternating runs at a fixed sample count. Each threshold's map of
//! samples per pixel is written as `DIR/spp-<threshold>.png`.

use super::args::ConvergenceArgs;
use super::convergence::{self, Row};
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

/// One rendered variant: its label, threshold, recorded waves and last image.
struct Run {
    label: String,
    threshold: Option<f32>,
    rows: Vec<Row>,
    /// Mean samples per pixel at each row.
    mean_spp: Vec<f64>,
    last: Arc<Snapshot>,
}

/// Runs `lucent bench adaptive`: `thresholds` besides 0, and `runs` alternating pairs of
/// `spp`-sample renders for the checks' overhead.
pub fn run(args: &ConvergenceArgs, thresholds: &[f32], runs: u32, spp: u32) -> Result<(), String> {
    let param = Settings::table().iter().find(|p| p.name == "noise-threshold").expect("in the table");
    for &t in thresholds {
        param.check(Value::Float(t)).map_err(|e| format!("--thresholds: {e}"))?;
    }
    if !(args.budget > 0.0 && args.budget.is_finite()) {
        return Err(format!("--budget {} must be a positive number of seconds", args.budget));
    }
    std::fs::create_dir_all(&args.out).map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let scene = Arc::new(open_scene(args.scene.as_deref(), &Default::default())?);
    let base = Settings {
        width: args.size,
        height: args.size,
        max_depth: args.max_depth,
        seed: args.seed,
        target_spp: None,
        ..Settings::default()
    };
    base.validate().map_err(|e| e.to_string())?;
    let reference = convergence::reference(args, &scene, base)?;
    let mut variants = vec![("uniform".to_string(), None), ("threshold 0 (never stops)".to_string(), Some(0.0))];
    variants.extend(thresholds.iter().map(|&t| (format!("threshold {}%", 100.0 * t), Some(t))));
    let mut results = Vec::new();
    for (label, threshold) in variants {
        let settings = Settings { noise_threshold: threshold, ..base };
        let run = render_for(&scene, settings, args, &label, &reference)?;
        let r = run.rows.last().expect("a row per run");
        eprintln!("{label:<28} {:>8.1} mean spp in {:>6.2} s, relMSE {:.3e}", run.last.mean_spp(), r.seconds, r.relmse);
        if let Some(t) = threshold.filter(|&t| t > 0.0) {
            let map = spp_map(&run.last);
            let path = args.out.join(format!("spp-{t}.png"));
            false_colour::write_png(&path, run.last.width, run.last.height, &map).map_err(|e| e.to_string())?;
        }
        results.push(Run { threshold, ..run });
    }
    let overhead = overhead(&scene, base, args.threads, runs, spp)?;
    let csv = to_csv(&results);
    let table = summarise(&results, args.budget, &overhead, runs, spp);
    write_text(&args.out.join("adaptive.csv"), &csv)?;
    write_text(&args.out.join("adaptive.md"), &table)?;
    println!("{table}");
    println!("wrote {}/adaptive.{{csv,md}} and spp-*.png", args.out.display());
    Ok(())
}

/// Renders `settings` for the time budget (or until every pixel has stopped), recording a
/// row after every pass.
fn render_for(
    scene: &Arc<Scene>,
    settings: Settings,
    args: &ConvergenceArgs,
    label: &str,
    reference: &[Vec3],
) -> Result<Run, String> {
    let job = Job { scene: Arc::clone(scene), camera: scene.default_camera(1.0), settings, window: None };
    let session = RenderSession::new(job, args.threads).map_err(|e| e.to_string())?;
    let (mut rows, mut mean_spp, mut last): (Vec<Row>, Vec<f64>, Option<Arc<Snapshot>>) =
        (Vec::new(), Vec::new(), None);
    let wall = Instant::now();
    loop {
        let timeout = Duration::from_secs_f64((args.budget - wall.elapsed().as_secs_f64()).max(0.05));
        let Some(snap) = session.wait_for_update(last.as_ref(), timeout) else { continue };
        if last.as_ref().is_none_or(|l| !Arc::ptr_eq(l, &snap)) {
            rows.push(convergence::row(label, &snap, reference));
            mean_spp.push(snap.mean_spp());
        }
        let over = snap.done || snap.elapsed.as_secs_f64() >= args.budget;
        last = Some(snap);
        if over {
            break;
        }
    }
    let last = last.ok_or("no image within the budget")?;
    Ok(Run { label: label.into(), threshold: settings.noise_threshold, rows, mean_spp, last })
}

/// The false-colour map of a snapshot's samples per pixel.
fn spp_map(snap: &Snapshot) -> Vec<[u8; 4]> {
    let range = false_colour::spp_range(&snap.pixel_spp, snap.spp);
    (0..snap.mean.len()).map(|i| false_colour::spp_colour(snap.pixel_spp(i), range)).collect()
}

/// What the checks cost when no pixel stops: the median over `runs` alternating pairs of
/// `spp`-sample renders of threshold 0's samples/s over uniform sampling's, with the
/// lowest and highest ratio.
struct Overhead {
    median: f64,
    low: f64,
    high: f64,
}

fn overhead(
    scene: &Arc<Scene>,
    base: Settings,
    threads: Option<usize>,
    runs: u32,
    spp: u32,
) -> Result<Overhead, String> {
    let mut ratios = Vec::new();
    for _ in 0..runs {
        let rate = |noise_threshold| -> Result<f64, String> {
            let settings = Settings { noise_threshold, target_spp: Some(spp), ..base };
            let job = Job { scene: Arc::clone(scene), camera: scene.default_camera(1.0), settings, window: None };
            let snap = RenderSession::new(job, threads).map_err(|e| e.to_string())?.wait_until_done();
            Ok(snap.samples_per_second())
        };
        let uniform = rate(None)?;
        ratios.push(rate(Some(0.0))? / uniform);
    }
    ratios.sort_by(f64::total_cmp);
    Ok(Overhead { median: ratios[ratios.len() / 2], low: ratios[0], high: ratios[ratios.len() - 1] })
}

/// The CSV: `variant,seconds,spp,mean_spp,relmse,rmse`, one row per wave (spp: of the
/// pixels still sampling).
fn to_csv(runs: &[Run]) -> String {
    let mut out = String::from("variant,seconds,spp,mean_spp,relmse,rmse\n");
    for run in runs {
        for (r, mean) in run.rows.iter().zip(&run.mean_spp) {
            let _ = writeln!(out, "{},{:.6},{},{mean:.2},{:.8e},{:.8e}", run.label, r.seconds, r.spp, r.relmse, r.rmse);
        }
    }
    out
}

/// The relative MSE of a run's last wave at or before `t` seconds.
fn relmse_at(run: &Run, t: f64) -> Option<f64> {
    run.rows.iter().rev().find(|r| r.seconds <= t).map(|r| r.relmse)
}

/// The Markdown table: per variant the mean spp and the share of pixels converged at the
/// end, the relative MSE at a quarter, half and all of the budget, its ratio to uniform
/// sampling's at the budget, and the time to reach uniform sampling's final relative MSE;
/// then the checks' overhead.
fn summarise(runs: &[Run], budget: f64, overhead: &Overhead, pairs: u32, spp: u32) -> String {
    let uniform = runs[0].rows.last().map_or(f64::NAN, |r| r.relmse);
    let times = [budget / 4.0, budget / 2.0, budget];
    let mut out = String::from("| variant | mean spp | pixels converged | ");
    for t in times {
        let _ = write!(out, "relMSE at {t:.1} s | ");
    }
    let _ = writeln!(out, "relMSE / uniform's | time to uniform's relMSE |");
    let _ = writeln!(out, "|{}", " --- |".repeat(4 + times.len()));
    for run in runs {
        let last = run.rows.last().expect("a row per run");
        let converged = match run.threshold {
            Some(_) => format!("{:.1}%", 100.0 * (1.0 - run.last.active_share())),
            None => "-".into(),
        };
        let _ = write!(out, "| {} | {:.1} | {converged} |", run.label, run.last.mean_spp());
        for t in times {
            let _ = write!(out, " {} |", relmse_at(run, t).map_or("-".into(), |e| format!("{e:.3e}")));
        }
        let reached = run
            .rows
            .iter()
            .find(|r| r.relmse <= uniform)
            .map_or("not reached".into(), |r| format!("{:.2} s", r.seconds));
        let done = if run.last.done { format!(" (all stopped at {:.2} s)", last.seconds) } else { String::new() };
        let _ = writeln!(out, " {:.3} | {reached}{done} |", last.relmse / uniform);
    }
    let _ = writeln!(
        out,
        "\nrelMSE: mean over pixels and channels of (x - ref)^2 / (ref^2 + 0.01). Checks' cost with no pixel stopping: threshold 0 renders {:.3} times uniform sampling's samples/s (median of {pairs} alternating pairs at {spp} spp; {:.3} to {:.3}).",
        overhead.median, overhead.low, overhead.high
    );
    out
}

fn write_text(path: &std::path::Path, text: &str) -> Result<(), String> {
    crate::film::output::replace_file(path, |tmp| std::fs::write(tmp, text)).map_err(|e| e.to_string())
}

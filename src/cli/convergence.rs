//! `lucent bench convergence`: what accuracy costs in time. Each strategy renders the
//! scene progressively for a time budget; every completed pass records its time, spp, rays
//! and error against a reference into a CSV, which is then drawn (log-log error against
//! time) and summarised in a Markdown table with fitted slopes and efficiencies.

use super::args::{ConvergenceArgs, StrategyName};
use super::render::open_scene;
use crate::film::output::{replace_file, write_image};
use crate::film::tonemap::Display;
use crate::integrator::{Directions, Integrator, LightSampling, PixelSampling, SamplerKind, Settings};
use crate::render::{Job, RenderSession, Snapshot};
use crate::scene::Scene;
use glam::Vec3;
use std::fmt::Write as _;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// One recorded wave: a strategy's state after a completed pass.
#[derive(Clone, Debug)]
pub struct Row {
    /// Strategy name.
    pub strategy: String,
    /// Render time so far.
    pub seconds: f64,
    /// Samples per pixel so far.
    pub spp: u32,
    /// Rays traced so far.
    pub rays: u64,
    /// Root-mean-square error against the reference, over pixels and channels.
    pub rmse: f64,
    /// Mean of (x - r)^2 / (r^2 + 0.01), over pixels and channels.
    pub relmse: f64,
}

impl StrategyName {
    /// The settings this strategy renders with, from the study's base settings.
    pub fn settings(self, base: Settings) -> Settings {
        // Every strategy but pt-mis-sobol draws independent numbers, whatever the default.
        let base = Settings { sampler: SamplerKind::Independent, ..base };
        let pt = Settings { integrator: Integrator::Path, ..base };
        let drt = |branching, directions| Settings {
            integrator: Integrator::Distribution,
            branching,
            directions,
            allow_expensive: true,
            ..base
        };
        match self {
            StrategyName::PtUniform => {
                Settings { importance_sampling: false, light_sampling: LightSampling::Off, ..pt }
            }
            StrategyName::PtCosine => Settings { light_sampling: LightSampling::Off, ..pt },
            StrategyName::PtExplicit => Settings { light_sampling: LightSampling::Explicit, ..pt },
            StrategyName::PtMis => pt,
            StrategyName::PtMisSobol => Settings { sampler: SamplerKind::Sobol, ..pt },
            StrategyName::Drt4 => drt(4, Directions::Stratified),
            StrategyName::Drt8 => drt(8, Directions::Stratified),
            StrategyName::GridPixel => Settings { pixel_sampling: PixelSampling::Grid, strata: 4, ..pt },
            StrategyName::GridHemisphere => drt(16, Directions::Grid),
            StrategyName::Bdpt => Settings { integrator: Integrator::Bdpt, ..base },
            StrategyName::Vcm => Settings { integrator: Integrator::Vcm, ..base },
        }
    }

    /// Whether the strategy is unbiased (its error should fall as time^-1/2).
    pub fn unbiased(self) -> bool {
        !matches!(self, StrategyName::GridPixel | StrategyName::GridHemisphere | StrategyName::Vcm)
    }

    /// Name as used on the command line and in the outputs.
    pub fn name(self) -> String {
        clap::ValueEnum::to_possible_value(&self).map_or_else(String::new, |v| v.get_name().to_owned())
    }
}

/// Runs `lucent bench convergence`.
pub fn run(args: &ConvergenceArgs) -> Result<(), String> {
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
    let camera = scene.default_camera(1.0);
    let reference = reference(args, &scene, base)?;
    let strategies = if args.strategies.is_empty() { StrategyName::ALL.to_vec() } else { args.strategies.clone() };
    let mut rows = Vec::new();
    for &strategy in &strategies {
        let settings = strategy.settings(base);
        let job = Job { scene: Arc::clone(&scene), camera, settings, window: None, aovs: false };
        let session = RenderSession::new(job, args.threads).map_err(|e| e.to_string())?;
        let mut last: Option<Arc<Snapshot>> = None;
        let wall = Instant::now();
        loop {
            let timeout = Duration::from_secs_f64((args.budget - wall.elapsed().as_secs_f64()).max(0.05));
            let Some(snap) = session.wait_for_update(last.as_ref(), timeout) else { continue };
            if last.as_ref().is_none_or(|l| !Arc::ptr_eq(l, &snap)) {
                rows.push(row(&strategy.name(), &snap, &reference));
            }
            let over = snap.elapsed.as_secs_f64() >= args.budget;
            last = Some(snap);
            if over {
                break;
            }
        }
        let r = rows.last().expect("a row per strategy");
        eprintln!("{:<16} {:>6} spp in {:>6.2} s, RMSE {:.5}", r.strategy, r.spp, r.seconds, r.rmse);
    }
    let csv = to_csv(&rows);
    write_text(&args.out.join("convergence.csv"), &csv)?;
    let summary = summarise(&rows, &strategies, args.budget);
    write_text(&args.out.join("convergence.md"), &summary)?;
    super::plot::error_against_time(&rows, &strategies, &args.out.join("convergence"), &scene.name)?;
    println!("{summary}");
    println!("wrote {}/convergence.{{csv,md,png,svg}}", args.out.display());
    Ok(())
}

/// The reference image: the given EXR, or a long MIS + Sobol render cached in the output
/// folder under a name that records what it depends on.
pub(super) fn reference(args: &ConvergenceArgs, scene: &Scene, base: Settings) -> Result<Vec<Vec3>, String> {
    let path = match &args.reference {
        Some(p) => p.clone(),
        None => args.out.join(format!(
            "reference-{}-{}px-depth{}-{}s.exr",
            scene.name, base.width, base.max_depth, args.reference_budget
        )),
    };
    if path.exists() {
        let img = image::open(&path).map_err(|e| format!("cannot read reference {}: {e}", path.display()))?;
        let img = img.into_rgb32f();
        if (img.width(), img.height()) != (base.width, base.height) {
            return Err(format!(
                "reference {} is {}x{}, the study renders {}x{}",
                path.display(),
                img.width(),
                img.height(),
                base.width,
                base.height
            ));
        }
        return Ok(img.pixels().map(|p| Vec3::from(p.0)).collect());
    }
    if args.reference.is_some() {
        return Err(format!("reference {}: no such file", path.display()));
    }
    // Another seed than the strategies': the Sobol strategy would otherwise repeat the
    // reference's first samples and look better than it is.
    let settings = Settings { sampler: SamplerKind::Sobol, seed: base.seed ^ 0x5eed_5eed, ..base };
    let job = Job {
        scene: Arc::new(scene_copy(scene)),
        camera: scene.default_camera(1.0),
        settings,
        window: None,
        aovs: false,
    };
    let session = RenderSession::new(job, args.threads).map_err(|e| e.to_string())?;
    let started = Instant::now();
    let mut snap = None;
    while started.elapsed().as_secs_f64() < args.reference_budget {
        let left = (args.reference_budget - started.elapsed().as_secs_f64()).max(0.05);
        snap = session.wait_for_update(snap.as_ref(), Duration::from_secs_f64(left)).or(snap);
    }
    let snap = snap.ok_or("the reference render produced no image")?;
    write_image(&path, snap.width, snap.height, &snap.mean, &Display::default()).map_err(|e| e.to_string())?;
    eprintln!(
        "rendered the reference (MIS + Sobol, {} spp) in {:.1} s; cached as {}",
        snap.spp,
        started.elapsed().as_secs_f64(),
        path.display()
    );
    Ok(snap.mean.clone())
}

/// A scene sharing `scene`'s geometry and images (sessions take ownership of an `Arc`).
fn scene_copy(scene: &Scene) -> Scene {
    scene.with_edits(scene.materials.clone(), scene.lights.clone())
}

fn row(strategy: &str, snap: &Snapshot, reference: &[Vec3]) -> Row {
    let (mut se, mut rel) = (0.0f64, 0.0f64);
    for (x, r) in snap.mean.iter().zip(reference) {
        for c in 0..3 {
            let d = (x[c] - r[c]) as f64;
            se += d * d;
            rel += d * d / ((r[c] as f64).powi(2) + 0.01);
        }
    }
    let n = (3 * reference.len()) as f64;
    Row {
        strategy: strategy.into(),
        seconds: snap.elapsed.as_secs_f64(),
        spp: snap.spp,
        rays: snap.rays,
        rmse: (se / n).sqrt(),
        relmse: rel / n,
    }
}

/// The CSV: header `strategy,seconds,spp,rays,rmse,relmse`, one row per wave.
pub fn to_csv(rows: &[Row]) -> String {
    let mut out = String::from("strategy,seconds,spp,rays,rmse,relmse\n");
    for r in rows {
        let _ = writeln!(out, "{},{:.6},{},{},{:.8e},{:.8e}", r.strategy, r.seconds, r.spp, r.rays, r.rmse, r.relmse);
    }
    out
}

/// Least-squares slope of log(rmse) against log(seconds), over a strategy's waves from
/// 4 spp on (the first passes are dominated by start-up); None with fewer than 3 points.
pub fn slope(rows: &[&Row]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.spp >= 4 && r.seconds > 0.0 && r.rmse > 0.0)
        .map(|r| (r.seconds.ln(), r.rmse.ln()))
        .collect();
    if pts.len() < 3 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The Markdown summary: per strategy, the final spp and error, the fitted slope, the
/// time to reach error levels, the error after fixed times, and the efficiency
/// 1 / (MSE x time) with its ratio to the best strategy.
fn summarise(rows: &[Row], strategies: &[StrategyName], budget: f64) -> String {
    let of = |s: StrategyName| rows.iter().filter(|r| r.strategy == s.name()).collect::<Vec<_>>();
    let finals: Vec<&Row> = strategies.iter().filter_map(|&s| of(s).last().copied()).collect();
    let mut sorted: Vec<f64> = finals.iter().map(|r| r.rmse).collect();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(1.0);
    let levels = [2.0 * median, median, 0.5 * median];
    let times = [budget / 4.0, budget / 2.0, budget];
    let efficiency = |r: &Row| 1.0 / (r.rmse * r.rmse * r.seconds.max(1e-9));
    let best = finals.iter().map(|r| efficiency(r)).fold(0.0, f64::max);
    let mut out = String::new();
    let _ = write!(out, "| strategy | spp | RMSE | slope |");
    for l in levels {
        let _ = write!(out, " time to RMSE {l:.4} |");
    }
    for t in times {
        let _ = write!(out, " RMSE at {t:.1} s |");
    }
    let _ = writeln!(out, " efficiency 1/(MSE s) | vs best |");
    let _ = writeln!(out, "|{}", " --- |".repeat(4 + levels.len() + times.len() + 2));
    for &s in strategies {
        let waves = of(s);
        let Some(last) = waves.last() else { continue };
        let slope = slope(&waves).map_or("-".into(), |k| format!("{k:.2}"));
        let label = if s.unbiased() { s.name() } else { format!("{} (biased)", s.name()) };
        let _ = write!(out, "| {label} | {} | {:.5} | {slope} |", last.spp, last.rmse);
        for l in levels {
            let reached =
                waves.iter().find(|r| r.rmse <= l).map_or("not reached".into(), |r| format!("{:.2} s", r.seconds));
            let _ = write!(out, " {reached} |");
        }
        for t in times {
            let at = waves.iter().rev().find(|r| r.seconds <= t).map_or("-".into(), |r| format!("{:.5}", r.rmse));
            let _ = write!(out, " {at} |");
        }
        let e = efficiency(last);
        let _ = writeln!(out, " {e:.3e} | {:.3} |", e / best);
    }
    out
}

fn write_text(path: &Path, text: &str) -> Result<(), String> {
    replace_file(path, |tmp| std::fs::write(tmp, text)).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(seconds: f64, rmse: f64, spp: u32) -> Row {
        Row { strategy: "x".into(), seconds, spp, rays: 0, rmse, relmse: 0.0 }
    }

    #[test]
    fn the_slope_of_an_inverse_square_root_law_is_minus_one_half() {
        let rows: Vec<Row> = (2..10).map(|k| 2f64.powi(k)).map(|t| r(t, 0.3 / t.sqrt(), 1 << 10)).collect();
        let refs: Vec<&Row> = rows.iter().collect();
        assert!((slope(&refs).unwrap() + 0.5).abs() < 1e-9);
        assert!(slope(&refs[..2]).is_none());
    }

    #[test]
    fn csv_has_the_documented_header_and_one_line_per_wave() {
        let csv = to_csv(&[r(1.0, 0.1, 4), r(2.0, 0.07, 8)]);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "strategy,seconds,spp,rays,rmse,relmse");
        assert_eq!(lines.len(), 3);
        assert!(lines[2].starts_with("x,2.000000,8,0,"));
    }
}

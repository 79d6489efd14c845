//! `lucent bench`: samples/s and rays/s, measured with variants alternating in one run so
//! that their ratios are meaningful on a noisy machine. `kernel` compares the scene's own
//! feature switches (what it pays for) with every switch on, on the Cornell box;
//! `robustness` measures each numerical-robustness mechanism by switching it off;
//! `convergence`, `throughput` and `adaptive` have modules of their own.

use super::args::{BenchArgs, BenchKind, ConvergenceArgs, Mechanism};
use super::render::open_scene;
use crate::integrator::Settings;
use crate::render::{Job, RenderSession};
use crate::scene::{Features, Scene};
use std::sync::Arc;

/// One measured configuration.
struct Variant {
    label: String,
    scene: Arc<Scene>,
    settings: Settings,
}

/// Runs `lucent bench`.
pub fn run(args: &BenchArgs) -> Result<(), String> {
    if args.spp == 0 || args.runs == 0 || args.threads == Some(0) {
        return Err("--spp, --runs and --threads must be at least 1".into());
    }
    if args.kind == BenchKind::Convergence {
        return super::convergence::run(&convergence_args(args)?);
    }
    if args.kind == BenchKind::Adaptive {
        return super::adaptive::run(&convergence_args(args)?, &args.thresholds, args.min_spp, args.runs);
    }
    if args.kind == BenchKind::Throughput {
        return super::throughput::run(args);
    }
    let size = args.size.unwrap_or(256);
    let settings =
        Settings { width: size, height: size, max_depth: 7, target_spp: Some(args.spp), ..Settings::default() };
    settings.validate().map_err(|e| e.to_string())?;
    let threads = args.threads.map_or_else(|| rayon::current_num_threads().to_string(), |t| t.to_string());
    let scenes: Vec<Option<&std::path::Path>> = match args.kind {
        BenchKind::Kernel if !args.scenes.is_empty() => return Err("bench kernel uses the built-in scene only".into()),
        _ if args.scenes.is_empty() => vec![None],
        _ => args.scenes.iter().map(|p| Some(p.as_path())).collect(),
    };
    for path in scenes {
        let scene = Arc::new(open_scene(path, &Default::default())?);
        println!(
            "{}: {} triangles, {s}x{s}, max depth 7, MIS, {} spp per run, {} runs each, {threads} threads",
            scene.name,
            scene.geometry.len(),
            args.spp,
            args.runs,
            s = size
        );
        println!("features of the scene: {:?}", scene.features);
        let variants = match args.kind {
            BenchKind::Kernel => kernel_variants(&scene, settings),
            _ => robustness_variants(&scene, settings),
        };
        measure(&variants, args)?;
    }
    Ok(())
}

/// The options of the convergence study (or of the adaptive bench, which shares them), checked.
fn convergence_args(args: &BenchArgs) -> Result<ConvergenceArgs, String> {
    let kind = clap::ValueEnum::to_possible_value(&args.kind).map_or_else(String::new, |v| v.get_name().to_owned());
    let budget = args.budget.ok_or_else(|| format!("bench {kind} needs --budget SECONDS"))?;
    let out = args.out.clone().ok_or_else(|| format!("bench {kind} needs --out DIR"))?;
    if args.scenes.len() > 1 {
        return Err(format!("bench {kind} takes one scene"));
    }
    let reference_budget = args.reference_budget.unwrap_or(8.0 * budget);
    if !(reference_budget > 0.0 && reference_budget.is_finite()) {
        return Err(format!("--reference-budget {reference_budget} must be a positive number of seconds"));
    }
    Ok(ConvergenceArgs {
        scene: args.scenes.first().cloned(),
        budget,
        out,
        reference: args.reference.clone(),
        reference_budget,
        strategies: args.strategies.clone(),
        size: args.size.unwrap_or(64),
        max_depth: args.max_depth,
        seed: args.seed,
        threads: args.threads,
    })
}

fn kernel_variants(scene: &Arc<Scene>, settings: Settings) -> Vec<Variant> {
    let mut general = scene.with_edits(scene.materials.clone(), scene.lights.clone());
    general.features = Features::ALL;
    let general = Arc::new(general);
    vec![
        Variant { label: "scene's features".into(), scene: Arc::clone(scene), settings },
        Variant { label: "every feature on".into(), scene: general, settings },
    ]
}

fn robustness_variants(scene: &Arc<Scene>, settings: Settings) -> Vec<Variant> {
    let with = |label: String, settings: Settings| Variant { label, scene: Arc::clone(scene), settings };
    let mut variants = vec![with("all mechanisms".into(), settings)];
    for m in Mechanism::ALL {
        variants.push(with(format!("without {m:?}").to_lowercase(), m.disable(settings)));
    }
    variants.push(with("without any".into(), Mechanism::ALL.iter().fold(settings, |s, m| m.disable(s))));
    variants
}

/// Runs every variant `runs` times in turn and prints medians and ratios to the first.
fn measure(variants: &[Variant], args: &BenchArgs) -> Result<(), String> {
    let mut results: Vec<Vec<(f64, f64)>> = vec![Vec::new(); variants.len()];
    for _ in 0..args.runs {
        for (v, out) in variants.iter().zip(&mut results) {
            let camera = v.scene.default_camera(1.0);
            let job = Job { scene: Arc::clone(&v.scene), camera, settings: v.settings, window: None, aovs: false };
            let snap = RenderSession::new(job, args.threads).map_err(|e| e.to_string())?.wait_until_done();
            out.push((snap.samples_per_second(), snap.rays_per_second()));
        }
    }
    let medians: Vec<(f64, f64)> = results
        .iter_mut()
        .map(|r| {
            r.sort_by(|a, b| a.0.total_cmp(&b.0));
            r[r.len() / 2]
        })
        .collect();
    let base = medians[0].0;
    for (v, m) in variants.iter().zip(&medians) {
        println!(
            "  {:<22} {:>7.3} Msamples/s {:>6.2} Mrays/s   samples/s ratio to {}: {:.3}",
            v.label,
            m.0 / 1e6,
            m.1 / 1e6,
            variants[0].label,
            m.0 / base
        );
    }
    Ok(())
}

//! `lucent render`: load, render progressively to a sample or time budget, write the image.

use super::args::RenderArgs;
use crate::film::output::{check_writable, write_image};
use crate::loader::{builtin, gltf};
use crate::render::{Job, RenderSession, Snapshot};
use crate::scene::{
    Scene,
    environment::{EnvSettings, Environment},
};
use indicatif::{ProgressBar, ProgressStyle};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Loads the scene named on the command line, or the built-in Cornell box, lit by
/// `environment`; prints warnings.
pub fn load_scene(path: Option<&std::path::Path>, environment: &EnvSettings) -> Result<Scene, String> {
    let env = (!environment.is_black()).then(|| Environment::load(environment.clone())).transpose()?;
    let desc = match path {
        Some(p) => gltf::load(p).map_err(|e| e.to_string())?,
        None => builtin::cornell_box(),
    };
    let scene = Scene::build(desc);
    let scene = if env.is_some() { scene.with_environment(env) } else { scene };
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    Ok(scene)
}

/// Runs `lucent render`.
pub fn run(args: &RenderArgs) -> Result<(), String> {
    if let Some(t) = args.time
        && !(t > 0.0 && t.is_finite())
    {
        return Err(format!("--time {t} must be a positive number of seconds"));
    }
    if args.spp == Some(0) {
        return Err("--spp must be at least 1".into());
    }
    check_writable(&args.out).map_err(|e| e.to_string())?;
    let target = match (args.spp, args.time) {
        (Some(n), _) => Some(n),
        (None, Some(_)) => None,
        (None, None) => Some(64),
    };
    let resolved = args.options.resolve(target)?;
    let settings = resolved.settings;
    if settings.integrator == crate::integrator::Integrator::Distribution {
        let rays = settings.rays_per_sample_bound();
        let per_pixel = target.map_or(String::new(), |n| format!(", {:.3e} per pixel at {n} spp", rays * n as f64));
        eprintln!("distribution ray tracing: up to {rays:.3e} rays per sample{per_pixel}");
    }
    let scene = Arc::new(load_scene(args.scene.as_deref(), &resolved.environment)?);
    let camera = super::args::pick_camera(args.options.camera, resolved.camera, &scene)?
        .unwrap_or_else(|| scene.default_camera(settings.width as f32 / settings.height as f32));
    let session = RenderSession::new(Job { scene: Arc::clone(&scene), camera, settings }, args.options.threads)
        .map_err(|e| e.to_string())?;

    let bar = match (args.time, target) {
        (Some(t), _) => ProgressBar::new((t * 1000.0) as u64).with_style(style("{elapsed_precise} [{bar:40}] {msg}")),
        (None, Some(n)) => {
            ProgressBar::new(n as u64).with_style(style("{elapsed_precise} [{bar:40}] {pos}/{len} spp {msg}"))
        }
        (None, None) => unreachable!("a target or a time budget is always set"),
    };
    let start = Instant::now();
    let mut latest: Option<Arc<Snapshot>> = None;
    loop {
        if let Some(s) = session.wait_for_update(latest.as_ref(), Duration::from_millis(200)) {
            bar.set_message(format!("{:.2} Msamples/s", s.samples_per_second() / 1e6));
            if args.time.is_none() {
                bar.set_position(s.spp as u64);
            }
            latest = Some(s);
        }
        if let Some(t) = args.time {
            bar.set_position(start.elapsed().as_millis() as u64);
            if start.elapsed().as_secs_f64() >= t {
                break;
            }
        }
        if latest.as_ref().is_some_and(|s| s.done) {
            break;
        }
    }
    drop(session);
    bar.finish_and_clear();
    let Some(snap) = latest else {
        return Err("the time budget ended before the first pass completed: give more --time".into());
    };
    write_image(&args.out, snap.width, snap.height, &snap.mean, &resolved.display).map_err(|e| e.to_string())?;
    println!("{}; wrote {}", snap.summary(&scene.name), args.out.display());
    let causes = crate::integrator::nan::report();
    if !causes.is_empty() {
        eprintln!("warning: non-finite values by cause: {causes}");
    }
    Ok(())
}

fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()).progress_chars("=> ")
}

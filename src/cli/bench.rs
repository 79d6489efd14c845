//! `lucent bench`: samples/s and rays/s on the built-in Cornell box (256x256, max depth 7),
//! for the kernel specialised to the scene's features and for the general kernel, measured
//! alternately in one run so that their ratio is meaningful on a noisy machine.

use super::args::BenchArgs;
use crate::integrator::Settings;
use crate::loader::builtin;
use crate::render::{Job, RenderSession};
use crate::scene::{Features, Scene};
use std::sync::Arc;

/// Runs `lucent bench`.
pub fn run(args: &BenchArgs) -> Result<(), String> {
    if args.spp == 0 || args.runs == 0 || args.threads == Some(0) {
        return Err("--spp, --runs and --threads must be at least 1".into());
    }
    let specialised = Arc::new(Scene::build(builtin::cornell_box()));
    let mut general = Scene::build(builtin::cornell_box());
    general.features = Features::ALL;
    let general = Arc::new(general);
    let settings =
        Settings { width: 256, height: 256, max_depth: 7, target_spp: Some(args.spp), ..Settings::default() };
    println!(
        "Cornell box 256x256, max depth 7, MIS, {} spp per run, {} runs each, {} threads",
        args.spp,
        args.runs,
        args.threads.map_or_else(|| rayon::current_num_threads().to_string(), |t| t.to_string())
    );
    println!("features of the scene: {:?}", specialised.features);
    let mut results: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    for _ in 0..args.runs {
        for (i, scene) in [&specialised, &general].into_iter().enumerate() {
            let camera = scene.default_camera(1.0);
            let job = Job { scene: Arc::clone(scene), camera, settings };
            let session = RenderSession::new(job, args.threads).map_err(|e| e.to_string())?;
            let snap = session.wait_until_done();
            results[i].push((snap.samples_per_second(), snap.rays_per_second()));
        }
    }
    let median = |v: &mut Vec<(f64, f64)>| {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v[v.len() / 2]
    };
    let spec = median(&mut results[0]);
    let general = median(&mut results[1]);
    println!("specialised kernel: {:.3} Msamples/s, {:.2} Mrays/s", spec.0 / 1e6, spec.1 / 1e6);
    println!("general kernel:     {:.3} Msamples/s, {:.2} Mrays/s", general.0 / 1e6, general.1 / 1e6);
    println!("specialised / general samples/s: {:.3}", spec.0 / general.0);
    Ok(())
}

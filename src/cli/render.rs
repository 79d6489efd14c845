//! `lucent render`: open, render progressively to a sample or time budget, write the image.

use super::args::{RenderArgs, RenderOptions};
use crate::config::ViewFile;
use crate::film::denoise::{self, denoise};
use crate::film::output::{check_can_write, check_writable, replace_file, write_image};
use crate::film::piece::{self, FORMAT, Header};
use crate::film::window::Window;
use crate::loader::save;
use crate::open::{OpenOptions, open};
use crate::render::{Job, RenderSession, Snapshot};
use crate::scene::{Scene, geometry::Geometry, instances::Instancing};
use indicatif::{ProgressBar, ProgressStyle};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Opens the scene named on the command line (or the built-in Cornell box) with `options`,
/// printing its warnings.
pub fn open_scene(path: Option<&std::path::Path>, options: &OpenOptions) -> Result<Scene, String> {
    let scene = open(path, options, &mut |_| {})?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    Ok(scene)
}

/// Runs `lucent render`: applies the view file's edits, writes the edited scene as glTF
/// with --save-gltf, and renders it with --out.
pub fn run(args: &RenderArgs) -> Result<(), String> {
    if let Some(t) = args.time
        && !(t > 0.0 && t.is_finite())
    {
        return Err(format!("--time {t} must be a positive number of seconds"));
    }
    if args.denoise {
        denoise::available()?;
    }
    if (args.denoise || args.aovs) && args.out.is_none() {
        return Err("--denoise and --aovs write images: give --out a .png or .exr".into());
    }
    let piece = args.out.as_ref().is_some_and(|o| o.extension().is_some_and(|e| e == "part"));
    if piece && (args.denoise || args.aovs) {
        return Err("--denoise and --aovs write images, not pieces: give --out a .png or .exr".into());
    }
    match &args.out {
        Some(out) if piece => check_can_write(out).map_err(|e| e.to_string())?,
        Some(out) => _ = check_writable(out).map_err(|e| e.to_string())?,
        None => {}
    }
    if let Some(gltf) = &args.save_gltf {
        check_can_write(gltf).map_err(|e| e.to_string())?;
    }
    for path in sidecars(args) {
        check_can_write(&path).map_err(|e| e.to_string())?;
    }
    let view = args.options.resolve(if args.time.is_none() { Some(64) } else { None })?;
    let mut settings = view.settings;
    if let Some(range) = &args.samples {
        if settings.noise_threshold.is_some() {
            return Err("--noise-threshold stops pixels by their samples from the first on, so it cannot render a range of samples (--samples): split the render by --region instead".into());
        }
        let (a, b) = super::merge::sample_range(range)?;
        if args.time.is_some() || args.options.settings_given("spp") {
            return Err("--samples A..B sets the samples: give it without --time and --spp".into());
        }
        (settings.first_sample, settings.target_spp) = (a, Some(b - a));
        if settings.pixel_sampling != crate::integrator::PixelSampling::Random
            && !args.options.params.given("strata")
            && args.options.view.is_none()
        {
            eprintln!(
                "warning: {} pixel sampling in pieces: give every piece the whole render's --strata",
                settings.pixel_sampling.name()
            );
        }
    }
    if piece && args.time.is_some() {
        return Err("a piece (--out NAME.part) needs a sample range or --spp, not --time".into());
    }
    let target = settings.target_spp;
    if settings.integrator == crate::integrator::Integrator::Distribution {
        let rays = settings.rays_per_sample_bound();
        let per_pixel = target.map_or(String::new(), |n| format!(", {:.3e} per pixel at {n} spp", rays * n as f64));
        eprintln!("distribution ray tracing: up to {rays:.3e} rays per sample{per_pixel}");
    }
    let scene = open_scene(
        args.scene.as_deref(),
        &OpenOptions {
            environment: view.environment.clone(),
            keep_dark: args.options.keeps_dark(),
            variant: args.options.variant.clone(),
            instancing: args.options.instancing(),
            ..OpenOptions::default()
        },
    )?;
    let scene = Arc::new(edited(scene, &view, args.scene.as_deref(), args.save_gltf.as_deref())?);
    let Some(out) = &args.out else { return Ok(()) };
    let camera = match args.options.camera {
        Some(i) => scene.file_camera(i).map_err(|e| format!("--{e}"))?,
        None => view.camera.unwrap_or_else(|| scene.default_camera(settings.width as f32 / settings.height as f32)),
    };
    let window = args.region.as_deref().map(|r| Window::parse(r, settings.width, settings.height)).transpose()?;
    let aovs = args.denoise || args.aovs;
    let start = Instant::now();
    let session =
        RenderSession::new(Job { scene: Arc::clone(&scene), camera, settings, window, aovs }, args.options.threads)
            .map_err(|e| e.to_string())?;
    // A budget too far off for the clock (1e30 s) simply never ends the render.
    if let Some(deadline) = args.time.and_then(|t| start.checked_add(Duration::try_from_secs_f64(t).ok()?)) {
        session.stop_at(deadline);
    }
    // The progress bar reads counts; only the last snapshot's images are written.
    session.images_at_end_only();
    eprintln!("{}: {}", scene.name, geometry_line(&scene.geometry));
    eprintln!("{}: simulating {}", scene.name, crate::integrator::simulated_effects(&scene, &settings));

    let bar = match (args.time, target) {
        (Some(t), _) => ProgressBar::new((t * 1000.0) as u64).with_style(style("{elapsed_precise} [{bar:40}] {msg}")),
        (None, Some(n)) => {
            ProgressBar::new(n as u64).with_style(style("{elapsed_precise} [{bar:40}] {pos}/{len} spp {msg}"))
        }
        (None, None) => unreachable!("a target or a time budget is always set"),
    };
    let mut latest: Option<Arc<Snapshot>> = None;
    loop {
        if let Some(s) = session.wait_for_update(latest.as_ref(), Duration::from_millis(200)) {
            let active = match settings.noise_threshold {
                Some(_) => format!(", {:.1}% of pixels active", 100.0 * s.active_share()),
                None => String::new(),
            };
            bar.set_message(format!("{:.2} Msamples/s{active}", s.samples_per_second() / 1e6));
            if args.time.is_none() {
                bar.set_position(s.spp as u64);
            }
            latest = Some(s);
        }
        // With a time budget the session ends the job at the deadline; only a first pass
        // still running then is given up.
        if let Some(t) = args.time {
            bar.set_position(start.elapsed().as_millis() as u64);
            if latest.is_none() && start.elapsed().as_secs_f64() >= t {
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
    let mut written = vec![out.clone()];
    if piece {
        let film = snap.film.as_ref().ok_or("the render stopped before its samples were done")?;
        let header = Header {
            format: FORMAT,
            scene: scene_id(args.scene.as_deref(), &view, &args.options)?,
            settings: toml::to_string(&settings.image_defining()).map_err(|e| e.to_string())?,
            camera: format!("{camera:?}"),
            display: view.display,
            first: settings.first_sample,
            count: snap.spp,
            width: settings.width,
            height: settings.height,
            window: window.unwrap_or(Window::full(settings.width, settings.height)),
            rejected: snap.rejected,
        };
        piece::write(out, &header, film).map_err(|e| e.to_string())?;
    } else {
        let write = |path: &Path, pixels: &[glam::Vec3]| {
            write_image(path, snap.width, snap.height, pixels, &view.display).map_err(|e| e.to_string())
        };
        if args.denoise {
            let start = Instant::now();
            let denoised = denoise(&snap.mean, snap.aovs.as_ref(), snap.width, snap.height)?;
            eprintln!("denoised in {:.0} ms", start.elapsed().as_secs_f64() * 1e3);
            write(out, &denoised)?;
            write(&beside(out, "noisy"), &snap.mean)?;
        } else {
            write(out, &snap.mean)?;
        }
        if args.aovs {
            let aovs = snap.aovs.as_ref().ok_or("the render kept no AOVs")?;
            write(&beside(out, "albedo"), &aovs.albedo)?;
            write(&beside(out, "normal"), &aovs.normal)?;
        }
        written.extend(sidecars(args));
    }
    let names: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
    println!("{}; wrote {}", snap.summary(&scene.name), names.join(", "));
    if let Some(e) = snap.relative_error() {
        eprintln!(
            "estimated noise: {:.1}% (mean relative standard error of pixel luminance, before denoising)",
            100.0 * e
        );
    }
    if let Some(t) = settings.noise_threshold {
        let (low, high) = (snap.pixel_spp.iter().min(), snap.pixel_spp.iter().max());
        println!(
            "noise threshold {}%: mean {:.1} spp ({} to {}), {:.1}% of pixels converged",
            100.0 * t,
            snap.mean_spp(),
            low.unwrap_or(&0),
            high.unwrap_or(&0),
            100.0 * (1.0 - snap.active_share())
        );
    }
    let causes = crate::integrator::nan::report();
    if !causes.is_empty() {
        eprintln!("warning: non-finite values by cause: {causes}");
    }
    Ok(())
}

/// The files written beside --out: with --denoise the noisy image (NAME.noisy.exr), then
/// with --aovs the albedo and normal images (NAME.albedo.exr, NAME.normal.exr).
fn sidecars(args: &RenderArgs) -> Vec<PathBuf> {
    let Some(out) = &args.out else { return Vec::new() };
    let noisy = args.denoise.then(|| beside(out, "noisy"));
    let aovs = if args.aovs { vec![beside(out, "albedo"), beside(out, "normal")] } else { Vec::new() };
    noisy.into_iter().chain(aovs).collect()
}

/// NAME.`what`.exr for --out NAME.png or NAME.exr.
fn beside(out: &Path, what: &str) -> PathBuf {
    out.with_extension(format!("{what}.exr"))
}

/// `scene` with the view file's material and light edits applied (sharing its BVH), after
/// writing it as glTF to `save_gltf` if asked (the file at `path`, or the built-in scene's,
/// with the edits patched in).
fn edited(scene: Scene, view: &ViewFile, path: Option<&Path>, save_gltf: Option<&Path>) -> Result<Scene, String> {
    let (mut materials, mut lights) = (scene.materials.clone(), scene.lights.clone());
    view.apply_edits(&mut materials, &mut lights)?;
    if let Some(out) = save_gltf {
        let edits = save::Edits { original: (&scene.materials, &scene.lights), edited: (&materials, &lights) };
        let bytes = save::patched(path, edits, out)?;
        replace_file(out, |tmp| std::fs::write(tmp, &bytes)).map_err(|e| e.to_string())?;
        println!("wrote {}", out.display());
    }
    Ok(if view.has_edits() { scene.with_edits(materials, lights) } else { scene })
}

/// One line on the geometry: triangles, instances, the BVHs' memory and build time.
fn geometry_line(g: &Geometry) -> String {
    let bytes = crate::memory::format_bytes(g.bytes() as u64);
    let build = g.build_time().as_secs_f64();
    match g.instance_count() {
        0 => format!("{} triangles, {bytes} with the BVH, built in {build:.3} s", g.len()),
        n => format!(
            "{} triangles placed: {} stored once and {n} placements of {} meshes, {bytes} with the BVHs, built in {build:.3} s",
            g.len(),
            g.unique_len(),
            g.instanced_meshes()
        ),
    }
}

/// What a piece's header names its scene by: the hash of the file and its sidecars, its
/// material variant and instancing, and the hash of the view file's material and light edits if it has any
/// (pieces of differently edited scenes must not merge).
fn scene_id(path: Option<&Path>, view: &ViewFile, options: &RenderOptions) -> Result<String, String> {
    let mut hash = super::merge::scene_hash(path)?;
    if let Some(v) = &options.variant {
        hash = format!("{hash} variant {v:?}");
    }
    if options.instancing() != Instancing::Auto {
        hash = format!("{hash} instancing {}", options.instancing);
    }
    if !view.has_edits() {
        return Ok(hash);
    }
    let edits = ViewFile { materials: view.materials.clone(), lights: view.lights.clone(), ..ViewFile::default() };
    let text = toml::to_string(&edits).map_err(|e| e.to_string())?;
    let digest: String = Sha256::digest(text.as_bytes()).iter().map(|b| format!("{b:02x}")).collect();
    Ok(format!("{hash} edited {digest}"))
}

fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()).progress_chars("=> ")
}

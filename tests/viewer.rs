//! The viewer: its state logic headless (loading, restarts, edits, picking, views), and
//! end to end in a real window under Xvfb, whose screenshot must equal the headless render.

mod common;

use lucent::film::false_colour;
use lucent::film::tonemap::Display;
use lucent::integrator::{LightSampling, Settings};
use lucent::loader::builtin;
use lucent::render::Snapshot;
use lucent::scene::Scene;
use lucent::scene::environment::{BUILT_IN, EnvSettings, Environment};
use lucent::viewer::state::{ImageView, ViewerState};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::time::{Duration, Instant};

fn viewer() -> ViewerState {
    let settings = Settings { width: 48, height: 48, ..Settings::default() };
    ViewerState::new(Scene::build(builtin::cornell_box()), None, settings, true, Display::default(), None, Some(1))
        .unwrap()
}

fn wait_for_load(state: &mut ViewerState) {
    let start = Instant::now();
    while !state.poll_loading() {
        assert!(start.elapsed() < Duration::from_secs(60), "loading never finished");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// The next image of the current job at full resolution (after `seen`), letting a preview
/// sharpen to it first as the window does.
fn next_full_image(state: &mut ViewerState, seen: Option<&Arc<Snapshot>>) -> Arc<Snapshot> {
    let start = Instant::now();
    loop {
        assert!(start.elapsed() < Duration::from_secs(60), "no full-resolution image");
        state.sync();
        if let Some(snap) = state.wait_for_update(seen, Duration::from_millis(100)) {
            let full = state.effective_settings();
            if snap.generation == state.generation() && !state.previewing() && snap.width == full.width {
                return snap;
            }
            state.snapshot();
        }
    }
}

/// Records full-resolution images of the current job until its curve has two points.
fn two_points(state: &mut ViewerState) {
    let mut seen: Option<Arc<Snapshot>> = None;
    loop {
        let snap = next_full_image(state, seen.as_ref());
        state.record_convergence(&snap);
        let same_job = seen.as_ref().is_some_and(|s| s.generation == snap.generation);
        if same_job && state.convergence.current.as_ref().is_some_and(|c| c.points.len() >= 2) {
            return;
        }
        seen = Some(snap);
    }
}

#[test]
fn another_scene_drops_the_last_save_message_and_a_tuned_file_saves_over_itself() {
    let mut state = viewer();
    let dir = common::scratch("viewer-tuned");
    state.gltf_path = dir.join("cornell-box.tuned.gltf").display().to_string();
    state.gltf_saved = Some(state.save_gltf());
    assert!(matches!(&state.gltf_saved, Some(Ok(p)) if p.exists()), "{:?}", state.gltf_saved);
    let tuned = dir.join("Box.tuned.glb");
    std::fs::copy(common::asset("Box/glTF-Binary/Box.glb"), &tuned).unwrap();
    state.open(tuned.clone());
    wait_for_load(&mut state);
    assert!(state.error.is_none() && state.scene.name != "cornell-box", "{:?}", state.error);
    assert!(state.gltf_saved.is_none(), "the message about the Cornell box is gone with it");
    assert_eq!(state.gltf_path, tuned.display().to_string(), "not Box.tuned.tuned.glb");
}

#[test]
fn the_convergence_plot_keeps_a_curve_per_estimator_not_one_per_camera_move_or_edit() {
    let mut state = viewer();
    two_points(&mut state);
    state.settings.light_sampling = LightSampling::Explicit;
    two_points(&mut state);
    let labels = |state: &ViewerState| -> Vec<String> {
        let log = &state.convergence;
        log.previous.iter().chain(&log.current).map(|c| format!("#{} {}", c.number, c.label)).collect()
    };
    assert_eq!(labels(&state), ["#1 default estimator", "#2 lights explicit"], "another estimator is compared");
    state.camera.orbit(glam::Vec2::new(10.0, 0.0), 48.0);
    two_points(&mut state);
    assert_eq!(labels(&state), ["#1 lights explicit"], "the camera moved: another image, the plot starts over");
    state.edit(|materials, _| materials[0].base_color = glam::Vec3::new(0.2, 0.4, 0.6));
    two_points(&mut state);
    assert_eq!(labels(&state), ["#1 lights explicit"], "an edit is another image too");
    state.settings.seed = 7;
    two_points(&mut state);
    assert_eq!(labels(&state), ["#1 lights explicit"], "another seed replaces the curve of the same estimator");
}

#[test]
fn an_opened_scene_shows_its_coarsest_preview_first_and_sharpens() {
    let mut state = viewer();
    state.open(common::asset("Box/glTF-Binary/Box.glb"));
    wait_for_load(&mut state);
    assert!(state.sync());
    assert_eq!(state.effective_settings().width, 6, "1/8 of 48: the first image comes at once");
    let full = next_full_image(&mut state, None);
    assert_eq!((full.width, full.height), (48, 48));
}

#[test]
fn a_file_camera_with_an_aspect_ratio_is_letterboxed_whole() {
    use glam::UVec2;
    use lucent::viewer::state::render_size;
    assert_eq!(render_size(UVec2::new(599, 800), Some(1.5)), UVec2::new(599, 399), "landscape in portrait");
    assert_eq!(render_size(UVec2::new(1600, 800), Some(1.5)), UVec2::new(1200, 800), "pillarboxed");
    assert_eq!(render_size(UVec2::new(599, 800), None), UVec2::new(599, 800), "no frame: the whole area");
    assert_eq!(render_size(UVec2::new(0, 5), Some(1e6)), UVec2::new(1, 1), "never empty");
    // prism.gltf's camera is made for 3:2: in the viewer's portrait area it keeps 3:2,
    // through a move too, and the view of a scene without cameras fills the area.
    let desc = lucent::loader::gltf::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scenes/prism.gltf")));
    let scene = Scene::build(desc.unwrap());
    assert_eq!(scene.cameras[0].1.aspect, Some(1.5));
    let settings = Settings { width: 64, height: 64, ..Settings::default() };
    let mut state = ViewerState::new(scene, None, settings, false, Display::default(), None, Some(1)).unwrap();
    state.viewport = UVec2::new(599, 800);
    let s = state.effective_settings();
    assert_eq!((s.width, s.height), (599, 399));
    state.camera.orbit(glam::Vec2::new(10.0, 0.0), 399.0);
    assert_eq!(state.aspect(), 599.0 / 399.0, "the frame is kept through a move");
    let settings = Settings { width: 64, height: 64, ..Settings::default() };
    let scene = Scene::build(lucent::loader::gltf::load(&common::asset("Box/glTF-Binary/Box.glb")).unwrap());
    assert!(scene.cameras.is_empty());
    let mut state = ViewerState::new(scene, None, settings, false, Display::default(), None, Some(1)).unwrap();
    state.viewport = UVec2::new(599, 800);
    let s = state.effective_settings();
    assert_eq!((s.width, s.height), (599, 800), "without a file camera, the whole area");
}

#[test]
fn the_camera_list_says_what_each_file_camera_frames() {
    // prism.gltf's camera looks at the prism (62% of its frame) in front of the wall; the same camera turned
    // round sees only the background.
    let desc = lucent::loader::gltf::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scenes/prism.gltf")));
    let mut scene = Scene::build(desc.unwrap());
    let mut away = scene.cameras[0].clone();
    away.1.rotation *= glam::Quat::from_rotation_y(std::f32::consts::PI);
    scene.cameras.push(away);
    let settings = Settings { width: 48, height: 48, ..Settings::default() };
    let state = ViewerState::new(scene, None, settings, true, Display::default(), None, Some(1)).unwrap();
    let subjects = state.camera_subjects();
    assert_eq!(subjects.len(), 2);
    assert!(subjects[0].starts_with("flint "), "the prism fills most of the frame: {}", subjects[0]);
    assert!(subjects[0].contains(", wall "), "the wall behind it: {}", subjects[0]);
    assert_eq!(subjects[1], "background only");
}

#[test]
fn an_edit_under_the_pinned_half_moves_the_divider_onto_the_selection() {
    let mut state = viewer();
    state.wait_for_update(None, Duration::from_secs(30)).expect("an image");
    let red = state.pick(glam::Vec2::new(0.05, 0.5)).unwrap();
    state.selected = Some(red);
    let _ = state.pin_image();
    let split = state.compare.view.split;
    assert!(split < 0.25, "the divider at {split} leaves the red wall on the left wall in the pinned half");
    // Another selection, edited: the divider follows it, until the user moves it.
    let green = state.pick(glam::Vec2::new(0.95, 0.5)).unwrap();
    state.selected = Some(green);
    state.edit(|materials, _| materials[green as usize].base_color = glam::Vec3::new(0.1, 0.2, 0.9));
    assert!(state.compare.view.split > 0.75, "{}", state.compare.view.split);
    state.compare.view.split = 0.4;
    state.compare.divider_moved = true;
    state.edit(|materials, _| materials[green as usize].base_color = glam::Vec3::new(0.9, 0.2, 0.1));
    assert_eq!(state.compare.view.split, 0.4, "the user's divider stays");
}

#[test]
fn a_malformed_dropped_file_reports_its_error_and_the_old_scene_keeps_rendering() {
    let mut state = viewer();
    let first = state.wait_for_update(None, Duration::from_secs(30)).expect("renders");
    let generation = state.generation();
    let dir = common::scratch("viewer-bad");
    let bad = dir.join("broken.glb");
    std::fs::write(&bad, b"glTF\x02\x00\x00\x00not really").unwrap();
    state.open(bad.clone());
    assert!(state.loading_status().is_some());
    wait_for_load(&mut state);
    let error = state.error.clone().expect("the error is shown");
    assert!(error.contains("broken.glb") && !error.contains('\n'), "{error}");
    assert_eq!(state.scene.name, "cornell-box");
    assert!(!state.sync(), "nothing to restart");
    assert_eq!(state.generation(), generation);
    let later = state.wait_for_update(Some(&first), Duration::from_secs(30)).expect("still rendering");
    assert!(later.spp > first.spp);
}

#[test]
fn a_good_file_replaces_the_scene() {
    let mut state = viewer();
    state.open(common::asset("Box/glTF-Binary/Box.glb"));
    wait_for_load(&mut state);
    assert!(state.error.is_none());
    assert_eq!(state.scene.name, "Box");
    assert!(state.sync(), "the new scene restarts accumulation");
}

#[test]
fn every_change_bumps_the_generation_and_edits_keep_the_bvh() {
    let mut state = viewer();
    let g0 = state.generation();
    state.settings.light_sampling = LightSampling::Explicit;
    assert!(state.sync());
    let g1 = state.generation();
    assert!(g1 > g0);
    state.camera.orbit(glam::Vec2::new(10.0, 0.0), 48.0);
    assert!(state.sync() && state.generation() > g1);
    let geometry = Arc::clone(&state.scene.geometry);
    state.edit(|materials, _| materials[0].base_color = glam::Vec3::new(0.2, 0.4, 0.6));
    assert!(state.edited() && Arc::ptr_eq(&geometry, &state.scene.geometry), "no BVH rebuild");
    assert!(state.sync());
    state.reset_edits();
    assert!(!state.edited());
    state.edit(|_, _| {});
    state.sync();
    assert!(!state.sync(), "an edit that changes nothing does not restart");
    let done = state.wait_for_update(None, Duration::from_secs(30)).unwrap();
    assert_eq!(done.generation, state.generation(), "only the current job's image is handed out");
}

#[test]
fn editing_a_medium_switches_the_volumetric_kernel_without_rebuilding_the_bvh() {
    let desc =
        lucent::loader::gltf::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scenes/cornell-fog.gltf")));
    let scene = Scene::build(desc.unwrap());
    let fog = scene.materials.iter().position(|m| m.name == "fog").unwrap();
    assert!(scene.features.media && scene.materials[fog].volume.is_some_and(|v| v.g == 0.5));
    let settings = Settings { width: 16, height: 16, ..Settings::default() };
    let mut state = ViewerState::new(scene, None, settings, true, Display::default(), None, Some(1)).unwrap();
    state.sync();
    let geometry = Arc::clone(&state.scene.geometry);
    state.edit(|materials, _| materials[fog].volume.as_mut().unwrap().albedo = glam::Vec3::ZERO);
    assert!(!state.scene.features.media, "a volume that no longer scatters needs no volumetric kernel");
    assert!(Arc::ptr_eq(&geometry, &state.scene.geometry) && state.sync(), "restarted, BVH kept");
    state.edit(|materials, _| materials[fog].volume.as_mut().unwrap().albedo = glam::Vec3::splat(0.9));
    assert!(state.scene.features.media && state.sync());
}

#[test]
fn editing_dispersion_switches_the_spectral_kernel_without_rebuilding_the_bvh() {
    let desc = lucent::loader::gltf::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scenes/prism.gltf")));
    let scene = Scene::build(desc.unwrap());
    let flint = scene.materials.iter().position(|m| m.name == "flint").unwrap();
    let settings = Settings { width: 16, height: 16, ..Settings::default() };
    assert!(lucent::integrator::is_spectral(&scene, &settings));
    let mut state = ViewerState::new(scene, None, settings, true, Display::default(), None, Some(1)).unwrap();
    state.sync();
    let geometry = Arc::clone(&state.scene.geometry);
    state.edit(|materials, _| materials[flint].dispersion = 0.0);
    assert!(!lucent::integrator::is_spectral(&state.scene, &state.settings), "no dispersion: the RGB kernel");
    assert!(Arc::ptr_eq(&geometry, &state.scene.geometry) && state.sync(), "restarted, BVH kept");
    state.edit(|materials, _| materials[flint].dispersion = 0.5);
    assert!(lucent::integrator::is_spectral(&state.scene, &state.settings) && state.sync());
}

#[test]
fn picking_finds_the_material_under_the_cursor_and_preview_lowers_the_resolution() {
    let mut state = viewer();
    let name = |m: Option<u32>| m.map(|i| state.scene.materials[i as usize].name.clone());
    assert_eq!(name(state.pick(glam::Vec2::new(0.5, 0.14))).as_deref(), Some("light"));
    assert_eq!(name(state.pick(glam::Vec2::new(0.05, 0.5))).as_deref(), Some("red"));
    assert_eq!(name(state.pick(glam::Vec2::new(0.95, 0.5))).as_deref(), Some("green"));
    state.moving = true;
    let s = state.effective_settings();
    assert!(s.width < 48 && s.height < 48 && s.target_spp.is_none());
}

#[test]
fn after_a_camera_move_the_preview_sharpens_one_level_per_image() {
    let mut state = viewer();
    state.moving = true;
    state.camera.orbit(glam::Vec2::new(5.0, 0.0), 48.0);
    assert!(state.sync());
    state.moving = false;
    let mut widths = vec![state.effective_settings().width];
    for _ in 0..50 {
        let snap = state.wait_for_update(None, Duration::from_secs(10)).expect("an image within 10 s");
        assert_eq!(snap.width, *widths.last().unwrap(), "the image is of the level being rendered");
        state.snapshot();
        state.sync();
        let width = state.effective_settings().width;
        if width == 48 {
            widths.push(width);
            break;
        }
        if width != *widths.last().unwrap() {
            widths.push(width);
        }
    }
    assert_eq!(widths, [6, 12, 24, 48], "1/8, 1/4, 1/2, then full resolution");
}

#[test]
fn screenshots_go_beside_the_scene_or_to_the_pictures_folder() {
    use lucent::viewer::state::default_screenshot_dir;
    let dir = common::scratch("viewer-shots");
    assert_eq!(default_screenshot_dir(Some(&dir.join("scene.gltf"))), *dir, "a writable scene folder");
    let elsewhere = default_screenshot_dir(Some(&dir.join("missing/scene.gltf")));
    assert!(elsewhere.ends_with("Lucent") || elsewhere == Path::new("."), "{}", elsewhere.display());
    assert_eq!(default_screenshot_dir(None), elsewhere, "the built-in scene has no folder");
    let mut state = viewer();
    state.screenshot_dir = dir.join("new/folder").to_string_lossy().into_owned();
    let _ = state.wait_for_update(None, Duration::from_secs(10)).expect("an image");
    let png = state.screenshot().expect("saved");
    assert!(png.starts_with(dir.join("new/folder")) && png.exists() && png.with_extension("exr").exists());
}

#[test]
fn views_save_and_load() {
    let mut state = viewer();
    let dir = common::scratch("viewer-view");
    state.view_path = dir.join("v.toml").to_string_lossy().into_owned();
    state.camera.dolly(2.0);
    state.settings.max_depth = 11;
    state.save_view().unwrap();
    let saved = state.camera;
    let mut other = viewer();
    other.view_path = state.view_path.clone();
    other.load_view().unwrap();
    assert!((other.camera.position() - saved.position()).length() < 1e-4);
    assert_eq!(other.settings.max_depth, 11);
}

/// A tiny equirectangular map written as EXR (blue sky over brown ground).
fn write_map(path: &Path) {
    let data = (0..8).flat_map(|i| if i < 4 { [0.2, 0.4, 1.0] } else { [0.3, 0.2, 0.1] }).collect();
    image::Rgb32FImage::from_raw(2, 4, data).unwrap().save(path).unwrap();
}

#[test]
fn the_environment_picker_offers_the_built_in_map_the_start_map_and_a_folders_maps() {
    // Started without a map: the built-in sky comes first, then the maps of the current folder.
    let mut state = viewer();
    assert_eq!(state.environment_maps.first().map(PathBuf::as_path), Some(Path::new(BUILT_IN)));
    assert_eq!(state.environment_dir(), ".");
    let dir = common::scratch("viewer-maps");
    for file in ["b.exr", "a.hdr", "C.EXR", "notes.txt", "sky.png"] {
        std::fs::write(dir.join(file), b"").unwrap();
    }
    state.set_environment_dir(dir.to_string_lossy().into_owned());
    let files = [dir.join("C.EXR"), dir.join("a.hdr"), dir.join("b.exr")];
    assert_eq!(state.environment_maps, [vec![PathBuf::from(BUILT_IN)], files.to_vec()].concat(), "rescanned");
    // Started with a map: it is offered, once, and its folder is the one scanned.
    let start = common::scratch("viewer-start");
    let sky = start.join("sky.exr");
    write_map(&sky);
    let settings = EnvSettings { map: Some(sky.clone()), ..EnvSettings::default() };
    let scene = Scene::build(builtin::cornell_box()).with_environment(Some(Environment::load(settings).unwrap()));
    let settings = Settings { width: 48, height: 48, ..Settings::default() };
    let mut state = ViewerState::new(scene, None, settings, true, Display::default(), None, Some(1)).unwrap();
    assert_eq!(state.environment_dir(), start.to_string_lossy());
    assert_eq!(state.environment_maps, [PathBuf::from(BUILT_IN), sky.clone()]);
    state.set_environment_dir(dir.to_string_lossy().into_owned());
    assert_eq!(state.environment_maps, [vec![PathBuf::from(BUILT_IN), sky], files.to_vec()].concat());
}

#[test]
fn the_built_in_map_lights_the_scene_and_is_kept_while_tuning() {
    let mut state = viewer();
    let geometry = Arc::clone(&state.scene.geometry);
    let mut env = state.environment.clone();
    env.map = Some(state.environment_maps[0].clone());
    state.set_environment(env.clone()).unwrap();
    assert!(state.scene.features.environment && state.sync(), "a map lights the scene and restarts");
    let map = Arc::clone(state.scene.environment.as_ref().unwrap().map().unwrap());
    env.rotation = 30.0;
    env.intensity = 0.5;
    state.set_environment(env.clone()).unwrap();
    let kept = state.scene.environment.as_ref().unwrap().map().unwrap();
    assert!(Arc::ptr_eq(&map, kept) && Arc::ptr_eq(&geometry, &state.scene.geometry), "nothing is reloaded");
    assert!(state.sync());
    let bad = EnvSettings { map: Some("/no/such/sky.exr".into()), ..env.clone() };
    let err = state.set_environment(bad).unwrap_err();
    assert!(err.contains("sky.exr") && !err.contains('\n'), "{err}");
    assert_eq!(state.environment, env, "the old environment stays");
    env.intensity = 0.0;
    state.set_environment(env).unwrap();
    assert!(!state.scene.features.environment, "a black environment costs nothing");
}

#[test]
fn the_denoise_toggle_shows_a_denoised_image_and_leaves_the_accumulation_alone() {
    if !common::oidn_installed("the_denoise_toggle_shows_a_denoised_image_and_leaves_the_accumulation_alone") {
        return;
    }
    let mut state = viewer();
    state.denoiser.enabled = true;
    let start = Instant::now();
    let (snap, image) = loop {
        assert!(start.elapsed() < Duration::from_secs(60), "no denoised image");
        state.poll_denoiser();
        if let Some(snap) = state.snapshot()
            && let Some(d) = state.denoiser.shown(&snap)
        {
            break (Arc::clone(&d.source), d.image.clone());
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    assert!(state.denoiser.status().starts_with(&format!("denoised at {} spp in ", snap.spp)));
    assert!(snap.aovs.is_some() && image != snap.mean, "denoised from the snapshot's image and AOVs");
    let later = state.wait_for_update(Some(&snap), Duration::from_secs(30)).expect("still rendering");
    assert!(later.spp > snap.spp && later.generation == snap.generation, "the accumulation went on, unrestarted");
    let rgba = state.display_rgba(&snap);
    let shown = lucent::film::tonemap::Display::default().to_srgb8(image[0]);
    assert_eq!(rgba[0][..3], shown, "the window shows the denoised image");
}

#[test]
fn the_target_error_mode_stops_and_the_views_show_error_and_samples() {
    // The noise threshold set (as the target error mode does): the render ends by itself
    // once every pixel has stopped, and the samples view spans the scale from the fewest
    // samples to the most.
    let mut state = viewer();
    state.settings.noise_threshold = Some(0.1);
    assert!(state.sync());
    let start = Instant::now();
    let mut snap = None;
    while snap.as_ref().is_none_or(|s: &Arc<lucent::render::Snapshot>| !s.done) {
        assert!(start.elapsed() < Duration::from_secs(60), "the threshold never stopped every pixel");
        snap = state.wait_for_update(snap.as_ref(), Duration::from_secs(1)).or(snap);
    }
    let snap = snap.unwrap();
    assert_eq!(snap.active, 0);
    let range = false_colour::spp_range(&snap.pixel_spp, snap.spp);
    assert!(range.0 < range.1, "every pixel took {range:?} samples");
    state.view = ImageView::Spp;
    let rgba = state.display_rgba(&snap);
    assert!(rgba.contains(&false_colour::spp_scale(0.0)) && rgba.contains(&false_colour::spp_scale(1.0)));
    state.view = ImageView::Error;
    let rgba = state.display_rgba(&snap);
    let i = (0..rgba.len()).find(|&i| snap.pixel_relative_error(i).is_some()).unwrap();
    assert_eq!(rgba[i], false_colour::error_colour(snap.pixel_relative_error(i).unwrap() as f32));
}

fn xvfb_run() -> Option<PathBuf> {
    std::env::var_os("PATH")?.to_str()?.split(':').map(|d| Path::new(d).join("xvfb-run")).find(|p| p.exists())
}

/// For a test in a real window: xvfb-run, a temporary folder and a private runtime folder
/// in it; None (the test is skipped, saying so) without xvfb-run, unless LUCENT_REQUIRE_XVFB.
fn under_xvfb(name: &str) -> Option<(PathBuf, common::Scratch, PathBuf)> {
    let Some(xvfb) = xvfb_run() else {
        assert!(
            std::env::var_os("LUCENT_REQUIRE_XVFB").is_none(),
            "LUCENT_REQUIRE_XVFB is set but xvfb-run is missing: the viewer test must run"
        );
        eprintln!("skipping the {name} viewer test: xvfb-run is not installed");
        return None;
    };
    let dir = common::scratch(&format!("viewer-{name}"));
    let runtime = dir.join("xdg");
    std::fs::create_dir_all(&runtime).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&runtime, std::fs::Permissions::from_mode(0o700)).unwrap();
    }
    Some((xvfb, dir, runtime))
}

#[test]
fn the_real_window_saves_the_same_image_as_the_headless_renderer() {
    window_and_headless_agree("e2e", &[]);
}

#[test]
fn bidirectional_path_tracing_runs_live_in_the_window_as_it_renders_headless() {
    // Its light-tracing contributions land on any pixel of the window's film.
    window_and_headless_agree("e2e-bdpt", &["--integrator", "bdpt"]);
}

#[test]
fn vertex_connection_and_merging_runs_live_in_the_window_as_it_renders_headless() {
    // Each of its passes traces an iteration's light subpaths before its camera paths.
    window_and_headless_agree("e2e-vcm", &["--integrator", "vcm"]);
}

/// The viewer under Xvfb, with `extra` settings, saves a screenshot whose EXR is the
/// headless render's, bit for bit.
fn window_and_headless_agree(name: &str, extra: &[&str]) {
    let Some((xvfb, dir, runtime)) = under_xvfb(name) else { return };
    let shot = dir.join("shot.png");
    let args = ["--spp", "8", "--width", "64", "--height", "48", "--seed", "3"];
    let out = Command::new(xvfb)
        .args(["-a", "-s", "-screen 0 1280x800x24", env!("CARGO_BIN_EXE_lucent"), "view"])
        .args(args)
        .args(extra)
        .arg("--screenshot")
        .arg(&shot)
        .env_remove("WAYLAND_DISPLAY")
        .env("XDG_RUNTIME_DIR", &runtime)
        .output()
        .unwrap();
    let log = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "viewer failed: {log}");
    assert!(log.contains("presenting with"), "a real surface was used: {log}");
    let reference = dir.join("ref.exr");
    let status = Command::new(env!("CARGO_BIN_EXE_lucent"))
        .arg("render")
        .args(args)
        .args(extra)
        .arg("--out")
        .arg(&reference)
        .status()
        .unwrap();
    assert!(status.success());
    let a = image::open(shot.with_extension("exr")).unwrap().into_rgb32f();
    let b = image::open(&reference).unwrap().into_rgb32f();
    assert_eq!(a.dimensions(), (64, 48));
    assert!(a.as_raw() == b.as_raw(), "the viewer's image differs from the headless render");
    let png = image::open(&shot).unwrap();
    assert_eq!((png.width(), png.height()), (64, 48));
}

#[test]
fn the_real_window_saves_its_edited_scene_as_gltf_that_renders_the_same_image() {
    let Some((xvfb, dir, runtime)) = under_xvfb("e2e-gltf") else { return };
    let view = dir.join("tuned.toml");
    let edits =
        "[[materials]]\nindex = 0\nname = \"white\"\nbase_color = [0.2, 0.5, 0.8]\nroughness = 0.3\nmetallic = 0.5\n";
    std::fs::write(&view, edits).unwrap();
    let (shot, gltf) = (dir.join("shot.png"), dir.join("tuned.gltf"));
    let args = ["--spp", "4", "--width", "64", "--height", "48", "--seed", "5"];
    let out = Command::new(xvfb)
        .args(["-a", "-s", "-screen 0 1280x800x24", env!("CARGO_BIN_EXE_lucent"), "view", "--view"])
        .arg(&view)
        .args(args)
        .arg("--screenshot")
        .arg(&shot)
        .arg("--save-gltf")
        .arg(&gltf)
        .env_remove("WAYLAND_DISPLAY")
        .env("XDG_RUNTIME_DIR", &runtime)
        .output()
        .unwrap();
    let log = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "viewer failed: {log}");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&gltf).expect("the window wrote it")).unwrap();
    let pbr = &json["materials"][0]["pbrMetallicRoughness"];
    assert_eq!((pbr["roughnessFactor"].as_f64(), pbr["metallicFactor"].as_f64()), (Some(0.3), Some(0.5)), "{pbr}");
    let reference = dir.join("ref.exr");
    let status = Command::new(env!("CARGO_BIN_EXE_lucent"))
        .arg("render")
        .arg(&gltf)
        .args(args)
        .arg("--out")
        .arg(&reference)
        .status()
        .unwrap();
    assert!(status.success());
    let a = image::open(shot.with_extension("exr")).unwrap().into_rgb32f();
    let b = image::open(&reference).unwrap().into_rgb32f();
    assert!(a.as_raw() == b.as_raw(), "the saved scene renders what the window showed");
    let plain = dir.join("plain.exr");
    let status = Command::new(env!("CARGO_BIN_EXE_lucent")).arg("render").args(args).arg("--out").arg(&plain).status();
    assert!(status.unwrap().success());
    let c = image::open(&plain).unwrap().into_rgb32f();
    assert!(a.as_raw() != c.as_raw(), "the edits changed the image");
}

#[test]
fn the_real_window_denoises_its_last_snapshot_as_the_headless_renderer_does() {
    let Some((xvfb, dir, runtime)) = under_xvfb("denoise") else { return };
    if !common::oidn_installed("the_real_window_denoises_its_last_snapshot_as_the_headless_renderer_does") {
        return;
    }
    let shot = dir.join("shot.png");
    let args = ["--spp", "8", "--width", "64", "--height", "48", "--seed", "3"];
    let out = Command::new(xvfb)
        .args(["-a", "-s", "-screen 0 1280x800x24", env!("CARGO_BIN_EXE_lucent"), "view", "--denoise"])
        .args(args)
        .arg("--screenshot")
        .arg(&shot)
        .env_remove("WAYLAND_DISPLAY")
        .env("XDG_RUNTIME_DIR", &runtime)
        .output()
        .unwrap();
    let log = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success() && log.contains("presenting with"), "viewer failed: {log}");
    let reference = dir.join("ref.exr");
    let render = Command::new(env!("CARGO_BIN_EXE_lucent"))
        .args(["render", "--denoise"])
        .args(args)
        .arg("--out")
        .arg(&reference)
        .output()
        .unwrap();
    assert!(render.status.success(), "{}", String::from_utf8_lossy(&render.stderr));
    let read = |path: &Path| image::open(path).unwrap().into_rgb32f();
    let noisy = read(&shot.with_extension("exr"));
    assert!(noisy.as_raw() == read(&dir.join("ref.noisy.exr")).as_raw(), "the viewer's noisy image differs");
    let denoised = read(&shot.with_extension("denoised.exr"));
    assert!(denoised.as_raw() != noisy.as_raw(), "the denoised image is the noisy one");
    // The same input to the same filter on the same machine: Open Image Denoise's CPU device
    // gives the same bits.
    assert!(denoised.as_raw() == read(&reference).as_raw(), "the viewer denoised differently");
    let png = image::open(&shot).unwrap().into_rgb8();
    let display = lucent::film::tonemap::Display::default();
    let expected: Vec<u8> = denoised.pixels().flat_map(|p| display.to_srgb8(glam::Vec3::from(p.0))).collect();
    assert!(png.as_raw() == &expected, "the PNG is the denoised image");
}

#[test]
fn the_window_on_a_folder_of_pieces_shows_their_merge_as_they_arrive() {
    let Some((xvfb, dir, runtime)) = under_xvfb("pieces") else { return };
    let folder = dir.join("pieces");
    std::fs::create_dir_all(&folder).unwrap();
    let lucent = env!("CARGO_BIN_EXE_lucent");
    let render = |samples: &str, out: &Path| {
        let args = ["render", "--width", "64", "--height", "48", "--samples", samples, "--out"];
        assert!(Command::new(lucent).args(args).arg(out).status().unwrap().success());
    };
    render("0..4", &folder.join("a.part"));
    render("4..8", &dir.join("b.part"));
    let shot = dir.join("shot.png");
    let mut viewer = Command::new(xvfb)
        // A viewer that never sees its samples would wait forever: `timeout` ends it, failing the test.
        .args(["-a", "-s", "-screen 0 1280x800x24", "timeout", "120", lucent, "view"])
        .arg(&folder)
        .args(["--spp", "8", "--screenshot"])
        .arg(&shot)
        .env_remove("WAYLAND_DISPLAY")
        .env("XDG_RUNTIME_DIR", &runtime)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = std::io::BufReader::new(viewer.stderr.take().unwrap());
    let mut log = Vec::new();
    for line in std::io::BufRead::lines(stderr) {
        let line = line.unwrap();
        log.push(line.clone());
        if line.contains("1 piece merged, 4 spp so far") {
            // The first piece is on screen: the second arrives, renamed in whole as a farm's do.
            std::fs::rename(dir.join("b.part"), folder.join("b.part")).unwrap();
        }
    }
    let status = viewer.wait().unwrap();
    assert!(status.success(), "viewer failed: {log:?}");
    assert!(log.iter().any(|l| l.contains("2 pieces merged, 8 spp so far")), "{log:?}");
    let merged = dir.join("merged.png");
    let out = Command::new(lucent).arg("merge").arg(&folder).arg("--out").arg(&merged).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(std::fs::read(&shot).unwrap(), std::fs::read(&merged).unwrap(), "the window saved another image");
}

//! The viewer's look-dev tools, headless: the pixel inspector and its probes, before/after
//! composition and the pin's round trip through its cache file, the luminance histogram
//! and auto-exposure, and progress towards a target (a time target stops the render at an
//! image equal to the render to the spp it reached).

mod common;

use glam::{UVec2, Vec2, Vec3};
use lucent::film::tonemap::{Display, Tonemap};
use lucent::integrator::Settings;
use lucent::loader::builtin;
use lucent::render::Snapshot;
use lucent::scene::Scene;
use lucent::viewer::compare::{
    CompareMode, CompareView, Pin, PinInfo, PinStore, compose, difference_colour, sidecar, size_mismatch,
};
use lucent::viewer::histogram::{BINS, Histogram, PER_STOP, auto_exposure, clip_points};
use lucent::viewer::inspect::{Probes, pixel_at, pixel_values};
use lucent::viewer::progress::{Target, TargetKind, format_seconds, progress};
use lucent::viewer::state::ViewerState;
use std::time::{Duration, Instant};

fn viewer() -> ViewerState {
    let settings = Settings { width: 48, height: 48, ..Settings::default() };
    ViewerState::new(Scene::build(builtin::cornell_box()), None, settings, true, Display::default(), None, Some(1))
        .unwrap()
}

/// The first image of at least `spp` samples per pixel.
fn image_with(state: &ViewerState, spp: u32) -> std::sync::Arc<Snapshot> {
    let mut seen = None;
    loop {
        let snap = state.wait_for_update(seen.as_ref(), Duration::from_secs(30)).expect("renders");
        if snap.spp >= spp {
            return snap;
        }
        seen = Some(snap);
    }
}

/// A `width` x `height` snapshot whose pixel i has mean (i, 2i, 3i) / 100 and variance i / 1e4.
fn snapshot(width: u32, height: u32, spp: u32) -> Snapshot {
    let n = (width * height) as usize;
    Snapshot {
        generation: 1,
        width,
        height,
        mean: (0..n).map(|i| Vec3::new(1.0, 2.0, 3.0) * i as f32 / 100.0).collect(),
        variance: (0..n).map(|i| Vec3::splat(i as f32 / 1e4)).collect(),
        luminance_variance: Vec::new(),
        estimate: lucent::film::adaptive::ErrorEstimate::Samples,
        aovs: None,
        spp,
        pixel_spp: Vec::new(),
        active: n as u64,
        elapsed: Duration::from_secs(1),
        samples: 0,
        rays: 0,
        rejected: 0,
        done: false,
        film: None,
    }
}

#[test]
fn the_inspector_reads_the_pixel_under_the_cursor_and_probes_follow_the_image() {
    assert_eq!(pixel_at(Vec2::new(0.0, 0.0), 4, 3), Some(UVec2::new(0, 0)));
    assert_eq!(pixel_at(Vec2::new(0.6, 0.5), 4, 3), Some(UVec2::new(2, 1)));
    assert_eq!(pixel_at(Vec2::new(1.0, 1.0), 4, 3), Some(UVec2::new(3, 2)), "the far edge is the last pixel");
    assert_eq!(pixel_at(Vec2::new(1.01, 0.5), 4, 3), None);
    assert_eq!(pixel_at(Vec2::new(0.5, -0.01), 4, 3), None);
    let snap = snapshot(4, 3, 16);
    let v = pixel_values(&snap, UVec2::new(2, 1)).unwrap();
    let i = 6;
    assert_eq!(v.rgb, snap.mean[i]);
    assert_eq!(v.luminance, lucent::math::luminance(snap.mean[i]));
    assert_eq!(v.samples, 16);
    assert_eq!(v.relative_error, snap.pixel_relative_error(i));
    assert!(v.relative_error.is_some());
    assert_eq!(pixel_values(&snap, UVec2::new(4, 0)), None);
    assert_eq!(pixel_values(&snapshot(4, 3, 1), UVec2::new(2, 1)).unwrap().relative_error, None, "one sample");

    let mut probes = Probes::default();
    assert!(probes.add(Vec2::new(0.6, 0.5), 4, 3));
    assert!(!probes.add(Vec2::new(0.7, 0.6), 4, 3), "the same pixel is pinned once");
    assert!(probes.add(Vec2::new(0.1, 0.9), 4, 3));
    assert!(!probes.add(Vec2::new(1.5, 0.5), 4, 3), "outside the image");
    let values = probes.values(&snap);
    assert_eq!(values.iter().map(|v| v.unwrap().pixel).collect::<Vec<_>>(), [UVec2::new(2, 1), UVec2::new(0, 2)]);
    // At twice the resolution a probe stays inside the block its pixel became.
    let big = snapshot(8, 6, 4);
    let p = probes.values(&big)[0].unwrap().pixel;
    assert!((4..6).contains(&p.x) && (2..4).contains(&p.y), "{p}");
    probes.remove(0);
    assert_eq!(probes.values(&snap)[0].unwrap().pixel, UVec2::new(0, 2));
    probes.clear();
    assert!(probes.positions().is_empty());
}

#[test]
fn probes_show_the_live_renders_pixels() {
    let mut state = viewer();
    let snap = image_with(&state, 16);
    state.probes.add(Vec2::new(0.5, 0.9), snap.width, snap.height);
    state.probes.add(Vec2::new(0.05, 0.5), snap.width, snap.height);
    for v in state.probes.values(&snap) {
        let v = v.unwrap();
        let i = (v.pixel.y * snap.width + v.pixel.x) as usize;
        assert_eq!(v.rgb, snap.mean[i]);
        assert!(v.luminance > 0.0, "the floor and the red wall are lit");
    }
    assert!(state.probes.values(&snap)[1].unwrap().rgb.x > state.probes.values(&snap)[1].unwrap().rgb.y, "red wall");
}

fn images() -> (Vec<Vec3>, Vec<Vec3>) {
    let live = (0..16).map(|i| Vec3::new(0.1, 0.2, 0.05) * (i + 1) as f32).collect();
    let pinned = (0..16).map(|i| Vec3::new(0.3, 0.1, 0.2) * (16 - i) as f32 / 8.0).collect();
    (live, pinned)
}

#[test]
fn the_split_shows_the_pinned_image_left_of_the_divider_and_the_live_one_right_of_it() {
    let (live, pinned) = images();
    let display = Display { exposure: -1.5, tonemap: Tonemap::Aces };
    let tonemap = |c: Vec3| {
        let [r, g, b] = display.to_srgb8(c);
        [r, g, b, 255]
    };
    let view = CompareView { mode: CompareMode::Split, split: 0.25, stops: 1.0 };
    let rgba = compose(&live, &pinned, 8, &view, &display);
    assert_eq!(rgba.len(), 16);
    for (i, c) in rgba.iter().enumerate() {
        let expected = if i % 8 < 2 { tonemap(pinned[i]) } else { tonemap(live[i]) };
        assert_eq!(*c, expected, "pixel {i}");
    }
    assert_ne!(tonemap(live[0]), tonemap(pinned[0]), "the two images differ where the test looks");
    let all = |mode| compose(&live, &pinned, 8, &CompareView { mode, ..view }, &display);
    assert_eq!(all(CompareMode::Pinned), pinned.iter().map(|&c| tonemap(c)).collect::<Vec<_>>());
    assert_eq!(all(CompareMode::Live), live.iter().map(|&c| tonemap(c)).collect::<Vec<_>>());
    let edge = compose(&live, &pinned, 8, &CompareView { split: 1.0, ..view }, &display);
    assert_eq!(edge, all(CompareMode::Pinned), "the divider at the right edge shows only the pinned image");
}

#[test]
fn the_difference_view_is_black_where_nothing_changed_and_signed_in_stops() {
    let (live, _) = images();
    let display = Display::default();
    let view = CompareView { mode: CompareMode::Difference, split: 0.5, stops: 1.0 };
    assert!(compose(&live, &live, 8, &view, &display).iter().all(|c| *c == [0, 0, 0, 255]), "identical: zero");
    let darker: Vec<Vec3> = live.iter().map(|&c| 0.5 * c).collect();
    let brighter: Vec<Vec3> = live.iter().map(|&c| 2.0 * c).collect();
    // Live twice the pinned: one stop brighter, full orange at a range of one stop.
    assert!(compose(&live, &darker, 8, &view, &display).iter().all(|c| *c == difference_colour(1.0, 1.0)));
    assert!(compose(&live, &brighter, 8, &view, &display).iter().all(|c| *c == difference_colour(-1.0, 1.0)));
    let half = compose(&live, &darker, 8, &CompareView { stops: 2.0, ..view }, &display);
    assert!(half.iter().all(|c| *c == difference_colour(0.5, 1.0)), "one stop at a range of two is half colour");
    let [r, g, b, _] = difference_colour(1.0, 1.0);
    assert!(r > b && g > 0, "brighter is orange");
    let [r, _, b, _] = difference_colour(-1.0, 1.0);
    assert!(b > r, "darker is blue");
    assert_eq!(difference_colour(0.0, 1.0), [0, 0, 0, 255]);
    assert_eq!(difference_colour(f32::INFINITY, 1.0), difference_colour(1.0, 1.0), "lit against black");
}

fn pin(width: u32, height: u32) -> Pin {
    let pixels = (0..width * height).map(|i| Vec3::new(i as f32 * 0.37, 1e-6, 1e4 + i as f32)).collect();
    let info = PinInfo { scene: "cornell-box".into(), spp: 64, seconds: 2.5, label: "lights explicit".into() };
    Pin { width, height, pixels, info }
}

#[test]
fn a_pin_round_trips_through_its_cache_file_with_its_metadata() {
    let dir = common::scratch("tools-store");
    let store = PinStore { dir: dir.join("pins") };
    assert!(store.load(None).unwrap().is_none(), "nothing pinned yet");
    let original = pin(5, 3);
    let path = store.save(None, &original).unwrap();
    assert!(path.starts_with(&store.dir) && path.exists() && sidecar(&path).exists());
    let back = store.load(None).unwrap().expect("saved");
    assert!(back.pixels == original.pixels, "pixels bit for bit");
    assert_eq!((back.width, back.height, &back.info), (5, 3, &original.info), "and the metadata");
    // Scenes have pins of their own, named after the file.
    let scene = common::asset("Box/glTF-Binary/Box.glb");
    let own = store.path_for(Some(&scene));
    assert_ne!(own, path);
    assert!(own.file_name().unwrap().to_string_lossy().starts_with("Box-"));
    assert_eq!(own, store.path_for(Some(&scene.parent().unwrap().join("../glTF-Binary/Box.glb"))), "canonical");
    assert!(store.load(Some(&scene)).unwrap().is_none());
    // An image without a sidecar (or with a damaged one) is named by its file.
    std::fs::write(sidecar(&path), "spp = 'many'").unwrap();
    let read = Pin::read(&path).unwrap();
    assert_eq!((read.pixels, read.info.label.as_str()), (original.pixels, "built-in-cornell-box.exr"));
    let err = Pin::read(&dir.join("missing.exr")).unwrap_err();
    assert!(err.contains("missing.exr") && !err.contains('\n'), "{err}");
    store.forget(None).unwrap();
    assert!(!path.exists() && !sidecar(&path).exists());
    store.forget(None).unwrap();
}

#[test]
fn the_pin_survives_a_restart_of_accumulation_and_of_the_viewer() {
    let dir = common::scratch("tools-restart");
    let store = PinStore { dir: dir.to_path_buf() };
    let mut state = viewer();
    state.compare.store = Some(store.clone());
    state.load_pin();
    assert!(state.compare.pin().is_none());
    assert!(state.pin_image().is_err(), "nothing rendered yet");
    let snap = state.wait_for_update(None, Duration::from_secs(30)).unwrap();
    state.pin_image().unwrap();
    let pinned = state.compare.pin().unwrap().clone();
    assert_eq!(pinned.pixels.len(), (pinned.width * pinned.height) as usize);
    assert!(pinned.info.spp >= snap.spp && pinned.info.label == "default estimator");
    assert_eq!(state.compare.view.mode, CompareMode::Split, "pinning shows the split");
    assert_eq!(state.compare.file.as_deref(), Some(store.path_for(None).as_path()));
    // A setting changes: accumulation restarts, the pin stays and is composed with the new image.
    state.settings.max_depth = 2;
    assert!(state.sync());
    assert!(state.compare.pin() == Some(&pinned), "the pin stays");
    let live = state.wait_for_update(None, Duration::from_secs(30)).unwrap();
    let shown = state.display_rgba(&live);
    let display = state.display;
    let expected = compose(&live.mean, &pinned.pixels, live.width, &state.compare.view, &display);
    assert!(shown == expected, "the split of the pin and the new image");
    // The viewer restarts: the pin comes back from the store.
    drop(state);
    let mut again = viewer();
    again.compare.store = Some(store.clone());
    again.load_pin();
    let back = again.compare.pin().expect("the pin comes back");
    assert!(back.pixels == pinned.pixels, "pixels bit for bit");
    assert_eq!(back.info, pinned.info);
    again.unpin().unwrap();
    assert!(again.compare.pin().is_none() && store.load(None).unwrap().is_none());
}

#[test]
fn a_pin_of_another_size_is_not_compared_and_says_why() {
    let mut state = viewer();
    let snap = state.wait_for_update(None, Duration::from_secs(30)).unwrap();
    let dir = common::scratch("tools-size");
    let file = dir.join("other.exr");
    pin(7, 5).write(&file).unwrap();
    state.compare_with(&file).unwrap();
    assert_eq!(state.compare.pin().unwrap().info.label, "lights explicit", "read with its sidecar");
    let note = size_mismatch(state.compare.pin().unwrap(), snap.width, snap.height).unwrap();
    assert!(note.contains("7x5") && note.contains("48x48") && !note.contains('\n'), "{note}");
    assert!(state.compare.rgba(&snap.mean, snap.width, snap.height, &state.display).is_none());
    let plain: Vec<[u8; 4]> =
        snap.mean.iter().map(|&c| state.display.to_srgb8(c)).map(|[r, g, b]| [r, g, b, 255]).collect();
    assert_eq!(state.display_rgba(&snap), plain, "the live image alone");
    assert!(state.compare_with(&dir.join("none.exr")).is_err());
}

#[test]
fn the_histogram_counts_every_pixel_in_its_quarter_stop() {
    // Greys: luminance 1.1 (0.14 stops), 0.3 (-1.74 stops), black, and far past white.
    let pixels = [1.1, 0.3, 0.3, 0.0, 1e9].map(Vec3::splat);
    let h = Histogram::of(&pixels, 0.0);
    assert_eq!(h.counts.len(), BINS);
    assert_eq!(h.counts.iter().sum::<u32>(), pixels.len() as u32);
    let bin = |stops: f32| ((stops + 16.0) * PER_STOP as f32).floor() as usize;
    assert_eq!((bin(0.14), bin(-1.74)), (64, 57));
    assert_eq!((h.counts[64], h.counts[57], h.counts[0], h.counts[BINS - 1]), (1, 2, 1, 1));
    assert!(Histogram::start(64) <= 0.14 && 0.14 < Histogram::start(65));
    // Exposure shifts luminance by its stops: +1 EV moves each lit pixel 4 bins up.
    let up = Histogram::of(&pixels, 1.0);
    assert_eq!((up.counts[68], up.counts[61], up.counts[0], up.counts[BINS - 1]), (1, 2, 1, 1));
    let state = viewer();
    let snap = state.wait_for_update(None, Duration::from_secs(30)).unwrap();
    assert_eq!(Histogram::of(&snap.mean, 0.0).counts.iter().sum::<u32>(), snap.width * snap.height);
}

#[test]
fn clipping_points_are_where_a_grey_turns_black_and_white() {
    for tonemap in [Tonemap::Linear, Tonemap::Aces, Tonemap::PbrNeutral] {
        let display = Display { exposure: 0.0, tonemap };
        let code = |stops: f32| display.to_srgb8(Vec3::splat(stops.exp2()))[0];
        let (black, white) = clip_points(tonemap);
        let (black, white) = (black.unwrap(), white.unwrap());
        assert!(code(white + 0.01) == 255 && code(white - 0.01) < 255, "{tonemap:?} white at {white}");
        assert!(code(black + 0.01) > 0 && code(black - 0.01) == 0, "{tonemap:?} black at {black}");
    }
    let linear = clip_points(Tonemap::Linear).1.unwrap();
    assert!(linear.abs() < 0.01, "the linear curve clips at 1: {linear}");
    assert!(clip_points(Tonemap::Aces).1.unwrap() > 1.0, "ACES keeps more than a stop past 1");
}

#[test]
fn auto_exposure_shows_the_chosen_percentile_as_the_chosen_grey() {
    // Lit greys of luminance 1 to 100, and black pixels it ignores.
    let mut pixels: Vec<Vec3> = (1..=100).map(|i| Vec3::splat(i as f32)).collect();
    pixels.extend([Vec3::ZERO; 300]);
    let exposed = |ev: f32, l: f32| l * ev.exp2();
    let median = auto_exposure(&pixels, 50.0, 0.18).unwrap();
    assert!((exposed(median, lucent::math::luminance(Vec3::splat(50.0))) - 0.18).abs() < 1e-5, "{median}");
    let high = auto_exposure(&pixels, 99.0, 0.9).unwrap();
    assert!((exposed(high, lucent::math::luminance(Vec3::splat(99.0))) - 0.9).abs() < 1e-5, "{high}");
    assert_eq!(auto_exposure(&[Vec3::ZERO; 4], 50.0, 0.18), None);
    assert_eq!(auto_exposure(&[Vec3::splat(1e-30)], 50.0, 0.18), Some(20.0), "within the display's range");
    // It changes the display only: no restart, the accumulated image untouched.
    let mut state = viewer();
    let snap = state.wait_for_update(None, Duration::from_secs(30)).unwrap();
    state.sync();
    let before = snap.mean.clone();
    state.auto_exposure.continuous = true;
    state.auto_exposure.grey = 0.5;
    state.auto_expose(&snap);
    let ev = state.display.exposure;
    assert_eq!(Some(ev), auto_exposure(&snap.mean, 50.0, 0.5));
    assert!(!state.sync(), "exposure is not a render setting");
    assert_eq!(snap.mean, before);
    state.display.exposure = ev + 0.01;
    state.auto_expose(&snap);
    assert_eq!(state.display.exposure, ev + 0.01, "noise-sized changes are left alone");
}

#[test]
fn progress_and_time_left_for_each_kind_of_target() {
    let spp = Target { kind: TargetKind::Spp, ..Target::default() };
    let p = progress(&spp, Some(100), 25, 10.0, None).unwrap();
    assert_eq!((p.fraction, p.remaining, p.reached), (0.25, Some(30.0), false));
    assert!(progress(&spp, Some(100), 100, 40.0, None).unwrap().reached);
    assert_eq!(progress(&spp, None, 25, 10.0, None), None, "no target spp: no bar");
    assert_eq!(progress(&spp, Some(100), 0, 0.0, None).unwrap().remaining, None, "no rate yet");
    let time = Target { kind: TargetKind::Time, seconds: 60.0, ..Target::default() };
    let p = progress(&time, None, 25, 15.0, None).unwrap();
    assert_eq!((p.fraction, p.remaining, p.reached), (0.25, Some(45.0), false));
    assert!(progress(&time, None, 25, 61.0, None).is_some_and(|p| p.reached && p.remaining == Some(0.0)));
    // Error ~ time^-1/2: halving 4% to 2% after 10 s takes 40 s in all.
    let error = Target { kind: TargetKind::Error, error: 0.02, ..Target::default() };
    let p = progress(&error, None, 25, 10.0, Some(0.04)).unwrap();
    assert_eq!((p.fraction, p.remaining, p.reached), (0.25, Some(30.0), false));
    assert!(progress(&error, None, 25, 10.0, Some(0.019)).unwrap().reached);
    assert_eq!(progress(&error, None, 1, 0.1, None).unwrap().remaining, None, "no estimate yet");
    assert_eq!(format_seconds(42.4), "42 s");
    assert_eq!(format_seconds(200.0), "3 min 20 s");
    assert_eq!(format_seconds(7500.0), "2 h 5 min");
}

#[test]
fn a_time_target_stops_the_render_at_the_image_of_the_spp_it_reached() {
    let mut state = viewer();
    state.target = Target { kind: TargetKind::Time, seconds: 0.3, ..Target::default() };
    let start = Instant::now();
    while !state.progress().is_some_and(|p| p.reached) {
        assert!(start.elapsed() < Duration::from_secs(60), "the target is never reached");
        state.sync();
        std::thread::sleep(Duration::from_millis(10));
    }
    state.sync();
    // A pass in flight completes; then nothing more is added.
    std::thread::sleep(Duration::from_millis(1000));
    let stopped = state.snapshot().unwrap();
    std::thread::sleep(Duration::from_millis(500));
    state.sync();
    let later = state.snapshot().unwrap();
    assert_eq!(later.spp, stopped.spp, "stopped at the time target");
    assert!(stopped.elapsed >= Duration::from_secs_f64(0.3));
    // What it shows is the render to that spp, bit for bit.
    let settings = Settings { target_spp: Some(stopped.spp), ..state.effective_settings() };
    let reference = common::render(&state.scene, state.camera.camera(), settings, Some(2));
    assert!(stopped.mean == reference.mean, "the image at a time target is the image at its spp");
    // A later target resumes the same job.
    state.target.seconds = 1e6;
    assert!(!state.sync(), "no restart");
    let resumed = state.wait_for_update(Some(&later), Duration::from_secs(30)).unwrap();
    assert!(resumed.spp > later.spp);
}

#[test]
fn an_unreadable_compare_image_is_refused_in_one_line_before_a_window_opens() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lucent"))
        .args(["view", "--width", "16", "--height", "16", "--compare", "/no/such/pinned.exr"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    let line = err.lines().find(|l| l.starts_with("error:")).unwrap_or_default();
    assert!(line.contains("/no/such/pinned.exr") && !err.contains("presenting with"), "{err}");
}

//! The render session: a new job bumps the generation, and no sample of the old job
//! reaches the new image (it equals a fresh render of the new job, bit for bit); a job
//! whose film would not fit in the memory limit is refused before it is allocated; a job
//! with a deadline ends there; a session asked for images at the end only builds them for
//! its last snapshot alone.

mod common;

use lucent::integrator::Settings;
use lucent::loader::{Limits, builtin};
use lucent::render::{Job, RenderSession, SessionError, Snapshot};
use lucent::scene::Scene;
use std::sync::Arc;
use std::time::{Duration, Instant};

#[test]
fn a_new_job_restarts_accumulation_without_stale_samples() {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let first = Settings { width: 32, height: 32, seed: 1, ..Settings::default() };
    let session = RenderSession::new(
        Job { scene: Arc::clone(&scene), camera, settings: first, window: None, aovs: false },
        Some(2),
    )
    .unwrap();
    let g1 = session.generation();
    let before = session.wait_for_update(None, Duration::from_secs(30)).expect("a first pass");
    assert_eq!(before.generation, g1);

    let mut moved = camera;
    moved.position.x += 0.05;
    let second = Settings { seed: 2, max_depth: 3, target_spp: Some(16), ..first };
    let g2 = session
        .set_job(Job { scene: Arc::clone(&scene), camera: moved, settings: second, window: None, aovs: false })
        .unwrap();
    assert!(g2 > g1, "a change bumps the generation");
    assert!(session.snapshot().is_none_or(|s| s.generation == g2), "no stale snapshot is handed out");
    let after = session.wait_until_done();
    assert_eq!((after.generation, after.spp), (g2, 16));

    let fresh = common::render(&scene, moved, second, Some(1));
    assert!(after.mean == fresh.mean, "the restarted image holds only samples of the new job");
}

#[test]
fn a_job_without_a_sample_target_ends_at_its_deadline() {
    // A deadline already passed: no further pass fits, so the job is done after the pass
    // in flight; without the deadline it would run until dropped.
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let settings = Settings { width: 16, height: 16, target_spp: None, ..Settings::default() };
    let job = Job { scene: Arc::clone(&scene), camera: scene.default_camera(1.0), settings, window: None, aovs: false };
    let session = RenderSession::new(job, Some(2)).unwrap();
    session.stop_at(Instant::now());
    let mut latest = None;
    let waited = Instant::now();
    while latest.as_ref().is_none_or(|s: &Arc<Snapshot>| !s.done) {
        assert!(waited.elapsed() < Duration::from_secs(60), "the job did not end at its deadline");
        latest = session.wait_for_update(latest.as_ref(), Duration::from_secs(1)).or(latest);
    }
}

#[test]
fn with_images_at_the_end_only_the_last_snapshot_has_them_and_they_are_the_same() {
    // Snapshots before the last carry counts and no images; the last one's images are
    // those of a session that built images after every pass, bit for bit, AOVs and the
    // noise threshold's per-pixel counts included.
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let settings = Settings {
        width: 64,
        height: 64,
        target_spp: Some(16),
        noise_threshold: Some(0.01),
        min_spp: 4,
        ..Settings::default()
    };
    let job = |settings| Job {
        scene: Arc::clone(&scene),
        camera: scene.default_camera(1.0),
        settings,
        window: None,
        aovs: true,
    };

    // Without a sample target or a noise threshold the passes go on until the session is
    // dropped, and every snapshot after the first few is one the flag applies to.
    let endless =
        RenderSession::new(job(Settings { target_spp: None, noise_threshold: None, ..settings }), Some(2)).unwrap();
    endless.images_at_end_only();
    let (mut latest, waited) = (None, Instant::now());
    loop {
        assert!(waited.elapsed() < Duration::from_secs(60), "no snapshot without images");
        let Some(s) = endless.wait_for_update(latest.as_ref(), Duration::from_secs(1)) else { continue };
        assert!(!s.done);
        if s.mean.is_empty() {
            assert!(s.variance.is_empty() && s.pixel_spp.is_empty() && s.aovs.is_none());
            assert!(s.spp > 0 && s.samples > 0 && (0.0..=1.0).contains(&s.active_share()));
            break;
        }
        latest = Some(s);
    }
    drop(endless);

    let session = RenderSession::new(job(settings), Some(2)).unwrap();
    session.images_at_end_only();
    let last = session.wait_until_done();
    let full = RenderSession::new(job(settings), Some(2)).unwrap().wait_until_done();
    assert_eq!(last.mean.len(), 64 * 64);
    assert!(last.mean == full.mean && last.variance == full.variance && last.pixel_spp == full.pixel_spp);
    let (a, b) = (last.aovs.as_ref().unwrap(), full.aovs.as_ref().unwrap());
    assert!(a.albedo == b.albedo && a.normal == b.normal);
}

#[test]
fn invalid_settings_are_refused() {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    for bad in [
        Settings { width: 0, ..Settings::default() },
        Settings { strata: 0, ..Settings::default() },
        Settings { firefly_clamp: Some(f32::NAN), ..Settings::default() },
        Settings { target_spp: Some(0), ..Settings::default() },
    ] {
        assert!(
            RenderSession::new(
                Job { scene: Arc::clone(&scene), camera, settings: bad, window: None, aovs: false },
                None
            )
            .is_err()
        );
    }
}

#[test]
fn a_film_over_the_memory_limit_is_refused_and_the_session_keeps_its_job() {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let small = Settings { width: 64, height: 64, target_spp: Some(2), ..Settings::default() };
    let limits = Limits { memory: 1 << 30 };
    let session = RenderSession::with_limits(
        Job { scene: Arc::clone(&scene), camera, settings: small, window: None, aovs: false },
        Some(1),
        limits,
    )
    .unwrap();
    let big = Settings { width: 4096, height: 4096, ..small };
    let err = session
        .set_job(Job { scene: Arc::clone(&scene), camera, settings: big, window: None, aovs: false })
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "image too large: 4096x4096 needs about 2.2 GB for the film, over the memory limit of 1.1 GB: render it in windows (lucent render --region) and merge them"
    );
    assert_eq!(session.wait_until_done().width, 64, "the refused job did not replace the running one");
    let new = RenderSession::with_limits(
        Job { scene: Arc::clone(&scene), camera, settings: big, window: None, aovs: false },
        Some(1),
        limits,
    );
    assert!(matches!(new, Err(SessionError::TooLarge { width: 4096, height: 4096, .. })));
}

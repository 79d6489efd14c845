//! The render session: a new job bumps the generation, and no sample of the old job
//! reaches the new image (it equals a fresh render of the new job, bit for bit).

mod common;

use lucent::integrator::Settings;
use lucent::loader::builtin;
use lucent::render::{Job, RenderSession};
use lucent::scene::Scene;
use std::sync::Arc;
use std::time::Duration;

#[test]
fn a_new_job_restarts_accumulation_without_stale_samples() {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let first = Settings { width: 32, height: 32, seed: 1, ..Settings::default() };
    let session = RenderSession::new(Job { scene: Arc::clone(&scene), camera, settings: first }, Some(2)).unwrap();
    let g1 = session.generation();
    let before = session.wait_for_update(None, Duration::from_secs(30)).expect("a first pass");
    assert_eq!(before.generation, g1);

    let mut moved = camera;
    moved.position.x += 0.05;
    let second = Settings { seed: 2, max_depth: 3, target_spp: Some(16), ..first };
    let g2 = session.set_job(Job { scene: Arc::clone(&scene), camera: moved, settings: second }).unwrap();
    assert!(g2 > g1, "a change bumps the generation");
    assert!(session.snapshot().is_none_or(|s| s.generation == g2), "no stale snapshot is handed out");
    let after = session.wait_until_done();
    assert_eq!((after.generation, after.spp), (g2, 16));

    let fresh = common::render(&scene, moved, second, Some(1));
    assert!(after.mean == fresh.mean, "the restarted image holds only samples of the new job");
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
        assert!(RenderSession::new(Job { scene: Arc::clone(&scene), camera, settings: bad }, None).is_err());
    }
}

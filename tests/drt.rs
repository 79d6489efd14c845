//! Distribution ray tracing: its cost is branching^depth rays per sample, exactly, and it
//! converges to the path tracer's image (Monte Carlo directions), while the textbook's
//! direction grid stops at a discretisation bias.

mod common;

use glam::Vec3;
use lucent::integrator::{Directions, Integrator, LightSampling, Settings};
use lucent::loader::builtin;
use lucent::scene::{Scene, SceneDesc, camera::Camera, material::Material, shapes::uv_sphere};
use std::sync::Arc;

/// Inside a closed sphere of albedo 0.5 emitting 0.5: with max depth D, L = 1 - 0.5^(D+1).
fn furnace() -> (Arc<Scene>, Camera) {
    let mut sphere = uv_sphere(Vec3::ZERO, 1.0, 24, 48, true, 0);
    sphere.normals = None;
    let material = Material { emissive: Vec3::splat(0.5), ..Material::lambert("furnace", Vec3::splat(0.5)) };
    let scene = Scene::build(SceneDesc { meshes: vec![sphere], materials: vec![material], ..SceneDesc::default() });
    (Arc::new(scene), Camera::look_at(Vec3::ZERO, Vec3::new(0.3, 0.2, -1.0), 1.2))
}

fn drt(branching: u32, depth: u32, directions: Directions, lights: LightSampling) -> Settings {
    Settings {
        width: 8,
        height: 8,
        integrator: Integrator::Distribution,
        branching,
        max_depth: depth,
        directions,
        light_sampling: lights,
        target_spp: Some(16),
        ..Settings::default()
    }
}

#[test]
fn rays_per_sample_follow_the_branching_power_law_exactly_in_a_closed_scene() {
    let (scene, camera) = furnace();
    for (n, d) in [(2u32, 2u32), (2, 5), (4, 3), (8, 2)] {
        let settings = drt(n, d, Directions::Stratified, LightSampling::Off);
        let snap = common::render(&scene, camera, settings, None);
        let expected: u64 = (0..=d).map(|k| (n as u64).pow(k)).sum();
        assert_eq!(snap.rays, expected * snap.samples, "N = {n}, D = {d}");
        assert_eq!(expected as f64, settings.rays_per_sample_bound());
    }
    // With light sampling, the bound adds one shadow ray per hit below the last depth.
    let settings = drt(4, 3, Directions::Stratified, LightSampling::Explicit);
    let snap = common::render(&scene, camera, settings, None);
    assert!(snap.rays as f64 <= settings.rays_per_sample_bound() * snap.samples as f64);
    assert!(snap.rays as f64 > 0.9 * settings.rays_per_sample_bound() * snap.samples as f64);
}

#[test]
fn monte_carlo_drt_matches_the_analytic_furnace_and_the_grid_shows_its_bias() {
    let (scene, camera) = furnace();
    let depth = 4;
    let exact = 1.0 - 0.5f64.powi(depth as i32 + 1);
    // The furnace is grey: the red channel stands for all three.
    let z_max = common::sidak_z(1e-3, common::SWITCHES.len());
    for (label, settings) in common::switches(drt(4, depth, Directions::Stratified, LightSampling::Off)) {
        let (mean, se) = common::image_mean(&common::render(&scene, camera, settings, None));
        common::assert_within(mean.x, se.x, exact, z_max, &label);
    }
    // The midpoint grid of eq. 10 is deterministic here (uniform radiance): its error is
    // the quadrature's, which shrinks as the grid refines but does not vanish.
    let depth = 2;
    let exact = 1.0 - 0.5f64.powi(depth as i32 + 1);
    let error = |n| {
        let settings = drt(n, depth, Directions::Grid, LightSampling::Off);
        (common::image_mean(&common::render(&scene, camera, settings, None)).0.x - exact).abs()
    };
    let (coarse, fine) = (error(16), error(64));
    assert!(coarse > 1e-3 && coarse < 0.1, "16 grid directions: error {coarse}");
    assert!(fine < coarse / 2.0 && fine > 1e-5, "64 grid directions: error {fine} vs {coarse}");
}

#[test]
fn drt_and_path_tracing_agree_on_the_cornell_box_block_by_block() {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    // 32x32 pixels in 8x8 blocks; 64 DRT samples per pixel so that the variance estimates
    // of pixels on the lamp's edge (rare, bright hits) are themselves reliable.
    let base = Settings { width: 32, height: 32, max_depth: 3, ..Settings::default() };
    let pt = common::render(&scene, camera, Settings { target_spp: Some(1024), ..base }, None);
    let drt = Settings { integrator: Integrator::Distribution, branching: 4, seed: 1, target_spp: Some(64), ..base };
    let drt = common::render(&scene, camera, drt, None);
    let z_max = common::sidak_z(1e-3, 16 * 3);
    common::assert_blocks_agree(&drt, &pt, 8, z_max, "DRT vs PT");
}

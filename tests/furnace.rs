//! Analytic furnace tests (pbrt-v4's analytic test scenes): closed enclosures whose exact
//! radiance is known, for every combination of the sampling switches. Tolerances come
//! from the variance the renderer itself estimates (z-tests, Sidak-corrected).

mod common;

use glam::Vec3;
use lucent::integrator::Settings;
use lucent::scene::{MeshDesc, Scene, SceneDesc, camera::Camera, material::Material, shapes::uv_sphere};
use std::sync::Arc;

/// Flat-shaded mesh: with face normals every facet is an exact Lambertian reflector, so the
/// closed polyhedron is an exact furnace whatever its tessellation.
fn flat(mut mesh: MeshDesc) -> MeshDesc {
    mesh.normals = None;
    mesh
}

/// Asserts that `scene` seen from `camera` (32x32 pixels, 64 samples, unbounded depth) has
/// mean radiance 1 with every sampling switch: z-tests, and within 2% in red.
fn assert_radiance_one(scene: &Arc<Scene>, camera: Camera, label: &str) {
    let z_max = common::sidak_z(1e-3, common::SWITCHES.len() * 3);
    let base = Settings { width: 32, height: 32, max_depth: u32::MAX, target_spp: Some(64), ..Settings::default() };
    for (switches, settings) in common::switches(base) {
        let snap = common::render(scene, camera, settings, None);
        let mean = common::assert_mean(&snap, 1.0, z_max, &format!("{label}, {switches}"));
        assert!((mean[0] - 1.0).abs() < 0.02, "{label}, {switches}: mean {mean:?} within 2% of 1");
    }
}

#[test]
fn emitting_lambertian_sphere_seen_from_inside_has_radiance_one() {
    // Le = 0.5, albedo 0.5: L = Le / (1 - albedo) = 1 everywhere, with unbounded depth.
    let material = Material { emissive: Vec3::splat(0.5), ..Material::lambert("furnace", Vec3::splat(0.5)) };
    let desc = SceneDesc {
        name: "furnace".into(),
        meshes: vec![flat(uv_sphere(Vec3::ZERO, 1.0, 24, 48, true, 0))],
        materials: vec![material],
        ..SceneDesc::default()
    };
    let scene = Arc::new(Scene::build(desc));
    let camera = Camera::look_at(Vec3::ZERO, Vec3::new(0.3, 0.2, -1.0), 1.2);
    assert_radiance_one(&scene, camera, "furnace");
}

#[test]
fn white_sphere_in_an_emitting_enclosure_returns_the_emitted_radiance() {
    // A convex albedo-1 sphere under uniform incident radiance 1 reflects exactly 1.
    let enclosure = Material { emissive: Vec3::ONE, ..Material::lambert("enclosure", Vec3::ZERO) };
    let white = Material::lambert("white", Vec3::ONE);
    let desc = SceneDesc {
        name: "enclosure".into(),
        meshes: vec![
            flat(uv_sphere(Vec3::ZERO, 3.0, 16, 32, true, 0)),
            flat(uv_sphere(Vec3::ZERO, 0.3, 24, 48, false, 1)),
        ],
        materials: vec![enclosure, white],
        ..SceneDesc::default()
    };
    let scene = Arc::new(Scene::build(desc));
    // A narrow view that sees only the small sphere.
    let camera = Camera::look_at(Vec3::new(0.0, 0.4, 1.5), Vec3::ZERO, 0.25);
    let z_max = common::sidak_z(1e-3, common::SWITCHES.len() * 3);
    let base = Settings { width: 24, height: 24, max_depth: 3, target_spp: Some(64), ..Settings::default() };
    for (label, settings) in common::switches(base) {
        let snap = common::render(&scene, camera, settings, None);
        common::assert_mean(&snap, 1.0, z_max, &label);
        let brightest = snap.mean.iter().map(|p| p.max_element()).fold(0.0f32, f32::max);
        assert!(brightest < 2.0, "no pixel far above the emitted radiance: {brightest}");
    }
}

#[test]
fn a_smooth_mirror_and_smooth_glass_in_the_furnace_change_nothing() {
    // Inside the enclosure above (L = 1 everywhere), a white mirror reflects 1 and a clear
    // glass sphere passes 1 (R + T = 1, its radiance scaled by eta^2 inside and back out):
    // every pixel is 1 in every mode. Emission found after the delta bounces must count in
    // full, also with explicit light sampling, or the mirror and glass would show only half.
    let enclosure = Material { emissive: Vec3::splat(0.5), ..Material::lambert("furnace", Vec3::splat(0.5)) };
    let mirror = Material { metallic: 1.0, roughness: 0.0, ..Material::lambert("mirror", Vec3::ONE) };
    let glass = Material::glass("glass", 1.5, Some(Vec3::ZERO));
    let desc = SceneDesc {
        name: "delta furnace".into(),
        meshes: vec![
            flat(uv_sphere(Vec3::ZERO, 1.0, 24, 48, true, 0)),
            flat(uv_sphere(Vec3::new(0.25, 0.0, -0.5), 0.2, 16, 32, false, 1)),
            flat(uv_sphere(Vec3::new(-0.25, 0.0, -0.5), 0.2, 16, 32, false, 2)),
        ],
        materials: vec![enclosure, mirror, glass],
        ..SceneDesc::default()
    };
    let scene = Arc::new(Scene::build(desc));
    let camera = Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 0.9);
    assert_radiance_one(&scene, camera, "delta furnace");
}

//! Analytic furnace tests (pbrt-v4's analytic test scenes): closed enclosures whose exact
//! radiance is known, for every combination of the sampling switches. Tolerances come
//! from the variance the renderer itself estimates (z-tests, Sidak-corrected).

mod common;

use glam::Vec3;
use lucent::integrator::{LightSampling, Settings};
use lucent::scene::{MeshDesc, Scene, SceneDesc, camera::Camera, material::Material, shapes::uv_sphere};
use std::sync::Arc;

const SWITCHES: [(bool, LightSampling); 6] = [
    (true, LightSampling::Off),
    (true, LightSampling::Explicit),
    (true, LightSampling::Mis),
    (false, LightSampling::Off),
    (false, LightSampling::Explicit),
    (false, LightSampling::Mis),
];

/// Flat-shaded mesh: with face normals every facet is an exact Lambertian reflector, so the
/// closed polyhedron is an exact furnace whatever its tessellation.
fn flat(mut mesh: MeshDesc) -> MeshDesc {
    mesh.normals = None;
    mesh
}

/// Asserts the image mean equals `expected` in every channel within a z-test bound
/// built from the per-pixel variance estimates; returns the measured mean.
fn assert_mean(snap: &lucent::render::Snapshot, expected: f64, z_max: f64, label: &str) -> [f64; 3] {
    assert_eq!(snap.rejected, 0, "{label}: NaN/Inf samples");
    let n = snap.mean.len() as f64;
    let mut out = [0.0; 3];
    for c in 0..3 {
        let mean = snap.mean.iter().map(|p| p[c] as f64).sum::<f64>() / n;
        let se = (snap.variance.iter().map(|v| v[c] as f64).sum::<f64>()).sqrt() / n;
        if se == 0.0 {
            // A zero-variance estimator (e.g. cosine sampling under uniform light) must be exact.
            assert!((mean - expected).abs() < 1e-5, "{label}: zero-variance mean {mean} != {expected}");
            out[c] = mean;
            continue;
        }
        let z = (mean - expected) / se;
        assert!(z.abs() < z_max, "{label}: channel {c} mean {mean:.5} vs {expected} (z = {z:.2}, se {se:.2e})");
        out[c] = mean;
    }
    out
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
    let z_max = common::sidak_z(1e-3, SWITCHES.len() * 3);
    for (importance, lights) in SWITCHES {
        let settings = Settings {
            width: 32,
            height: 32,
            max_depth: u32::MAX,
            importance_sampling: importance,
            light_sampling: lights,
            target_spp: Some(64),
            ..Settings::default()
        };
        let snap = common::render(&scene, camera, settings, None);
        let mean = assert_mean(&snap, 1.0, z_max, &format!("importance {importance}, lights {lights:?}"));
        assert!((mean[0] - 1.0).abs() < 0.02, "mean {mean:?} within 2% of 1");
    }
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
    let z_max = common::sidak_z(1e-3, SWITCHES.len() * 3);
    for (importance, lights) in SWITCHES {
        let settings = Settings {
            width: 24,
            height: 24,
            max_depth: 3,
            importance_sampling: importance,
            light_sampling: lights,
            target_spp: Some(64),
            ..Settings::default()
        };
        let snap = common::render(&scene, camera, settings, None);
        assert_mean(&snap, 1.0, z_max, &format!("importance {importance}, lights {lights:?}"));
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
    let z_max = common::sidak_z(1e-3, SWITCHES.len() * 3);
    for (importance, lights) in SWITCHES {
        let settings = Settings {
            width: 32,
            height: 32,
            max_depth: u32::MAX,
            importance_sampling: importance,
            light_sampling: lights,
            target_spp: Some(64),
            ..Settings::default()
        };
        let snap = common::render(&scene, camera, settings, None);
        let mean =
            assert_mean(&snap, 1.0, z_max, &format!("delta furnace, importance {importance}, lights {lights:?}"));
        assert!((mean[0] - 1.0).abs() < 0.02, "mean {mean:?} within 2% of 1");
    }
}

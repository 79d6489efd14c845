//! The control variate for the edges of emitters the camera sees (`integrator::edges`): it
//! makes the pixels along a seen light's outline exact where nothing hides it, and leaves
//! every pixel's mean unchanged where something does.

mod common;

use glam::Vec3;
use lucent::integrator::{Integrator, SamplerKind, Settings};
use lucent::loader::builtin;
use lucent::render::Snapshot;
use lucent::scene::{MeshDesc, Scene, SceneDesc, camera::Camera, material::Material};
use std::sync::Arc;

const SIZE: u32 = 64;

/// Emitted light only (max depth 0), `spp` samples per pixel.
fn emission_only(spp: u32, light_edges: bool, sampler: SamplerKind, seed: u64) -> Settings {
    Settings {
        width: SIZE,
        height: SIZE,
        max_depth: 0,
        target_spp: Some(spp),
        light_edges,
        sampler,
        seed,
        ..Settings::default()
    }
}

fn total_variance(s: &Snapshot) -> f64 {
    s.variance.iter().map(|v| v.as_dvec3().element_sum()).sum()
}

#[test]
fn a_seen_light_is_exact_along_its_edges() {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let reference = common::render(&scene, camera, emission_only(1024, false, SamplerKind::Independent, 2), None);
    // The bidirectional estimators find a seen light by one strategy alone (the camera
    // subpath's), so the control variate fits them as it fits the path tracer.
    for integrator in [Integrator::Path, Integrator::Bdpt, Integrator::Vcm] {
        let settings = |edges| Settings { integrator, ..emission_only(16, edges, SamplerKind::Sobol, 1) };
        let with = common::render(&scene, camera, settings(true), None);
        let without = common::render(&scene, camera, settings(false), None);
        // Without it the light's edge pixels are a coin toss per sample; with it each sample
        // carries the pixel's exact share of the light (to rounding).
        let (v_with, v_without) = (total_variance(&with), total_variance(&without));
        assert!(v_without > 1.0, "{integrator:?}: the light's edges are in view: variance {v_without}");
        assert!(
            v_with < 1e-9 * v_without,
            "{integrator:?}: variance {v_with} with the control variate against {v_without}"
        );
        // And the exact pixels are the pixels' means: an independent, unbiased render without it.
        let z = common::sidak_z(1e-3, 3 * (SIZE * SIZE / 64) as usize);
        common::assert_blocks_agree(&with, &reference, 8, z, &format!("{integrator:?}, light edges on"));
    }
}

/// An emitting square facing the camera, and a grey strip in front of it that hides part
/// of its outline.
fn hidden_light() -> SceneDesc {
    let quad = |name: &str, lo: Vec3, hi: Vec3, material: u32| MeshDesc {
        name: name.into(),
        positions: vec![lo, Vec3::new(hi.x, lo.y, lo.z), hi, Vec3::new(lo.x, hi.y, lo.z)],
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
        ..MeshDesc::default()
    };
    SceneDesc {
        name: "hidden light".into(),
        meshes: vec![
            quad("lamp", Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), 0),
            quad("strip", Vec3::new(-2.0, -0.5, 1.0), Vec3::new(0.35, 0.3, 1.0), 1),
        ],
        materials: vec![
            Material { emissive: Vec3::new(3.0, 2.0, 1.0), ..Material::lambert("lamp", Vec3::ZERO) },
            Material::lambert("strip", Vec3::splat(0.5)),
        ],
        ..SceneDesc::default()
    }
}

#[test]
fn a_partly_hidden_light_keeps_its_mean() {
    let scene = Arc::new(Scene::build(hidden_light()));
    let camera = Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 0.8);
    // Independent samples, so that the variances the z-tests use are honest.
    let with = common::render(&scene, camera, emission_only(256, true, SamplerKind::Independent, 1), None);
    let without = common::render(&scene, camera, emission_only(256, false, SamplerKind::Independent, 2), None);
    let z = common::sidak_z(1e-3, 3 * (SIZE * SIZE / 64) as usize);
    common::assert_blocks_agree(&with, &without, 8, z, "hidden light edges");
    // Film columns: the lamp's right edge (x = 1) falls at 47.14, its left edge (x = -1)
    // at 16.86, rows 16.86 to 47.14; the strip covers rows 26.3 to 41.5 of the left edge.
    let pixel_variance = |s: &Snapshot, x: u32, rows: std::ops::RangeInclusive<u32>| -> f64 {
        rows.map(|y| s.variance[(y * SIZE + x) as usize].as_dvec3().element_sum()).sum()
    };
    // Along the open right edge the control variate cancels the coin toss.
    let (open_with, open_without) = (pixel_variance(&with, 47, 18..=45), pixel_variance(&without, 47, 18..=45));
    assert!(open_without > 0.0 && open_with < 1e-9 * open_without, "open edge: {open_with} against {open_without}");
    // Behind the strip the edge pixels see no light: the view's set-up finds the strip in
    // front of the lamp there and gives them no term, so they stay exact (black).
    let (hidden_with, hidden_without) = (pixel_variance(&with, 16, 28..=40), pixel_variance(&without, 16, 28..=40));
    assert_eq!((hidden_with, hidden_without), (0.0, 0.0), "the strip hides the light there");
    // Where the strip's edges cross the lamp's (rows 26 and 41 of that column), the set-up's
    // rays through the covered part all meet the lamp while some samples meet the strip:
    // those pixels keep the term, and its noise of mean zero (the z-tests above).
    for y in [26, 41] {
        assert!(pixel_variance(&with, 16, y..=y) > 1e-4, "pixel (16, {y}) keeps the term where partly hidden");
    }
}

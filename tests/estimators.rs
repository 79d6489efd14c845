//! Estimator agreement: on the Cornell box every combination of the importance-sampling
//! and light-sampling switches, and the Sobol sampler, converges to the same image as MIS;
//! on the glass Cornell box (a smooth mirror sphere and a smooth glass sphere: delta lobes)
//! so do explicit light sampling and no light sampling, with and without importance
//! sampling. Block means of pixels are compared with a z-test whose variance comes from
//! the per-pixel estimates, at family-wise significance 1e-3 with the Sidak correction over
//! blocks, channels and combinations.

mod common;

use lucent::integrator::{LightSampling, PixelSampling, SamplerKind, Settings};
use lucent::loader::builtin;
use lucent::scene::Scene;
use std::sync::Arc;

const SIZE: u32 = 128;
const BLOCK: u32 = 16;

fn cornell() -> Arc<Scene> {
    Arc::new(Scene::build(builtin::cornell_box()))
}

fn settings(importance: bool, lights: LightSampling, pixel_sampling: PixelSampling, seed: u64, spp: u32) -> Settings {
    Settings {
        width: SIZE,
        height: SIZE,
        seed,
        importance_sampling: importance,
        light_sampling: lights,
        pixel_sampling,
        target_spp: Some(spp),
        ..Settings::default()
    }
}

#[test]
fn every_switch_combination_agrees_with_mis_block_by_block() {
    let scene = cornell();
    let camera = scene.default_camera(1.0);
    let reference =
        common::render(&scene, camera, settings(true, LightSampling::Mis, PixelSampling::Random, 1, 64), None);
    // The Sobol sampler's per-pixel variance overestimates the error of its mean (its
    // samples are stratified), which only makes its z-test conservative.
    use SamplerKind::{Independent, Sobol};
    let combos = [
        (true, LightSampling::Off, PixelSampling::Random, 256, Independent),
        (true, LightSampling::Explicit, PixelSampling::Random, 64, Independent),
        (true, LightSampling::Mis, PixelSampling::Stratified, 64, Independent),
        (false, LightSampling::Off, PixelSampling::Random, 256, Independent),
        (false, LightSampling::Explicit, PixelSampling::Random, 64, Independent),
        (false, LightSampling::Mis, PixelSampling::Random, 64, Independent),
        (true, LightSampling::Mis, PixelSampling::Random, 64, Sobol),
    ];
    let z_max = common::sidak_z(1e-3, combos.len() * common::blocks(&reference, BLOCK).len() * 3);
    for (importance, lights, pixels, spp, sampler) in combos {
        let s = Settings { sampler, ..settings(importance, lights, pixels, 2, spp) };
        let snap = common::render(&scene, camera, s, None);
        let label = format!("importance {importance}, lights {lights:?}, {pixels:?}, {sampler:?} vs MIS");
        let worst = common::assert_blocks_agree(&snap, &reference, BLOCK, z_max, &label);
        eprintln!("{label}: worst |z| {worst:.2} (limit {z_max:.2})");
    }
}

#[test]
fn the_grid_baseline_matches_the_reference_over_the_whole_image() {
    // Grid pixel sampling is biased per pixel by discretisation (edges alias), but over the
    // whole image the midpoint rule's error is far below the path noise, so the image means
    // must pass the same z-test (variance of a mean of pixel means: sum of variances / n^2).
    let scene = cornell();
    let camera = scene.default_camera(1.0);
    let reference =
        common::render(&scene, camera, settings(true, LightSampling::Mis, PixelSampling::Random, 3, 64), None);
    let grid = common::render(&scene, camera, settings(true, LightSampling::Mis, PixelSampling::Grid, 3, 64), None);
    // The whole image as one block.
    let z_max = common::sidak_z(1e-3, 3);
    common::assert_block_means_agree(
        &common::blocks(&grid, SIZE),
        &common::blocks(&reference, SIZE),
        0..3,
        0.0,
        z_max,
        "grid vs reference",
    );
    assert!(common::image_mean(&grid).0.as_vec3().min_element() > 0.0);
}

#[test]
fn explicit_and_no_light_sampling_agree_with_mis_on_the_glass_box() {
    // Delta lobes: no light is sampled at the mirror or the glass, and light found after
    // them counts in full in every mode. Had explicit sampling dropped it (as before delta
    // lobes existed), the mirror sphere would show no lamp and the caustic would vanish.
    let scene = Arc::new(Scene::build(common::load("cornell-box-glass.gltf")));
    let size = 64;
    let camera = scene.default_camera(1.0);
    let glass = |importance, lights, seed, spp| Settings {
        width: size,
        height: size,
        max_depth: 10,
        ..settings(importance, lights, PixelSampling::Random, seed, spp)
    };
    let reference = common::render(&scene, camera, glass(true, LightSampling::Mis, 11, 512), None);
    let combos = [
        (true, LightSampling::Explicit, 512),
        (true, LightSampling::Off, 1024),
        (false, LightSampling::Explicit, 512),
        (false, LightSampling::Mis, 512),
    ];
    let z_max = common::sidak_z(1e-3, combos.len() * common::blocks(&reference, 8).len() * 3);
    for (importance, lights, spp) in combos {
        let snap = common::render(&scene, camera, glass(importance, lights, 12, spp), None);
        let label = format!("glass box, importance {importance}, lights {lights:?} vs MIS");
        let worst = common::assert_blocks_agree(&snap, &reference, 8, z_max, &label);
        eprintln!("{label}: worst |z| {worst:.2} (limit {z_max:.2})");
    }
}

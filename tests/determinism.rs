//! Reproducibility: every pixel sample is a pure function of (pixel, index, seed), so
//! images are bit-identical whatever the thread count, and skipping the effects a scene
//! lacks gives the same bits as running every feature's code.

mod common;

use lucent::integrator::{LightSampling, PixelSampling, SamplerKind, Settings};
use lucent::loader::builtin;
use lucent::scene::{Features, Scene};
use std::sync::Arc;

fn settings(seed: u64) -> Settings {
    Settings { width: 48, height: 40, seed, target_spp: Some(12), ..Settings::default() }
}

#[test]
fn images_are_bit_identical_with_one_and_many_threads() {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(48.0 / 40.0);
    let variants = [
        (PixelSampling::Random, SamplerKind::Independent),
        (PixelSampling::Stratified, SamplerKind::Independent),
        (PixelSampling::Grid, SamplerKind::Independent),
        (PixelSampling::Random, SamplerKind::Sobol),
    ];
    for (pixel_sampling, sampler) in variants {
        let s = Settings { pixel_sampling, sampler, strata: 3, ..settings(5) };
        let one = common::render(&scene, camera, s, Some(1));
        let many = common::render(&scene, camera, s, Some(3));
        assert_eq!(one.spp, 12);
        assert!(one.mean == many.mean, "{pixel_sampling:?}, {sampler:?}: 1 vs 3 threads differ");
        assert!(one.variance == many.variance);
    }
    let other_seed = common::render(&scene, camera, settings(6), Some(2));
    let seed5 = common::render(&scene, camera, settings(5), Some(2));
    assert!(other_seed.mean != seed5.mean, "the seed changes the image");
}

#[test]
fn skipping_absent_effects_gives_the_bits_of_running_them_all() {
    let specialised = Arc::new(Scene::build(builtin::cornell_box()));
    // The box's glTF materials are single-sided, so camera rays cull back faces.
    assert_eq!(specialised.features, Features { emissive: true, cutouts: true, ..Features::default() });
    let mut general = Scene::build(builtin::cornell_box());
    general.features = Features::ALL;
    let general = Arc::new(general);
    let camera = specialised.default_camera(1.2);
    for light_sampling in [LightSampling::Off, LightSampling::Explicit, LightSampling::Mis] {
        let s = Settings { light_sampling, ..settings(1) };
        let a = common::render(&specialised, camera, s, None);
        let b = common::render(&general, camera, s, None);
        assert!(a.mean == b.mean, "{light_sampling:?}: the scene's switches and every feature on differ");
    }
}

#[test]
fn shadow_rays_stop_at_refracting_glass_with_the_bits_of_testing_what_they_cross() {
    // The glass box's glass refracts (index 1.5 against air): no light passes it straight,
    // so its shadow rays take an occlusion query, not a walk through every surface.
    let path = common::asset("cornell-box-glass.gltf");
    let open = || lucent::open::open(Some(&path), &Default::default(), &mut |_| {}).expect("the glass box loads");
    let specialised = Arc::new(open());
    assert!(specialised.features.volumes && !specialised.features.see_through, "{:?}", specialised.features);
    let mut walking = open();
    walking.features.see_through = true;
    let walking = Arc::new(walking);
    let camera = specialised.default_camera(1.2);
    for light_sampling in [LightSampling::Explicit, LightSampling::Mis] {
        let s = Settings { light_sampling, max_depth: 4, ..settings(3) };
        let a = common::render(&specialised, camera, s, None);
        let b = common::render(&walking, camera, s, None);
        assert!(a.mean == b.mean, "{light_sampling:?}: occlusion queries and walks differ");
    }
}

#[test]
fn a_pixels_samples_taken_together_are_the_bits_of_each_taken_alone() {
    use glam::UVec2;
    use lucent::integrator::{View, sample_pixel, sample_pixels};
    let scene = Scene::build(builtin::cornell_box());
    let camera = scene.default_camera(1.0);
    // Replicates split the indices among sequences; indices past 2^16 start new ones.
    for (sampler, replicates) in [(SamplerKind::Sobol, 1), (SamplerKind::Sobol, 2), (SamplerKind::Independent, 1)] {
        let settings = Settings { width: 16, height: 16, sampler, ..settings(9) };
        let settings = if replicates > 1 { Settings { noise_threshold: Some(0.05), ..settings } } else { settings };
        assert_eq!(settings.replicates(), replicates);
        let view = View::new(&scene, &camera, 16, 16);
        for (pixel, start) in [(UVec2::new(7, 4), 0), (UVec2::new(3, 12), 65_530)] {
            let mut together = Vec::new();
            sample_pixels(
                &scene,
                &settings,
                &view,
                pixel,
                start..start + 12,
                false,
                |i, out| together.push((i, out)),
                (&mut |_, _| {}, None),
            );
            assert_eq!(together.len(), 12);
            for (i, out) in together {
                let alone = sample_pixel(&scene, &settings, &view, pixel, i, false, &mut |_, _| {});
                assert_eq!(
                    out.radiance.to_rgb().to_array().map(f32::to_bits),
                    alone.radiance.to_rgb().to_array().map(f32::to_bits)
                );
                assert_eq!(out.rays, alone.rays, "{sampler:?} x{replicates}, sample {i} of {pixel}");
            }
        }
    }
}

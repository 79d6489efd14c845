//! NaN/Inf values are counted per cause (debug builds, or the `nan-causes` feature that the
//! test command enables), so that a regression names its source. Each case plants one
//! non-finite value where only one cause can see it. One test per process: the counters
//! are global.

use glam::{UVec2, Vec3};
use lucent::integrator::nan::{self, NanCause};
use lucent::integrator::{Settings, View, sample_pixel};
use lucent::loader::builtin;
use lucent::scene::Scene;

fn count(cause: NanCause) -> u64 {
    nan::counts().iter().find(|(c, _)| *c == cause).unwrap().1
}

/// Renders 64 samples of each pixel of an 8x8 Cornell box with the materials changed by
/// `edit`, and returns how many samples came out non-finite. The lamp covers 0.19 of each
/// of two pixels there (its radiance 17 against 3.16 in those pixels at depth 1), so with
/// one sample per pixel camera rays miss it with probability 0.66; with 64, below 1e-11.
fn render_with(edit: impl Fn(&mut Vec<lucent::scene::material::Material>)) -> u32 {
    let scene = Scene::build(builtin::cornell_box());
    let mut materials = scene.materials.clone();
    edit(&mut materials);
    let scene = scene.with_edits(materials, scene.lights.clone());
    let settings = Settings { width: 8, height: 8, ..Settings::default() };
    let view = View::new(&scene, &scene.default_camera(1.0), 8, 8);
    (0..64u32 * 64)
        .map(|i| {
            let pixel = UVec2::new(i % 64 % 8, i % 64 / 8);
            !sample_pixel(&scene, &settings, &view, pixel, (i / 64) as u64, false, &mut |_, _| {}).radiance.is_finite()
                as u32
        })
        .sum()
}

#[test]
fn each_planted_nan_is_counted_under_its_cause() {
    assert!(nan::enabled(), "run the tests with --features nan-causes (the README's test command does)");
    let before = nan::counts();
    assert!(before.iter().all(|(_, n)| *n == 0), "{before:?}");

    // Infinite emission on the lamp, seen directly by camera rays.
    let inf = Vec3::new(f32::INFINITY, 1.0, 1.0);
    let bad = render_with(|m| m.iter_mut().filter(|m| m.is_emissive()).for_each(|m| m.emissive = inf));
    assert!(bad > 0 && count(NanCause::Emission) > 0, "{:?}", nan::counts());
    assert_eq!(count(NanCause::LightSample) + count(NanCause::BsdfSample) + count(NanCause::CameraRay), 0);

    // NaN albedo on every non-emissive surface: the BSDF sample rejects it (no direction),
    // and light samples through it are non-finite.
    let emission_before = count(NanCause::Emission);
    let bad = render_with(|m| m.iter_mut().filter(|m| !m.is_emissive()).for_each(|m| m.base_color = Vec3::NAN));
    assert!(bad > 0 && count(NanCause::LightSample) > 0, "{:?}", nan::counts());
    assert_eq!(count(NanCause::Emission), emission_before);
    assert_eq!(count(NanCause::BsdfSample) + count(NanCause::CameraRay), 0);
    assert!(nan::report().contains("Emission") && nan::report().contains("LightSample"));
}

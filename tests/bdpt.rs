//! Bidirectional path tracing converges to the path tracer's images where both can render
//! them (the Cornell box; the glass box's delta lobes), finds the caustic a point light casts
//! through glass, which the path tracer cannot, and renders the same bits on any number of
//! threads although its light-tracing contributions land on any pixel. Vertex connection and
//! merging agrees with them too at its default radius, and sees that caustic through the
//! glass ball itself, which no connection can.
//!
//! A BDPT render's own variance estimate misses the noise of what it splats, so its error is
//! estimated from independent renders (seeds): the mean of K renders' blocks and the
//! variance of that mean from their spread, against a long path-traced reference.

mod common;

use glam::{DVec3, Vec3};
use lucent::integrator::{Integrator, Settings};
use lucent::loader::builtin;
use lucent::scene::{
    Scene, SceneDesc,
    camera::Camera,
    light::{PunctualKind, PunctualLight},
    material::Material,
    shapes::{cuboid, uv_sphere},
};
use std::sync::Arc;

const SIZE: u32 = 32;
const BLOCK: u32 = 8;

/// Block means of `k` renders of `settings` with seeds 1..=k, and the variance of their
/// mean from the renders' spread.
fn independent_blocks(scene: &Arc<Scene>, camera: Camera, settings: Settings, k: u64) -> Vec<(DVec3, DVec3)> {
    let renders: Vec<Vec<(DVec3, DVec3)>> = (1..=k)
        .map(|seed| {
            let snap = common::render(scene, camera, Settings { seed, ..settings }, None);
            assert_eq!(snap.rejected, 0, "NaN/Inf samples");
            common::blocks(&snap, BLOCK)
        })
        .collect();
    (0..renders[0].len())
        .map(|b| {
            let mean = renders.iter().map(|r| r[b].0).sum::<DVec3>() / k as f64;
            let var = renders.iter().map(|r| (r[b].0 - mean) * (r[b].0 - mean)).sum::<DVec3>() / (k - 1) as f64;
            (mean, var / k as f64)
        })
        .collect()
}

/// The bidirectional estimators count scattering in media toward `max_depth`: so does the
/// path tracer here (`max_volume_depth` off), so that both cut the same paths.
fn settings(integrator: Integrator, spp: u32, max_depth: u32) -> Settings {
    Settings {
        width: SIZE,
        height: SIZE,
        integrator,
        target_spp: Some(spp),
        max_depth,
        max_volume_depth: None,
        ..Settings::default()
    }
}

/// BDPT's blocks agree with the path tracer's, at family-wise significance 1e-3.
fn agrees_with_the_path_tracer(scene: &Arc<Scene>, camera: Camera, max_depth: u32, label: &str) {
    agrees_with_the_path_tracer_as(Integrator::Bdpt, scene, camera, max_depth, label);
}

/// `integrator`'s blocks agree with the path tracer's, at family-wise significance 1e-3.
fn agrees_with_the_path_tracer_as(
    integrator: Integrator,
    scene: &Arc<Scene>,
    camera: Camera,
    max_depth: u32,
    label: &str,
) {
    let reference = common::render(scene, camera, settings(Integrator::Path, 2048, max_depth), None);
    let bdpt = independent_blocks(scene, camera, settings(integrator, 64, max_depth), 12);
    let blocks = (SIZE / BLOCK).pow(2) as usize;
    let z_max = common::sidak_z(1e-3, blocks * 3);
    common::assert_block_means_agree(&bdpt, &common::blocks(&reference, BLOCK), 0..3, 0.0, z_max, label);
}

#[test]
fn bdpt_agrees_with_the_path_tracer_on_the_cornell_box() {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    agrees_with_the_path_tracer(&scene, camera, 5, "Cornell box");
}

#[test]
fn bdpt_agrees_with_the_path_tracer_through_mirrors_and_glass() {
    let scene = Arc::new(Scene::build(common::load("cornell-box-glass.gltf")));
    let camera = scene.default_camera(1.0);
    agrees_with_the_path_tracer(&scene, camera, 8, "glass box");
}

/// A white point light of intensity 20 at `position`.
fn bulb(position: Vec3) -> PunctualLight {
    PunctualLight {
        name: "bulb".into(),
        kind: PunctualKind::Point,
        position,
        direction: -Vec3::Y,
        color: Vec3::ONE,
        intensity: 20.0,
        range: None,
        source: None,
    }
}

/// A grey floor, a smooth glass ball above it, and a point light above the ball.
fn point_light_over_glass() -> (Arc<Scene>, Camera) {
    let light = bulb(Vec3::new(0.0, 3.0, 0.0));
    let desc = SceneDesc {
        name: "caustic".into(),
        meshes: vec![
            cuboid(Vec3::new(-3.0, -1.1, -3.0), Vec3::new(3.0, -1.0, 3.0), false, 0),
            uv_sphere(Vec3::ZERO, 0.6, 48, 96, false, 1),
        ],
        materials: vec![Material::lambert("floor", Vec3::splat(0.7)), Material::glass("ball", 1.5, None)],
        lights: vec![light],
        ..SceneDesc::default()
    };
    let scene = Arc::new(Scene::build(desc));
    // Looking down at the floor under the ball, past its side.
    let camera = Camera::look_at(Vec3::new(0.0, 2.0, 3.5), Vec3::new(0.0, -1.0, 0.0), 0.7);
    (scene, camera)
}

#[test]
fn bdpt_finds_the_caustic_a_point_light_casts_through_glass() {
    // The path tracer cannot connect a floor point to a point light through the ball (its
    // shadow rays stop at refracting surfaces, and BSDF sampling never hits a point): under
    // the ball it sees a shadow. BDPT's light subpaths refract through the ball and are seen
    // by the camera where they land: the image holds more light than the path tracer's.
    let (scene, camera) = point_light_over_glass();
    let pt = common::render(&scene, camera, settings(Integrator::Path, 256, 8), None);
    let bdpt = independent_blocks(&scene, camera, settings(Integrator::Bdpt, 64, 8), 8);
    assert_more_light((&bdpt, "BDPT"), (&common::blocks(&pt, BLOCK), "the path tracer"));
}

/// Asserts the image of blocks `with` holds more light in all than `without`, by ten
/// standard errors of the difference.
fn assert_more_light((with, a): (&[(DVec3, DVec3)], &str), (without, b): (&[(DVec3, DVec3)], &str)) {
    let total = |b: &[(DVec3, DVec3)]| b.iter().map(|x| x.0.element_sum()).sum::<f64>();
    let var = |b: &[(DVec3, DVec3)]| b.iter().map(|x| x.1.element_sum()).sum::<f64>();
    let (more, less, se) = (total(with), total(without), (var(with) + var(without)).sqrt());
    assert!(more - less > 10.0 * se, "{a} {more:.4}, {b} {less:.4} (se {se:.4})");
}

#[test]
fn vcm_agrees_with_the_path_tracer_on_the_cornell_box_and_through_glass() {
    // Merging is biased at any finite radius; at the default radius (0.2% of the scene's,
    // shrinking) the bias must stay below what 12 renders of 64 iterations can detect.
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    agrees_with_the_path_tracer_as(Integrator::Vcm, &scene, scene.default_camera(1.0), 5, "VCM, Cornell box");
    let scene = Arc::new(Scene::build(common::load("cornell-box-glass.gltf")));
    agrees_with_the_path_tracer_as(Integrator::Vcm, &scene, scene.default_camera(1.0), 8, "VCM, glass box");
}

#[test]
fn vcm_merges_carry_the_right_energy_at_a_wide_radius() {
    // At a radius of 3% of the scene's, merging carries 6 to 7% of the brightest blocks'
    // light (measured: without merges they are 6% dark, with twice their energy 8% bright).
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let reference = common::render(&scene, camera, settings(Integrator::Path, 2048, 5), None);
    let wide = Settings { vcm_radius: 0.03, ..settings(Integrator::Vcm, 64, 5) };
    let vcm = independent_blocks(&scene, camera, wide, 12);
    let z_max = common::sidak_z(1e-3, (SIZE / BLOCK).pow(2) as usize * 3);
    // The kernel's bias at this radius, measured: up to 1% of a block (next to the light).
    // Allowed: 3%, which merges off by a factor of 2 (the disc's area against its radius's
    // square, the number of light paths) exceed; smaller errors this test cannot see.
    for (b, (v, r)) in vcm.iter().zip(&common::blocks(&reference, BLOCK)).enumerate() {
        for c in 0..3 {
            let se = (v.1[c] + r.1[c]).sqrt();
            let allowed = z_max * se + 0.03 * r.0[c];
            assert!(
                (v.0[c] - r.0[c]).abs() < allowed,
                "block {b} channel {c}: VCM {:.5}, reference {:.5}",
                v.0[c],
                r.0[c]
            );
        }
    }
}

#[test]
fn vcm_converges_to_bdpt_as_its_radius_shrinks() {
    // Merging at a radius r blurs the light it carries, a bias growing as r^2 (and as the
    // merges' weight, which falls with r too). At a wide radius (10% of the scene's) held
    // fixed (alpha 1) it shows: blocks lie far off a long BDPT render. Shrinking from there
    // (alpha 1/4: r_i^2 = r^2 i^-3/4 at iteration i), the bias left in N iterations is at
    // most the fixed radius's times the mean of i^-3/4 (1/16 at 256): each block must lie
    // between BDPT's and that, within its noise. The bias vanishes with the radius, which is
    // what makes VCM consistent.
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let reference = common::blocks(&common::render(&scene, camera, settings(Integrator::Bdpt, 4096, 5), None), BLOCK);
    let z_max = common::sidak_z(1e-3, (SIZE / BLOCK).pow(2) as usize * 3);
    let (iterations, alpha) = (256u32, 0.25f64);
    let fixed = Settings { vcm_radius: 0.1, vcm_alpha: 1.0, ..settings(Integrator::Vcm, iterations, 5) };
    let fixed_blocks = independent_blocks(&scene, camera, fixed, 6);
    let biased = common::assert_block_means_agree(&fixed_blocks, &reference, 0..3, 0.0, f64::INFINITY, "fixed");
    assert!(biased > 10.0 * z_max, "at a fixed radius the worst block is only {biased:.1} standard errors off");
    let share = (1..=iterations).map(|i| (i as f64).powf(alpha - 1.0)).sum::<f64>() / iterations as f64;
    let shrinking = Settings { vcm_alpha: alpha as f32, ..fixed };
    let vcm = independent_blocks(&scene, camera, shrinking, 6);
    for (b, ((v, r), f)) in vcm.iter().zip(&reference).zip(&fixed_blocks).enumerate() {
        for c in 0..3 {
            let bound = share * (f.0[c] - r.0[c]);
            let se = (v.1[c] + r.1[c] + share * share * f.1[c]).sqrt();
            let (low, high) = (bound.min(0.0) - z_max * se, bound.max(0.0) + z_max * se);
            let bias = v.0[c] - r.0[c];
            assert!(
                (low..=high).contains(&bias),
                "block {b} channel {c}: shrinking, {bias:.5} off BDPT; allowed {low:.5}..{high:.5} (fixed: {:.5})",
                f.0[c] - r.0[c]
            );
        }
    }
}

#[test]
fn vcm_sees_the_caustic_through_the_glass_that_casts_it() {
    // Looking down through the ball at the floor under it: light from the point light
    // crosses the ball, lands on the floor and crosses the ball again to the camera. Every
    // vertex but the floor's is a delta, and the floor's neighbours are both deltas, so no
    // connection can make these paths: BDPT sees the floor there in the ball's shadow.
    // Merging at the floor finds them.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scenes/caustic.gltf");
    let scene = Arc::new(Scene::build(common::load(path)));
    let camera = scene.file_camera(1).expect("the camera through the ball");
    let bdpt = independent_blocks(&scene, camera, settings(Integrator::Bdpt, 32, 8), 6);
    // A wider radius than the default: 32 iterations of 1,024 light subpaths are few.
    let wide = Settings { vcm_radius: 0.02, ..settings(Integrator::Vcm, 32, 8) };
    let vcm = independent_blocks(&scene, camera, wide, 6);
    assert_more_light((&vcm, "VCM"), (&bdpt, "BDPT"));
}

#[test]
fn vcm_renders_the_same_bits_on_any_number_of_threads() {
    same_bits_on_one_and_two_threads(settings(Integrator::Vcm, 4, 6));
}

#[test]
fn bidirectional_renders_give_the_denoiser_the_path_tracers_albedo_and_normal() {
    // On the Cornell box's diffuse walls the first vertex of a camera ray decides both, and
    // every estimator starts from the same camera rays.
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let aovs = |integrator| {
        let job = lucent::render::Job {
            scene: Arc::clone(&scene),
            camera,
            settings: settings(integrator, 4, 5),
            window: None,
            aovs: true,
        };
        let snap = lucent::render::RenderSession::new(job, None).expect("valid").wait_until_done();
        snap.aovs.clone().expect("AOVs recorded")
    };
    let path = aovs(Integrator::Path);
    assert!(path.albedo.iter().any(|a| a.max_element() > 0.1), "the path tracer records an albedo");
    for integrator in [Integrator::Bdpt, Integrator::Vcm] {
        let other = aovs(integrator);
        assert_eq!(other.albedo, path.albedo, "{integrator:?}: albedo");
        assert_eq!(other.normal, path.normal, "{integrator:?}: normal");
    }
}

#[test]
fn bdpt_renders_the_same_bits_on_any_number_of_threads() {
    same_bits_on_one_and_two_threads(settings(Integrator::Bdpt, 8, 6));
}

/// The glass box rendered with `s` on one thread and on two: the same bits.
fn same_bits_on_one_and_two_threads(s: Settings) {
    let scene = Arc::new(Scene::build(common::load("cornell-box-glass.gltf")));
    let camera = scene.default_camera(1.0);
    let (one, two) = (common::render(&scene, camera, s, Some(1)), common::render(&scene, camera, s, Some(2)));
    assert_eq!(one.mean, two.mean);
}

#[test]
fn bdpt_refuses_what_it_does_not_simulate() {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let s = Settings { noise_threshold: Some(0.05), ..settings(Integrator::Bdpt, 8, 5) };
    let job = lucent::render::Job { scene, camera, settings: s, window: None, aovs: false };
    let err = lucent::render::RenderSession::new(job, None).err().expect("refused");
    assert!(err.to_string().contains("noise-threshold"), "{err}");
    let deep =
        Settings { max_depth: lucent::integrator::MAX_BIDIRECTIONAL_DEPTH + 1, ..settings(Integrator::Vcm, 8, 5) };
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let job = lucent::render::Job { scene, camera, settings: deep, window: None, aovs: false };
    let err = lucent::render::RenderSession::new(job, None).err().expect("refused");
    assert!(err.to_string().contains("at most 32 bounces (--max-depth 33)"), "{err}");
}

#[test]
fn materials_of_every_kind_stay_finite_under_bdpt() {
    // Glossy, metallic and transmitting materials, lit by an area light and the sky.
    let mut desc = builtin::cornell_box();
    desc.materials.push(Material { metallic: 1.0, roughness: 0.3, ..Material::lambert("metal", Vec3::splat(0.9)) });
    desc.materials.push(Material { transmission: 1.0, roughness: 0.4, ..Material::glass("frosted", 1.5, None) });
    let n = desc.materials.len() as u32;
    desc.meshes.push(uv_sphere(Vec3::new(-0.1, -0.1, 0.0), 0.1, 16, 32, false, n - 2));
    desc.meshes.push(uv_sphere(Vec3::new(0.1, -0.1, 0.1), 0.1, 16, 32, false, n - 1));
    let scene = Arc::new(Scene::build(desc));
    let camera = scene.default_camera(1.0);
    let snap = common::render(&scene, camera, settings(Integrator::Bdpt, 16, 7), None);
    assert_eq!(snap.rejected, 0);
    assert!(snap.mean.iter().all(|p| p.is_finite()));
}

#[test]
fn bdpt_agrees_with_the_path_tracer_under_the_sky_and_a_sun() {
    // Light from infinitely far away, both kinds: the built-in sky (importance-sampled) and a
    // directional light, on rough metal, frosted glass and a diffuse floor.
    use lucent::scene::environment::{EnvSettings, Environment};
    let sun = PunctualLight {
        name: "sun".into(),
        kind: PunctualKind::Directional,
        position: Vec3::ZERO,
        direction: Vec3::new(0.4, -1.0, -0.3).normalize(),
        color: Vec3::new(1.0, 0.9, 0.8),
        intensity: 2.0,
        range: None,
        source: None,
    };
    let desc = SceneDesc {
        name: "outdoors".into(),
        meshes: vec![
            cuboid(Vec3::new(-2.0, -1.1, -2.0), Vec3::new(2.0, -1.0, 2.0), false, 0),
            uv_sphere(Vec3::new(-0.6, -0.4, 0.0), 0.55, 24, 48, false, 1),
            uv_sphere(Vec3::new(0.6, -0.4, 0.0), 0.55, 24, 48, false, 2),
        ],
        materials: vec![
            Material::lambert("floor", Vec3::splat(0.6)),
            Material { metallic: 1.0, roughness: 0.35, ..Material::lambert("metal", Vec3::new(0.9, 0.7, 0.4)) },
            Material { roughness: 0.3, ..Material::glass("frosted", 1.5, None) },
        ],
        lights: vec![sun],
        ..SceneDesc::default()
    };
    let sky = Environment::load(EnvSettings::built_in()).unwrap();
    let scene = Arc::new(Scene::build(desc).with_environment(Some(sky)));
    let camera = Camera::look_at(Vec3::new(0.0, 1.0, 3.5), Vec3::new(0.0, -0.5, 0.0), 0.8);
    agrees_with_the_path_tracer(&scene, camera, 6, "sky and sun");
}

#[test]
fn bdpt_and_vcm_agree_with_the_path_tracer_through_a_dispersive_prism() {
    // A white line seen through flint glass: every wavelength bends its own way, so each path
    // keeps its hero wavelength alone past the prism, on both subpaths.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scenes/prism.gltf");
    let scene = Arc::new(Scene::build(common::load(path)));
    let camera = scene.file_camera(0).expect("the prism's camera");
    agrees_with_the_path_tracer_as(Integrator::Bdpt, &scene, camera, 6, "BDPT, prism");
    agrees_with_the_path_tracer_as(Integrator::Vcm, &scene, camera, 6, "VCM, prism");
}

/// The rainbow scene (docs/scenes/make_rainbow.py) rendered `k` times at 96 x 64, and the
/// light each render adds over the path tracer's image (which has no beam) inside the box
/// the spectrum falls in: per render, the sum of each channel and each channel's mean
/// column, weighted by its light.
fn rainbow_light(settings: Settings, k: u64) -> Vec<(DVec3, DVec3)> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scenes/rainbow.gltf");
    let scene = Arc::new(Scene::build(common::load(path)));
    let camera = scene.file_camera(0).expect("the rainbow's camera");
    let (w, h) = (96, 64);
    let sized = |s: Settings| Settings { width: w, height: h, max_depth: 6, ..s };
    let ambient = common::render(&scene, camera, sized(settings_for(Integrator::Path, 512)), None);
    (1..=k)
        .map(|seed| {
            let snap = common::render(&scene, camera, sized(Settings { seed, ..settings }), None);
            assert_eq!(snap.rejected, 0, "NaN/Inf samples");
            let (mut sum, mut moment) = (DVec3::ZERO, DVec3::ZERO);
            // The spectrum lands around columns 44 to 57 of row 28; the box leaves room.
            for y in 20..38 {
                for x in 30..74 {
                    let i = (y * w + x) as usize;
                    let extra = (snap.mean[i] - ambient.mean[i]).as_dvec3();
                    sum += extra;
                    moment += extra * x as f64;
                }
            }
            (sum, moment / sum)
        })
        .collect()
}

fn settings_for(integrator: Integrator, spp: u32) -> Settings {
    Settings { integrator, target_spp: Some(spp), ..Settings::default() }
}

/// Mean and standard error of `f` over renders.
fn mean_se(renders: &[(DVec3, DVec3)], f: impl Fn(&(DVec3, DVec3)) -> f64) -> (f64, f64) {
    let n = renders.len() as f64;
    let mean = renders.iter().map(&f).sum::<f64>() / n;
    let var = renders.iter().map(|r| (f(r) - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
fn bdpt_throws_the_prisms_rainbow_onto_the_wall_with_the_beams_energy() {
    // A spot light seen only through a prism's delta refractions: the path tracer cannot
    // find it, BDPT's light tracing does. Red bends least: its light lands right of blue's
    // (the beam turns clockwise seen from above, towards -x). Spreading the beam into its
    // spectrum keeps its energy: the same sum as the beam refracted at n_d (--spectral off),
    // to within the sampling error and 3% (the prism's Fresnel transmission and the
    // spectral round trip of white vary by under 1% over the visible range).
    let spectral = rainbow_light(settings_for(Integrator::Bdpt, 32), 8);
    let rgb = rainbow_light(
        Settings { spectral: lucent::integrator::Spectral::Off, ..settings_for(Integrator::Bdpt, 32) },
        8,
    );
    let (split, se) = mean_se(&spectral, |r| r.1.x - r.1.z);
    assert!(split > 6.0 * se && split > 2.0, "red's mean column minus blue's: {split:.2} px (se {se:.2})");
    let (rgb_split, rgb_se) = mean_se(&rgb, |r| r.1.x - r.1.z);
    assert!(rgb_split.abs() < 6.0 * rgb_se + 0.2, "without dispersion no split: {rgb_split:.2} px (se {rgb_se:.2})");
    let (a, se_a) = mean_se(&spectral, |r| r.0.element_sum());
    let (b, se_b) = mean_se(&rgb, |r| r.0.element_sum());
    assert!(
        b > 0.0 && (a - b).abs() < 4.0 * (se_a * se_a + se_b * se_b).sqrt() + 0.03 * b,
        "spectral {a:.3} (se {se_a:.3}), RGB {b:.3} (se {se_b:.3})"
    );
}

#[test]
fn vcm_merges_the_rainbows_light_with_its_energy() {
    // Past the prism each light path keeps its hero wavelength alone, while the camera paths
    // that merge with it (straight onto the wall) keep all of theirs: merged light must count
    // as the hero's alone. At a wide radius merges carry most of the wall's light; the box
    // holds the blurred spectrum, and its sum matches BDPT's.
    let wide = Settings { vcm_radius: 0.01, ..settings_for(Integrator::Vcm, 64) };
    let vcm = rainbow_light(wide, 16);
    let bdpt = rainbow_light(settings_for(Integrator::Bdpt, 32), 8);
    let (a, se_a) = mean_se(&vcm, |r| r.0.element_sum());
    let (b, se_b) = mean_se(&bdpt, |r| r.0.element_sum());
    assert!(
        (a - b).abs() < 4.0 * (se_a * se_a + se_b * se_b).sqrt() + 0.03 * b,
        "VCM {a:.3} (se {se_a:.3}), BDPT {b:.3} (se {se_b:.3})"
    );
}

#[test]
fn light_tracing_does_not_show_the_camera_the_back_of_a_single_sided_surface() {
    // A single-sided slab under a point light, seen from above through its culled top: the
    // camera sees the slab's unlit inside, black. Light tracing reaches the lit top from the
    // light; the camera must not see it there either.
    let light = bulb(Vec3::new(0.0, 2.0, 0.0));
    let slab = Material { double_sided: false, ..Material::lambert("slab", Vec3::splat(0.7)) };
    let desc = SceneDesc {
        meshes: vec![cuboid(Vec3::new(-2.0, -1.1, -2.0), Vec3::new(2.0, -1.0, 2.0), true, 0)],
        materials: vec![slab],
        lights: vec![light],
        ..SceneDesc::default()
    };
    let scene = Arc::new(Scene::build(desc));
    let camera = Camera::look_at(Vec3::new(0.0, 1.0, 1.0), Vec3::new(0.0, -1.0, 0.0), 0.7);
    for integrator in [Integrator::Path, Integrator::Bdpt] {
        let snap = common::render(&scene, camera, settings(integrator, 16, 5), None);
        let total: f32 = snap.mean.iter().map(|p| p.element_sum()).sum();
        assert_eq!(total, 0.0, "{integrator:?} sees light through the culled top");
    }
}

#[test]
fn bdpt_and_vcm_agree_with_the_path_tracer_in_fog_smoke_wax_and_a_spot_lights_beam() {
    // Medium vertices: free flights sampled along every segment of both subpaths, the phase
    // function as their BSDF, transmittance on connections (ratio tracking through the smoke's
    // grid); merging stays at surfaces. The wax's random walk is cut at the same depth as the
    // path tracer's.
    // The spot light hangs inside the fog: light subpaths start in it.
    for name in ["cornell-fog", "cornell-smoke", "cornell-subsurface", "spot-fog"] {
        let path = format!("{}/docs/scenes/{name}.gltf", env!("CARGO_MANIFEST_DIR"));
        let scene = Arc::new(Scene::build(common::load(path)));
        let camera = scene.default_camera(1.0);
        agrees_with_the_path_tracer_as(Integrator::Bdpt, &scene, camera, 8, &format!("BDPT, {name}"));
        agrees_with_the_path_tracer_as(Integrator::Vcm, &scene, camera, 8, &format!("VCM, {name}"));
    }
}

#[test]
fn each_strategy_alone_estimates_the_paths_it_can_make() {
    // Unweighted, the connections with s light vertices estimate every path of depth s - 1
    // and more on their own (s = 0 from depth 0, the camera finding the light; s = 1 from
    // depth 1, as (1, 1) is not a strategy): the path tracer's image to the max depth,
    // minus its image of the shallower depths. Each strategy's contribution and light
    // tracing's splats are checked alone here, apart from the weights.
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let max_depth = 4;
    let path =
        |depth| common::blocks(&common::render(&scene, camera, settings(Integrator::Path, 2048, depth), None), BLOCK);
    let full = path(max_depth);
    let z_max = common::sidak_z(1e-3, 5 * (SIZE / BLOCK).pow(2) as usize * 3);
    for s in 0..=4u32 {
        let shallowest = if s == 0 { 0 } else { (s - 1).max(1) };
        let reference: Vec<(DVec3, DVec3)> = match shallowest {
            0 => full.clone(),
            d => full.iter().zip(path(d - 1)).map(|(a, b)| (a.0 - b.0, a.1 + b.1)).collect(),
        };
        let one = Settings { strategy: Some(s), ..settings(Integrator::Bdpt, 64, max_depth) };
        let blocks = independent_blocks(&scene, camera, one, 12);
        common::assert_block_means_agree(&blocks, &reference, 0..3, 0.0, z_max, &format!("strategy s = {s}"));
    }
}

#[test]
fn the_white_furnace_holds_under_bdpt_and_vcm() {
    // Inside an emitting sphere of Le 0.5 and albedo 0.5, with a white mirror ball and a
    // clear glass ball: radiance 1 - 0.5^(d + 1) everywhere at max depth d (a little less
    // through the balls, whose delta bounces count: 1 - 0.5^(d - 1) at worst).
    let enclosure = Material { emissive: Vec3::splat(0.5), ..Material::lambert("furnace", Vec3::splat(0.5)) };
    let mirror = Material { metallic: 1.0, roughness: 0.0, ..Material::lambert("mirror", Vec3::ONE) };
    let desc = SceneDesc {
        meshes: vec![
            uv_sphere(Vec3::ZERO, 1.0, 24, 48, true, 0),
            uv_sphere(Vec3::new(0.25, 0.0, -0.5), 0.2, 16, 32, false, 1),
            uv_sphere(Vec3::new(-0.25, 0.0, -0.5), 0.2, 16, 32, false, 2),
        ],
        materials: vec![enclosure, mirror, Material::glass("glass", 1.5, Some(Vec3::ZERO))],
        ..SceneDesc::default()
    };
    let scene = Arc::new(Scene::build(desc));
    let camera = Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 0.9);
    let depth = 12;
    let expected = 1.0 - 0.5f64.powi(depth as i32 + 1);
    for integrator in [Integrator::Bdpt, Integrator::Vcm] {
        let s = Settings { width: 24, height: 24, ..settings(integrator, 8, depth) };
        let renders: Vec<(DVec3, DVec3)> = (1..=8)
            .map(|seed| {
                let snap = common::render(&scene, camera, Settings { seed, ..s }, None);
                assert_eq!(snap.rejected, 0, "NaN/Inf samples");
                (common::image_mean(&snap).0, DVec3::ZERO)
            })
            .collect();
        for c in 0..3 {
            let (mean, se) = mean_se(&renders, |r| r.0[c]);
            assert!(
                (mean - expected).abs() < 4.5 * se + 1e-3,
                "{integrator:?} channel {c}: {mean:.5} (se {se:.5}), expected {expected:.5}"
            );
        }
    }
}

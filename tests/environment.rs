//! The environment light: its sampling density against a chi-square test, its orientation
//! and rotation, an exact convex-object furnace under a uniform sky for every sampling
//! switch, and agreement of BSDF sampling, light sampling and MIS under an HDR map.

mod common;

use glam::{UVec2, Vec3};
use lucent::integrator::{Integrator, LightSampling, Settings};
use lucent::math::sampler::Sampler;
use lucent::render::Snapshot;
use lucent::scene::{
    MeshDesc, Scene, SceneDesc,
    camera::Camera,
    environment::{BUILT_IN, EnvSettings, Environment},
    material::Material,
    shapes::uv_sphere,
};
use std::f64::consts::PI;
use std::sync::Arc;

const THETA_BINS: usize = 32;
const PHI_BINS: usize = 64;
/// Midpoints per bin and axis: two per texel of a 1024 x 512 map, whose density is constant
/// per texel, so the expected counts are exact for bins aligned with texels.
const SUB: usize = 32;
const SAMPLES: usize = 400_000;

/// The built-in sky (Poly Haven's venice_sunset, 1024 x 512) turned by `rotation` degrees.
fn sky(rotation: f32) -> Environment {
    let map = Some(BUILT_IN.into());
    Environment::load(EnvSettings { map, rotation, ..EnvSettings::default() }).expect("the built-in map loads")
}

/// World direction of polar angle `theta` from +y and azimuth `phi` from -z towards +x.
fn direction(theta: f64, phi: f64) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    Vec3::new((st * phi.sin()) as f32, ct as f32, (-st * phi.cos()) as f32)
}

#[test]
fn the_map_density_passes_a_chi_square_test() {
    // Rotations by a multiple of the texel width keep texels aligned with the bins.
    let rotations = [0.0, 90.0, -45.0];
    let alpha = common::sidak_alpha(0.01, rotations.len());
    for rotation in rotations {
        let env = sky(rotation);
        let (dt, dp) = (PI / THETA_BINS as f64, 2.0 * PI / PHI_BINS as f64);
        let bins = THETA_BINS * PHI_BINS;
        let mut observed = vec![0.0f64; bins + 1];
        let mut sampler = Sampler::new(UVec2::new(3, 5), 0, 17);
        let mut mismatched = 0;
        for _ in 0..SAMPLES {
            match env.sample(sampler.next_2d()) {
                Some((d, le, pdf)) => {
                    assert!((d.length() - 1.0).abs() < 1e-5 && pdf > 0.0 && le.is_finite(), "{d} {pdf}");
                    mismatched += ((env.pdf(d) - pdf).abs() > 1e-3 * pdf) as usize;
                    let theta = (d.y as f64).clamp(-1.0, 1.0).acos();
                    let phi = (d.x as f64).atan2(-d.z as f64).rem_euclid(2.0 * PI);
                    let (i, j) = (((theta / dt) as usize).min(THETA_BINS - 1), ((phi / dp) as usize).min(PHI_BINS - 1));
                    observed[i * PHI_BINS + j] += 1.0;
                }
                None => observed[bins] += 1.0,
            }
        }
        // Rounding may put a sample on a texel edge into its neighbour; that is all it may do.
        assert!(mismatched * 1000 < SAMPLES, "rotated {rotation}: {mismatched} samples whose pdf disagrees with pdf()");
        let expected = common::expected_counts((THETA_BINS, PHI_BINS), (dt, dp), SUB, SAMPLES, |theta, phi| {
            env.pdf(direction(theta, phi)) as f64
        });
        let total: f64 = expected[..bins].iter().sum();
        assert!(
            (total / SAMPLES as f64 - 1.0).abs() < 1e-3,
            "rotated {rotation}: the density integrates to {}",
            total / SAMPLES as f64
        );
        let p = common::chi2_p_value(&observed, &expected);
        assert!(p > alpha, "rotated {rotation}: chi-square p = {p:.2e}");
    }
}

#[test]
fn the_map_centre_is_seen_along_minus_z_with_the_sky_up_and_rotation_turns_it() {
    // An 8 x 4 map: top half sky blue, bottom half ground brown, the right half (u > 1/2)
    // with extra red. Written as EXR and read back through the loader.
    let (w, h) = (8u32, 4u32);
    let mut data = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let base = if y < h / 2 { [0.2, 0.4, 1.0] } else { [0.3, 0.2, 0.1] };
            let red = if x >= w / 2 { 1.0 } else { 0.0 };
            data.extend([base[0] + red, base[1], base[2]]);
        }
    }
    let dir = common::scratch("env");
    let path = dir.join("quadrants.exr");
    image::Rgb32FImage::from_raw(w, h, data).unwrap().save(&path).unwrap();
    let load = |rotation: f32| {
        Environment::load(EnvSettings { map: Some(path.clone()), rotation, ..EnvSettings::default() }).unwrap()
    };
    let env = load(0.0);
    let up = env.radiance(Vec3::Y).to_rgb();
    assert!((up - Vec3::new(0.7, 0.4, 1.0)).length() < 1e-6, "straight up: sky, u wrapping: {up}");
    assert_eq!(env.radiance(Vec3::NEG_Y).to_rgb().y, 0.2, "straight down: ground");
    assert!(env.radiance(Vec3::new(1.0, 0.3, 0.0).normalize()).to_rgb().x > 1.0, "+x (right of -z) is u = 3/4");
    assert!(env.radiance(Vec3::new(-1.0, 0.3, 0.0).normalize()).to_rgb().x < 0.3, "-x is u = 1/4");
    let turned = load(180.0);
    assert!(turned.radiance(Vec3::new(-1.0, 0.3, 0.0).normalize()).to_rgb().x > 1.0, "rotating by 180 swaps sides");
    let scaled = Environment::load(EnvSettings { map: Some(path.clone()), intensity: 3.0, ..EnvSettings::default() });
    assert!((scaled.unwrap().radiance(Vec3::NEG_Y).to_rgb().y - 0.6).abs() < 1e-6);
}

#[test]
fn a_bad_map_is_a_one_line_error() {
    let missing = EnvSettings { map: Some("/no/such/sky.hdr".into()), ..EnvSettings::default() };
    let err = Environment::load(missing).err().unwrap();
    assert!(err.contains("/no/such/sky.hdr") && !err.contains('\n'), "{err}");
    let negative = EnvSettings { intensity: -1.0, background: Vec3::ONE, ..EnvSettings::default() };
    assert!(Environment::load(negative).err().unwrap().contains("intensity"));
    // A FIFO blocked the read forever (a view file can name one); it is refused first.
    let dir = common::scratch("env-fifo");
    let fifo = dir.join("sky.hdr");
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let err = Environment::load(EnvSettings { map: Some(fifo), ..EnvSettings::default() }).err().unwrap();
    assert!(err.contains("sky.hdr: not a regular file"), "{err}");
}

#[test]
fn a_convex_lambertian_under_a_uniform_sky_reflects_albedo_times_sky() {
    // A flat-shaded convex polyhedron sees only the sky: L = albedo x background, exactly,
    // for every way of sampling (BSDF, light, MIS; path tracing and DRT).
    let sky = Vec3::new(0.6, 0.8, 1.0);
    let mut sphere = uv_sphere(Vec3::ZERO, 1.0, 16, 32, false, 0);
    sphere.normals = None;
    let desc = SceneDesc {
        name: "convex".into(),
        meshes: vec![sphere],
        materials: vec![Material::lambert("white", Vec3::splat(0.5))],
        ..SceneDesc::default()
    };
    let env = Environment::load(EnvSettings { background: sky, ..EnvSettings::default() }).unwrap();
    let scene = Arc::new(Scene::build(desc).with_environment(Some(env)));
    assert!(scene.features.environment && scene.light_sampler.environment_pmf() == 1.0);
    // The whole image lies inside the silhouette.
    let camera = Camera::look_at(Vec3::new(0.3, 0.5, 3.0), Vec3::ZERO, 0.2);
    let base =
        Settings { width: 24, height: 24, max_depth: 3, branching: 4, target_spp: Some(32), ..Settings::default() };
    let drt = Settings {
        integrator: Integrator::Distribution,
        importance_sampling: true,
        light_sampling: LightSampling::Mis,
        ..base
    };
    let cases: Vec<(String, Settings)> =
        common::switches(base).chain([("importance true, lights Mis".into(), drt)]).collect();
    let z_max = common::sidak_z(1e-3, cases.len() * 3);
    for (label, settings) in cases {
        let snap = common::render(&scene, camera, settings, None);
        assert_eq!(snap.rejected, 0);
        // Cosine sampling of a uniform sky has zero variance: then the mean must be exact.
        let (mean, se) = common::image_mean(&snap);
        for c in 0..3 {
            let label = format!("{:?}, {label}, channel {c}", settings.integrator);
            common::assert_within(mean[c], se[c], 0.5 * sky[c] as f64, z_max, &label);
        }
    }
}

#[test]
fn bsdf_sampling_light_sampling_and_mis_agree_under_an_hdr_sky() {
    // A glossy sphere on a diffuse ground under the sunset map: the three estimators of
    // the same integral must agree within their combined standard errors, and MIS must
    // not be noisier than the worse of the two it combines.
    let ground = MeshDesc {
        name: "ground".into(),
        positions: vec![
            Vec3::new(-4.0, 0.0, -4.0),
            Vec3::new(4.0, 0.0, -4.0),
            Vec3::new(4.0, 0.0, 4.0),
            Vec3::new(-4.0, 0.0, 4.0),
        ],
        indices: vec![0, 2, 1, 0, 3, 2],
        material: 0,
        ..MeshDesc::default()
    };
    let glossy = Material { metallic: 1.0, roughness: 0.35, ..Material::lambert("gold", Vec3::new(0.9, 0.7, 0.3)) };
    let desc = SceneDesc {
        name: "sphere on ground".into(),
        meshes: vec![ground, uv_sphere(Vec3::new(0.0, 1.0, 0.0), 1.0, 32, 64, false, 1)],
        materials: vec![Material::lambert("ground", Vec3::splat(0.5)), glossy],
        ..SceneDesc::default()
    };
    let scene = Arc::new(Scene::build(desc).with_environment(Some(sky(0.0))));
    let camera = Camera::look_at(Vec3::new(0.0, 2.0, 5.0), Vec3::new(0.0, 0.8, 0.0), 0.8);
    let run = |lights| {
        let settings = Settings {
            width: 32,
            height: 32,
            max_depth: 4,
            light_sampling: lights,
            target_spp: Some(128),
            ..Settings::default()
        };
        let snap = common::render(&scene, camera, settings, None);
        assert_eq!(snap.rejected, 0, "{lights:?}: NaN/Inf samples");
        snap
    };
    let (off, explicit, mis) = (run(LightSampling::Off), run(LightSampling::Explicit), run(LightSampling::Mis));
    let z_max = common::sidak_z(1e-3, 6);
    // Each image as one block.
    let whole = |s: &Snapshot| common::blocks(s, 32);
    for (label, other) in [("BSDF sampling vs MIS", &off), ("light sampling vs MIS", &explicit)] {
        common::assert_block_means_agree(&whole(other), &whole(&mis), 0..3, 0.0, z_max, label);
    }
    let se = |s: &Snapshot| common::image_mean(s).1;
    let (off, explicit, mis) = (se(&off), se(&explicit), se(&mis));
    for c in 0..3 {
        assert!(mis[c] <= off[c].max(explicit[c]), "MIS se {} vs {} / {}", mis[c], off[c], explicit[c]);
    }
}

#[test]
fn a_truncated_map_is_called_truncated_and_named() {
    let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/venice_sunset_1k.hdr")).unwrap();
    let dir = common::scratch("env");
    let path = dir.join("cut.hdr");
    std::fs::write(&path, &bytes[..bytes.len() / 3]).unwrap();
    let err =
        Environment::load(EnvSettings { map: Some(path.clone()), ..EnvSettings::default() }).err().expect("refused");
    let want = format!(
        "cannot load environment {}: truncated: the file ends after {} bytes, before the 1024x512 texels its header announces",
        path.display(),
        bytes.len() / 3
    );
    assert_eq!(err, want);
}

#[test]
fn a_scene_without_light_of_its_own_is_lit_by_the_built_in_sky_unless_kept_dark() {
    use lucent::open::{OpenOptions, open};
    let assets = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/assets");
    let lit_by_sky = |path: Option<&std::path::Path>, keep_dark: bool| {
        let scene = open(path, &OpenOptions { keep_dark, ..OpenOptions::default() }, &mut |_| {}).expect("opens");
        let sky = scene.environment.as_ref().map(|e| e.settings.clone());
        let said = scene.warnings.iter().any(|w| w.contains("no light of its own"));
        assert_eq!(sky.is_some(), said, "the sky is added exactly when it is said");
        sky.map(|s| assert_eq!(s, EnvSettings::built_in())).is_some()
    };
    let unlit = assets.join("Box/glTF-Binary/Box.glb");
    assert!(lit_by_sky(Some(&unlit), false), "a model without lights gets the sky");
    assert!(!lit_by_sky(Some(&unlit), true), "unless asked to stay dark");
    assert!(!lit_by_sky(None, false), "the Cornell box's lamp is a light of its own");
    let lamp = assets.join("LightsPunctualLamp/glTF/LightsPunctualLamp.gltf");
    assert!(!lit_by_sky(Some(&lamp), false), "punctual lights are lights of its own");
    let emissive = assets.join("EmissiveStrengthTest/glTF-Binary/EmissiveStrengthTest.glb");
    assert!(!lit_by_sky(Some(&emissive), false), "untextured emission is a lamp");
}

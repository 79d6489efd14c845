//! Spectral transport: the wavelength sampler against its pdf (chi-square), the RGB
//! upsampling's round trip and bounds, a spectral white furnace, agreement with the RGB
//! kernel where the two must agree exactly in expectation (white light, one colour per
//! path), the kernel chosen on demand, and determinism across thread counts.

mod common;

use glam::{UVec2, Vec3};
use lucent::integrator::{Settings, Spectral, is_spectral};
use lucent::loader::builtin;
use lucent::math::sampler::Sampler;
use lucent::scene::{
    Scene, SceneDesc,
    camera::Camera,
    environment::{EnvSettings, Environment},
    material::Material,
    shapes,
};
use lucent::spectrum::{
    cie::{LAMBDA_MAX, LAMBDA_MIN},
    sampled::{Sampled, sample_visible, visible_pdf},
};
use std::sync::Arc;

#[test]
fn sampled_wavelengths_follow_their_pdf() {
    let bins = 47;
    let n = 200_000;
    let width = (LAMBDA_MAX - LAMBDA_MIN) as f64 / bins as f64;
    let mut observed = vec![0.0f64; bins];
    let mut sampler = Sampler::new(UVec2::new(1, 2), 3, 4);
    for _ in 0..n {
        let s = Sampled::new(sampler.next_1d());
        for &l in &s.lambda {
            observed[(((l - LAMBDA_MIN) as f64 / width) as usize).min(bins - 1)] += 1.0;
        }
    }
    let expected: Vec<f64> = (0..bins)
        .map(|b| {
            let sub = 64;
            let integral: f64 = (0..sub)
                .map(|k| {
                    let l = LAMBDA_MIN as f64 + (b as f64 + (k as f64 + 0.5) / sub as f64) * width;
                    visible_pdf(l as f32) as f64 * width / sub as f64
                })
                .sum();
            integral * (3 * n) as f64
        })
        .collect();
    let p = common::chi2_p_value(&observed, &expected);
    assert!(p > 1e-3, "chi-square p = {p:e}");
    // A wrong density is rejected: the same samples against a uniform one.
    let uniform = vec![(3 * n) as f64 / bins as f64; bins];
    assert!(common::chi2_p_value(&observed, &uniform) < 1e-6);
    assert!(sample_visible(0.0) >= LAMBDA_MIN && sample_visible(0.999_999) <= LAMBDA_MAX);
}

/// The linear sRGB that the spectrum of `rgb` has under D65, by quadrature over the
/// sampling variable (each node is one path's three wavelengths).
fn round_trip(rgb: Vec3) -> Vec3 {
    let n = 20_000;
    (0..n)
        .map(|i| {
            let s = Sampled::new((i as f32 + 0.5) / n as f32);
            s.to_rgb(s.illuminant(rgb))
        })
        .sum::<Vec3>()
        / n as f32
}

/// Test colours: black, white, greys, the primaries and secondaries, and a spread of others.
fn test_colours() -> Vec<Vec3> {
    let mut colours = vec![Vec3::ZERO, Vec3::ONE, Vec3::splat(0.18), Vec3::splat(0.5)];
    for i in 0..3 {
        let mut c = Vec3::ZERO;
        c[i] = 1.0;
        colours.extend([c, Vec3::ONE - c]);
    }
    let mut sampler = Sampler::new(UVec2::new(7, 7), 0, 9);
    colours.extend((0..20).map(|_| Vec3::new(sampler.next_1d(), sampler.next_1d(), sampler.next_1d())));
    colours
}

#[test]
fn upsampled_colours_round_trip_stay_in_range_and_white_is_one() {
    let mut worst = 0.0f32;
    for c in test_colours() {
        let back = round_trip(c);
        worst = worst.max((back - c).abs().max_element());
        for i in 0..200 {
            let s = Sampled::new((i as f32 + 0.5) / 200.0);
            let r = s.reflectance(c);
            for k in 0..3 {
                assert!((-2e-4..=1.0 + 2e-4).contains(&r.get(k)), "{c} at {} nm: {}", s.lambda[k], r.get(k));
            }
            if c == Vec3::ONE {
                assert!((r.to_rgb() - Vec3::ONE).abs().max_element() < 1e-5, "white is 1: {r:?}");
            }
        }
    }
    // The stated round-trip error (README): below 1e-3 for every test colour.
    assert!(worst < 1e-3, "worst round-trip error {worst}");
}

/// A closed sphere whose inside emits `le` and reflects `albedo` (grey): L = le / (1 - albedo).
fn furnace(le: f32, albedo: f32) -> Arc<Scene> {
    let mut sphere = shapes::uv_sphere(Vec3::ZERO, 1.0, 12, 24, true, 0);
    sphere.normals = None;
    let wall = Material { emissive: Vec3::splat(le), ..Material::lambert("wall", Vec3::splat(albedo)) };
    Arc::new(Scene::build(SceneDesc { meshes: vec![sphere], materials: vec![wall], ..SceneDesc::default() }))
}

#[test]
fn a_spectral_white_furnace_returns_one() {
    let scene = furnace(0.5, 0.5);
    let camera = Camera::look_at(Vec3::ZERO, Vec3::new(0.3, 0.1, -1.0), 1.2);
    let settings = Settings {
        width: 16,
        height: 16,
        max_depth: u32::MAX,
        spectral: Spectral::On,
        target_spp: Some(64),
        ..Settings::default()
    };
    assert!(is_spectral(&scene, &settings));
    let snap = common::render(&scene, camera, settings, None);
    let z_max = common::sidak_z(1e-3, 3);
    let (mean, se) = common::image_mean(&snap);
    for c in 0..3 {
        common::assert_within(mean[c], se[c], 1.0, z_max, &format!("channel {c}"));
    }
    // Every wavelength of a path carries the same throughput: a white wall reflects 1/2 of
    // each, exactly.
    let s = Sampled::new(0.37);
    assert_eq!(s.reflectance(Vec3::splat(0.5)) * 2.0, s.reflectance(Vec3::ONE));
}

/// The Cornell box with its lamp made white, seen directly and with one bounce: each path
/// carries at most one colour, so spectral and RGB agree exactly in expectation.
fn white_lamp_cornell() -> Arc<Scene> {
    let mut desc = builtin::cornell_box();
    for m in &mut desc.materials {
        if m.is_emissive() {
            m.emissive = Vec3::splat(m.emissive.max_element());
        }
    }
    Arc::new(Scene::build(desc))
}

/// Renders `scene` by the RGB and the spectral kernel, one bounce, `spp` samples per pixel
/// (seeds `seed` and `seed + 1`), and asserts their 8x8 blocks agree (z-tests, Sidak).
fn assert_rgb_and_spectral_agree(scene: &Arc<Scene>, spp: u32, seed: u64, label: &str) {
    let camera = scene.default_camera(1.0);
    let settings = |spectral, seed| Settings {
        width: 48,
        height: 48,
        max_depth: 1,
        spectral,
        seed,
        target_spp: Some(spp),
        ..Settings::default()
    };
    let z_max = common::sidak_z(1e-3, 3 * 36);
    let rgb = common::render(scene, camera, settings(Spectral::Off, seed), None);
    let spectral = common::render(scene, camera, settings(Spectral::On, seed + 1), None);
    common::assert_blocks_agree(&spectral, &rgb, 8, z_max, label);
}

#[test]
fn spectral_and_rgb_agree_where_each_path_carries_one_colour() {
    assert_rgb_and_spectral_agree(&white_lamp_cornell(), 256, 1, "Cornell box, white lamp, direct light");
}

#[test]
fn a_textured_model_under_a_white_sky_agrees_in_rgb_and_spectral() {
    let desc = common::load("BoxTextured/glTF-Binary/BoxTextured.glb");
    let white = Environment::load(EnvSettings { background: Vec3::ONE, ..EnvSettings::default() }).unwrap();
    let scene = Arc::new(Scene::build(desc).with_environment(Some(white)));
    assert!(scene.features.textures);
    assert_rgb_and_spectral_agree(&scene, 128, 3, "BoxTextured under a white sky, one bounce");
}

#[test]
fn the_spectral_kernel_runs_on_demand_and_is_deterministic_across_thread_counts() {
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let auto = Settings::default();
    assert!(!is_spectral(&scene, &auto), "no dispersive material: RGB");
    let mut glass = builtin::cornell_box();
    glass.materials.push(Material {
        dispersion: 1.0,
        ..Material::dielectric("flint", 1.7, Some(lucent::medium::Volume::absorbing(Vec3::ZERO)))
    });
    let id = glass.materials.len() as u32 - 1;
    glass.meshes.push(shapes::uv_sphere(Vec3::new(0.0, 0.3, 0.0), 0.15, 12, 24, false, id));
    let glass = Arc::new(Scene::build(glass));
    assert!(glass.features.dispersion && is_spectral(&glass, &auto));
    assert!(!is_spectral(&glass, &Settings { spectral: Spectral::Off, ..auto }));
    let settings = Settings { width: 24, height: 24, target_spp: Some(8), ..auto };
    let camera = glass.default_camera(1.0);
    let one = common::render(&glass, camera, settings, Some(1));
    let two = common::render(&glass, camera, settings, Some(2));
    assert_eq!(one.mean, two.mean, "the same bits on 1 and 2 threads");
    assert_eq!(one.rejected, 0);
}

/// The prism experiment: a right-angle prism whose first face (z = -1) is square to the
/// camera's axis and whose second leans by `APEX`, thicker towards -x; a thin white emissive
/// line far behind it, where the view through the prism lands; nothing else.
const APEX: f32 = std::f32::consts::FRAC_PI_6;
const N_D: f32 = 1.6;
const LINE_Z: f32 = -6.0;
const LINE_HALF_WIDTH: f32 = 0.004;
const WIDTH: u32 = 160;
const HEIGHT: u32 = 4;

fn prism_camera() -> Camera {
    let yfov = 2.0 * (0.15f32.tan() / (WIDTH as f32 / HEIGHT as f32)).atan();
    Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), yfov)
}

/// Outward unit normal of the leaning face, and a point on it.
fn second_face() -> (Vec3, Vec3) {
    (Vec3::new(APEX.sin(), 0.0, -APEX.cos()), Vec3::new(0.5, 0.0, -1.0))
}

fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    // d arrives against n; eta = n_incident / n_transmitted.
    let cos_i = -d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    (k >= 0.0).then(|| eta * d + (eta * cos_i - k.sqrt()) * n)
}

/// Where the camera ray `d` meets the line's plane through the prism at index `n`, and the
/// two faces' Fresnel transmittance, by Snell's law.
fn through_prism(d: Vec3, n: f32) -> Option<(Vec3, f32)> {
    let (normal, point) = second_face();
    let p1 = d * (-1.0 / d.z);
    if p1.x.abs() > 0.5 || p1.y.abs() > 0.5 {
        return None;
    }
    let t1 = 1.0 - lucent::bsdf::microfacet::fresnel_dielectric(-d.z, n);
    let inside = refract(d, Vec3::Z, 1.0 / n)?;
    let p2 = p1 + inside * ((point - p1).dot(normal) / inside.dot(normal));
    let cos2 = inside.dot(normal);
    let t2 = 1.0 - lucent::bsdf::microfacet::fresnel_dielectric(-cos2, n);
    let out = refract(inside, -normal, n)?;
    Some((p2 + out * ((LINE_Z - p2.z) / out.z), t1 * t2))
}

/// The line's x: where the centre pixel's ray lands at n_d.
fn line_x() -> f32 {
    let ray = prism_camera().rays(WIDTH, HEIGHT).ray(glam::Vec2::new(WIDTH as f32 / 2.0, HEIGHT as f32 / 2.0));
    through_prism(ray.d, N_D).unwrap().0.x
}

fn prism_scene(dispersion: f32) -> Arc<Scene> {
    let (t, x) = (APEX.tan(), line_x());
    let corners = |y: f32| [Vec3::new(-0.5, y, -1.0), Vec3::new(0.5, y, -1.0), Vec3::new(-0.5, y, -1.0 - t)];
    let (lo, hi) = (corners(-0.5), corners(0.5));
    let tris = [
        [lo[0], lo[2], lo[1]],
        [hi[0], hi[1], hi[2]],
        [lo[0], lo[1], hi[1]],
        [lo[0], hi[1], hi[0]],
        [lo[1], lo[2], hi[2]],
        [lo[1], hi[2], hi[1]],
        [lo[2], lo[0], hi[0]],
        [lo[2], hi[0], hi[2]],
    ];
    let mesh = |tris: &[[Vec3; 3]], material| lucent::scene::MeshDesc {
        positions: tris.iter().flatten().copied().collect(),
        indices: (0..3 * tris.len() as u32).collect(),
        material,
        ..Default::default()
    };
    let (a, b) = (x - LINE_HALF_WIDTH, x + LINE_HALF_WIDTH);
    let line = [
        [Vec3::new(a, -3.0, LINE_Z), Vec3::new(b, -3.0, LINE_Z), Vec3::new(b, 3.0, LINE_Z)],
        [Vec3::new(a, -3.0, LINE_Z), Vec3::new(b, 3.0, LINE_Z), Vec3::new(a, 3.0, LINE_Z)],
    ];
    let glass = Material {
        dispersion,
        ..Material::dielectric("flint", N_D, Some(lucent::medium::Volume::absorbing(Vec3::ZERO)))
    };
    let lamp = Material { emissive: Vec3::ONE, ..Material::lambert("line", Vec3::ZERO) };
    let desc = SceneDesc {
        meshes: vec![mesh(&tris, 0), mesh(&line, 1)],
        materials: vec![glass, lamp],
        ..SceneDesc::default()
    };
    let scene = Scene::build(desc);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    Arc::new(scene)
}

/// The image Snell's law predicts, per column and channel: each pixel integrated over 16
/// positions across it (the line is vertical) and 1 nm steps, with the film's response
/// (linear sRGB of the CIE matching functions under D65).
fn predicted(dispersion: f32) -> Vec<Vec3> {
    use lucent::spectrum::sampled::{cmf, d65};
    use lucent::spectrum::upsample::{CMF_Y, XYZ_TO_RGB};
    let m = glam::Mat3::from_cols_array_2d(&XYZ_TO_RGB).transpose();
    // KHR_materials_dispersion: V_d = 20 / dispersion.
    let index = |lambda: f32| {
        if dispersion == 0.0 {
            return N_D;
        }
        (N_D + (N_D - 1.0) * dispersion / 20.0 * (523_655.0 / (lambda * lambda) - 1.5168)).max(1.0)
    };
    let (rays, x) = (prism_camera().rays(WIDTH, HEIGHT), line_x());
    let sub = 16;
    (0..WIDTH)
        .map(|u| {
            let mut sum = Vec3::ZERO;
            for s in 0..sub {
                let d = rays.ray(glam::Vec2::new(u as f32 + (s as f32 + 0.5) / sub as f32, HEIGHT as f32 / 2.0)).d;
                for l in 360..=830 {
                    let lambda = l as f32;
                    if let Some((p, t)) = through_prism(d, index(lambda))
                        && (p.x - x).abs() <= LINE_HALF_WIDTH
                    {
                        sum += m * cmf(lambda) * (d65(lambda) * t / CMF_Y);
                    }
                }
            }
            sum / sub as f32
        })
        .collect()
}

/// Per channel: the centroid column of `columns` (signed weights), and the total.
fn centroid(columns: &[Vec3], c: usize) -> (f64, f64) {
    let total: f64 = columns.iter().map(|v| v[c] as f64).sum();
    let moment: f64 = columns.iter().enumerate().map(|(u, v)| (u as f64 + 0.5) * v[c] as f64).sum();
    (moment / total, total)
}

/// The rendered image summed over rows: per column, its mean and variance.
fn columns(s: &lucent::render::Snapshot) -> (Vec<Vec3>, Vec<Vec3>) {
    let (mut mean, mut var) = (vec![Vec3::ZERO; s.width as usize], vec![Vec3::ZERO; s.width as usize]);
    for y in 0..s.height as usize {
        for x in 0..s.width as usize {
            mean[x] += s.mean[y * s.width as usize + x] / s.height as f32;
            var[x] += s.variance[y * s.width as usize + x] / (s.height * s.height) as f32;
        }
    }
    (mean, var)
}

/// Standard error of a centroid (delta method on independent columns).
fn centroid_se(mean: &[Vec3], var: &[Vec3], c: usize) -> f64 {
    let (k, total) = centroid(mean, c);
    var.iter().enumerate().map(|(u, v)| ((u as f64 + 0.5 - k) / total).powi(2) * v[c] as f64).sum::<f64>().sqrt()
}

#[test]
fn a_prism_bends_blue_more_than_red_by_the_angle_snells_law_predicts() {
    let camera = prism_camera();
    let settings = Settings { width: WIDTH, height: HEIGHT, target_spp: Some(2048), ..Settings::default() };
    let z = common::sidak_z(1e-3, 3 + 3 + 2 + 1);
    let mut totals = Vec::new();
    for dispersion in [0.0f32, 1.0] {
        let scene = prism_scene(dispersion);
        assert_eq!(scene.features.dispersion, dispersion > 0.0);
        let snap = common::render(&scene, camera, settings, None);
        assert_eq!(snap.rejected, 0);
        let (mean, var) = columns(&snap);
        let model = predicted(dispersion);
        for c in 0..3 {
            let (rendered, predicted) = (centroid(&mean, c).0, centroid(&model, c).0);
            // Noise, plus the model's quadrature (1/16 pixel across, 1 nm).
            let tolerance = z * centroid_se(&mean, &var, c) + 1.0 / 16.0;
            assert!(
                (rendered - predicted).abs() < tolerance,
                "dispersion {dispersion}, channel {c}: centroid {rendered:.3} against Snell's {predicted:.3} (within {tolerance:.3})"
            );
        }
        let (r, b) = (centroid(&model, 0).0, centroid(&model, 2).0);
        if dispersion > 0.0 {
            // Blue (higher index) bends further towards the thick side, -x: it appears at
            // larger columns than red, by several pixels.
            assert!(b - r > 4.0, "Snell's law predicts blue {b:.2} vs red {r:.2}");
        } else {
            let (g, se) = (centroid(&mean, 1).0, centroid_se(&mean, &var, 1));
            for c in [0, 2] {
                let k = centroid(&mean, c).0;
                let tolerance = z * (se + centroid_se(&mean, &var, c));
                assert!((k - g).abs() < tolerance, "without dispersion channel {c} sits at {k:.3}, green at {g:.3}");
            }
            assert!((b - r).abs() < 0.05, "one index: the model's channels coincide ({r:.3}, {b:.3})");
        }
        let total: f64 = (0..3).map(|c| centroid(&mean, c).1).sum();
        let se: f64 = var.iter().map(|v| v.element_sum() as f64).sum::<f64>().sqrt();
        let expected: f64 = (0..3).map(|c| centroid(&model, c).1).sum();
        totals.push((total, se, expected));
    }
    let ((a, sa, ea), (b, sb, eb)) = (totals[0], totals[1]);
    let tolerance = z * (sa * sa + sb * sb).sqrt() + (ea - eb).abs();
    assert!((a - b).abs() < tolerance, "total light with dispersion {a:.5}, without {b:.5} (within {tolerance:.5})");
}

#[test]
fn dispersion_is_read_from_gltf_and_bad_values_are_refused_with_a_warning() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scenes/prism.gltf")).unwrap();
    let load = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
        let flint = json["materials"].as_array_mut().unwrap().iter_mut().find(|m| m["name"] == "flint").unwrap();
        edit(flint);
        lucent::loader::gltf::load_slice(json.to_string().as_bytes(), "prism").unwrap()
    };
    let flint = |desc: &SceneDesc| desc.materials.iter().find(|m| m.name == "flint").unwrap().clone();
    let good = load(&|_| {});
    assert_eq!(flint(&good).dispersion, 1.0);
    assert!(flint(&good).is_dispersive() && good.warnings.is_empty(), "{:?}", good.warnings);
    // n(lambda) from the extension's formula: at 587.6 nm (the d line) it is n_d.
    assert!((flint(&good).ior_at(587.56) - 1.7).abs() < 1e-3);
    assert!(flint(&good).ior_at(450.0) > flint(&good).ior_at(650.0));
    let negative = load(&|m| m["extensions"]["KHR_materials_dispersion"]["dispersion"] = serde_json::json!(-3.0));
    assert_eq!(flint(&negative).dispersion, 0.0);
    assert!(
        negative.warnings.iter().any(|w| w.contains("\"flint\"") && w.contains("dispersion -3")),
        "{:?}",
        negative.warnings
    );
    let thin = load(&|m| {
        m["extensions"].as_object_mut().unwrap().remove("KHR_materials_volume");
    });
    assert!(!flint(&thin).is_dispersive());
    assert!(
        thin.warnings.iter().any(|w| w.contains("\"flint\"") && w.contains("KHR_materials_volume")),
        "{:?}",
        thin.warnings
    );
    let scene = Arc::new(Scene::build(thin));
    assert!(!scene.features.dispersion, "a thin wall needs no spectral kernel");
}

//! Lights against their closed forms: a KHR_lights_punctual spot light of a fifth of a
//! degree seen on a facing Lambertian wall, pixel block by pixel block; and every kind's
//! rays leaving it (`Light::sample_le`) carrying its power, with the densities `pdf_le`
//! reports.

mod common;

use glam::{DVec3, Vec2, Vec3};
use lucent::integrator::Settings;
use lucent::scene::light::{Cone, Light, PunctualKind, PunctualLight, TriangleLight};
use lucent::scene::{Scene, SceneDesc, camera::Camera, material::Material, shapes::cuboid};
use std::f64::consts::PI;
use std::sync::Arc;

#[test]
fn a_fifth_of_a_degree_spot_lights_a_facing_wall_with_its_full_intensity() {
    let (inner, outer) = (0.1f64.to_radians(), 0.2f64.to_radians());
    let (intensity, albedo, distance) = (3.0f64, 0.8f64, 1.0f64);
    // The wall's front face is the plane z = -1/4, facing the light.
    let wall_z = -0.25;
    let light = DVec3::new(0.0, 0.0, wall_z + distance);
    let spot = PunctualLight {
        name: "spot".into(),
        kind: PunctualKind::Spot(Cone::new(inner as f32, outer as f32)),
        position: light.as_vec3(),
        direction: -Vec3::Z,
        color: Vec3::ONE,
        intensity: intensity as f32,
        range: None,
        source: None,
    };
    let wall = cuboid(Vec3::new(-1.0, -1.0, wall_z as f32 - 0.1), Vec3::new(1.0, 1.0, wall_z as f32), false, 0);
    let scene = Arc::new(Scene::build(SceneDesc {
        name: "spot".into(),
        meshes: vec![wall],
        materials: vec![Material::lambert("wall", Vec3::splat(albedo as f32))],
        lights: vec![spot],
        ..SceneDesc::default()
    }));
    // Seen from the light itself, the frame spans 1.25 times the outer cone: the inner disc
    // (which holds the four central 8 x 8 blocks), the ramp between the cones, dark corners.
    let half = 1.25 * outer.tan();
    let camera = Camera::look_at(light.as_vec3(), Vec3::new(0.0, 0.0, wall_z as f32), (2.0 * half.atan()) as f32);
    let size = 64;
    let settings = Settings { width: size, height: size, target_spp: Some(64), seed: 3, ..Settings::default() };
    let snap = common::render(&scene, camera, settings, None);

    // Radiance at wall point p: albedo / pi times the irradiance I f(theta) cos / r^2 of
    // KHR_lights_punctual's falloff f (1 inside the inner cone, the squared ramp in cos
    // between the cones, 0 outside), for the angle theta off the axis; cos = d / r.
    let (cos_inner, cos_outer) = (inner.cos(), outer.cos());
    let radiance = |p: DVec3| {
        let to = p - light;
        let r = to.length();
        let cos = -to.z / r;
        let t = ((cos - cos_outer) / (cos_inner - cos_outer)).clamp(0.0, 1.0);
        albedo / PI * intensity * t * t * cos / (r * r)
    };
    // Each pixel's expected value: the radiance averaged over its area (box filter), by the
    // midpoint rule on 16 x 16 points.
    let rays = camera.rays(size, size);
    let sub = 16;
    let expected: Vec<f64> = (0..size * size)
        .map(|i| {
            let (x, y) = ((i % size) as f32, (i / size) as f32);
            let mut sum = 0.0;
            for a in 0..sub {
                for b in 0..sub {
                    let film = Vec2::new(x + (a as f32 + 0.5) / sub as f32, y + (b as f32 + 0.5) / sub as f32);
                    let ray = rays.ray(film);
                    let d = ray.d.as_dvec3();
                    sum += radiance(light + d * (distance / -d.z));
                }
            }
            sum / (sub * sub) as f64
        })
        .collect();

    // 8 x 8 blocks: z-tests of the block means against their expected values, with the
    // standard error the render estimates. Blocks inside the inner cone are all but
    // noiseless (every sample sees the same light), and those at the dark edge see almost
    // none, so the error has a floor of the f32 rounding of 64 accumulated samples of the
    // brightest value (well under 1e-4 of it).
    let full = albedo / PI * intensity / (distance * distance);
    let blocks = common::blocks(&snap, 8);
    let want = common::block_stats(size, size, 8, expected.iter().map(|&e| (DVec3::splat(e), DVec3::ZERO)));
    let z_max = common::sidak_z(1e-3, blocks.len());
    // The wall is grey under a white light: the red channel stands for all three.
    common::assert_block_means_agree(&blocks, &want, 0..1, 1e-4 * full, z_max, "spot");
    let per_side = (size / 8) as usize;
    let mut centre = 0.0;
    for (bx, by) in [(3, 3), (4, 3), (3, 4), (4, 4)] {
        centre += blocks[by * per_side + bx].0.x / 4.0;
    }
    // The four central blocks lie inside the inner cone: I / d^2 times albedo / pi.
    assert!((centre / full - 1.0).abs() < 1e-3, "the centre: {centre:.5} of {full:.5}");
}

/// A lit scene of every light kind: an emissive square (two triangles), a point, a spot and
/// a directional light, and the built-in sky.
fn every_kind() -> Scene {
    use lucent::scene::environment::{EnvSettings, Environment};
    let emitter = Material { emissive: Vec3::new(2.0, 1.0, 0.5), ..Material::lambert("panel", Vec3::ZERO) };
    let panel = cuboid(Vec3::new(-0.5, 0.99, -0.5), Vec3::new(0.5, 1.0, 0.5), false, 0);
    let light = |name: &str, kind, position, intensity| PunctualLight {
        name: name.into(),
        kind,
        position,
        direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
        color: Vec3::new(1.0, 0.8, 0.6),
        intensity,
        range: None,
        source: None,
    };
    let desc = SceneDesc {
        name: "every light".into(),
        meshes: vec![panel],
        materials: vec![emitter],
        lights: vec![
            light("point", PunctualKind::Point, Vec3::new(0.2, 0.5, 0.1), 3.0),
            light("spot", PunctualKind::Spot(Cone::new(0.3, 0.6)), Vec3::new(-0.2, 0.8, 0.0), 5.0),
            light("sun", PunctualKind::Directional, Vec3::ZERO, 1.5),
        ],
        ..SceneDesc::default()
    };
    let sky = Environment::load(EnvSettings::built_in()).unwrap();
    Scene::build(desc).with_environment(Some(sky))
}

#[test]
fn every_light_emits_its_power_and_samples_rays_with_the_densities_it_reports() {
    // Flux = E[Le |cos| / (pdf_pos pdf_dir)] over sample_le's rays (luminance), against each
    // light's power: exact for the panel (uniform emission, cosine directions), the point and
    // the sun; a Monte Carlo estimate for the spot (its falloff over a uniform cone) and the
    // sky (its map importance-sampled), z-tested with the estimate's standard error. The sky's
    // power is pi r^2 times the integral of its radiance over the sphere, computed here by
    // quadrature of `Environment::radiance`.
    let scene = every_kind();
    let mut lights: Vec<Light> = (0..scene.geometry.len() as u32)
        .filter(|&t| scene.light_sampler.triangle_pmf(t) > 0.0)
        .map(|t| {
            let p = scene.geometry.positions(t);
            let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
            Light::Triangle(TriangleLight { tri: t, area, power: 0.0 })
        })
        .collect();
    assert!(lights.len() >= 2, "the panel's front emits");
    lights.extend(scene.lights.iter().map(PunctualLight::light));
    lights.push(Light::Environment);
    let env = scene.environment.as_ref().unwrap();
    let lum = |c: Vec3| 0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64;
    let (n_theta, n_phi) = (512, 1024);
    let mut sky = 0.0;
    for i in 0..n_theta {
        let theta = (i as f64 + 0.5) / n_theta as f64 * PI;
        for j in 0..n_phi {
            let phi = (j as f64 + 0.5) / n_phi as f64 * 2.0 * PI;
            let d = Vec3::new((theta.sin() * phi.cos()) as f32, theta.cos() as f32, (theta.sin() * phi.sin()) as f32);
            sky += lum(env.radiance(d).to_rgb()) * theta.sin();
        }
    }
    let r = scene.radius() as f64;
    let sky_power = PI * r * r * sky * (PI / n_theta as f64) * (2.0 * PI / n_phi as f64);
    let z_max = common::sidak_z(1e-3, lights.len());
    let n = 1 << 16;
    let mut rng = lucent::math::sampler::Sampler::new(glam::UVec2::new(1, 2), 0, 3);
    for light in &lights {
        let power = match light {
            Light::Environment => sky_power,
            Light::Triangle(t) => {
                let le = lum(scene.emission(&scene.light_point(t.tri, [1.0 / 3.0; 3])).to_rgb());
                PI * t.area as f64 * le
            }
            other => other.power(&scene) as f64,
        };
        let (mut sum, mut sum2, mut off_texel) = (0.0f64, 0.0f64, 0);
        for _ in 0..n {
            let (u_pos, u_dir) = (rng.next_2d(), rng.next_2d());
            let Some(s) = light.sample_le(&scene, u_pos, u_dir) else { continue };
            assert!((s.ray.d.length() - 1.0).abs() < 1e-5 && s.ray.o.is_finite(), "{light:?}: {:?}", s.ray);
            let cos = s.n.map_or(1.0, |n| n.dot(s.ray.d).abs() as f64);
            let flux = lum(s.radiance.to_rgb()) * cos / (s.pdf_pos as f64 * s.pdf_dir as f64);
            sum += flux;
            sum2 += flux * flux;
            // The densities pdf_le reports for the ray, where they are not deltas.
            let (pos, dir) = light.pdf_le(&scene, s.n.unwrap_or(Vec3::ZERO), s.ray.d);
            let close = |a: f32, b: f32| (a - b).abs() <= 1e-4 * b.abs();
            match light {
                Light::Point(_) | Light::Spot(_) => assert!(close(dir, s.pdf_dir), "{light:?}: {dir} {}", s.pdf_dir),
                Light::Directional(_) => assert!(close(pos, s.pdf_pos), "{light:?}: {pos} {}", s.pdf_pos),
                // A direction drawn on a texel's edge may round into its neighbour.
                Light::Environment => off_texel += !(close(pos, s.pdf_pos) && close(dir, s.pdf_dir)) as usize,
                Light::Triangle(_) => {
                    assert!(close(pos, s.pdf_pos) && close(dir, s.pdf_dir), "{light:?}: {pos} {dir} {s:?}")
                }
            }
        }
        assert!(off_texel * 1000 < n, "{light:?}: {off_texel} of {n} rays with other densities");
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
        // Exact estimators have no spread but f32 rounding: a floor of 1e-5 of the power.
        let z = (mean - power) / se.max(1e-5 * power);
        assert!(z.abs() < z_max, "{light:?}: flux {mean:.5} +- {se:.5} against power {power:.5} (z = {z:.1})");
    }
}

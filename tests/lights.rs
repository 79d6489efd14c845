//! Punctual lights against their closed forms: a KHR_lights_punctual spot light of a fifth
//! of a degree seen on a facing Lambertian wall, pixel block by pixel block.

mod common;

use glam::{DVec3, Vec2, Vec3};
use lucent::integrator::Settings;
use lucent::scene::light::{Cone, PunctualKind, PunctualLight};
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

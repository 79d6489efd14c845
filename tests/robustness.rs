//! Hard cases stay numerically stable: watertight intersection, no self-intersection,
//! scale invariance, and exact long accumulation.

mod common;

use glam::{Affine3A, DVec3, Quat, UVec2, Vec3};
use lucent::film::Film;
use lucent::integrator::Settings;
use lucent::loader::gltf;
use lucent::math::sampler::Sampler;
use lucent::math::warp::uniform_hemisphere;
use lucent::scene::{MeshDesc, Scene, SceneDesc, camera::Camera, geometry::Ray, material::Material};
use lucent::spectrum::Spectrum;
use std::f32::consts::PI;
use std::path::Path;
use std::sync::Arc;

/// A closed sphere (shared vertices, one vertex per pole, the seam wrapped by index) whose
/// vertices are jittered radially by up to `jitter` of the radius.
fn closed_sphere(radius: f32, stacks: u32, slices: u32, jitter: f32) -> MeshDesc {
    let mut rng = Sampler::new(UVec2::new(1, 1), 0, 42);
    let mut positions = vec![Vec3::Y * radius];
    for i in 1..stacks {
        let theta = PI * i as f32 / stacks as f32;
        for j in 0..slices {
            let phi = 2.0 * PI * j as f32 / slices as f32;
            let r = radius * (1.0 + jitter * (2.0 * rng.next_1d() - 1.0));
            positions.push(r * Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    positions.push(-Vec3::Y * radius);
    let ring = |i: u32, j: u32| 1 + (i - 1) * slices + j % slices;
    let south = positions.len() as u32 - 1;
    let mut indices = Vec::new();
    for j in 0..slices {
        indices.extend_from_slice(&[0, ring(1, j + 1), ring(1, j)]);
        indices.extend_from_slice(&[south, ring(stacks - 1, j), ring(stacks - 1, j + 1)]);
    }
    for i in 1..stacks - 1 {
        for j in 0..slices {
            let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j));
            indices.extend_from_slice(&[a, b, c, a, c, d]);
        }
    }
    MeshDesc { name: "sphere".into(), positions, indices, ..MeshDesc::default() }
}

fn sphere_scene(mesh: MeshDesc) -> Scene {
    Scene::build(SceneDesc {
        name: "sphere".into(),
        meshes: vec![mesh],
        materials: vec![Material::lambert("grey", Vec3::splat(0.5))],
        ..SceneDesc::default()
    })
}

fn random_direction(s: &mut Sampler) -> Vec3 {
    let d = uniform_hemisphere(s.next_2d());
    if s.next_1d() < 0.5 { d } else { -d }
}

#[test]
fn a_closed_jittered_sphere_is_watertight() {
    let mesh = closed_sphere(1.0, 96, 192, 0.01);
    let vertices = mesh.positions.clone();
    let indices = mesh.indices.clone();
    let scene = sphere_scene(mesh);
    let mut s = Sampler::new(UVec2::new(3, 4), 0, 7);
    let mut misses = 0;
    for _ in 0..100_000 {
        let o = Vec3::new(s.next_1d() - 0.5, s.next_1d() - 0.5, s.next_1d() - 0.5) * 1.0;
        let ray = Ray { o, d: random_direction(&mut s), tmax: f32::INFINITY };
        misses += scene.geometry.intersect(&ray).is_none() as u32;
    }
    // Rays from the centre aimed exactly at every vertex and at every edge midpoint.
    let mut aimed = 0;
    for tri in indices.chunks_exact(3) {
        let p = [0, 1, 2].map(|k| vertices[tri[k] as usize]);
        for target in [p[0], p[1], p[2], 0.5 * (p[0] + p[1]), 0.5 * (p[1] + p[2]), 0.5 * (p[2] + p[0])] {
            let ray = Ray { o: Vec3::ZERO, d: target.normalize(), tmax: f32::INFINITY };
            misses += scene.geometry.intersect(&ray).is_none() as u32;
            aimed += 1;
        }
    }
    assert!(aimed > 100_000);
    assert_eq!(misses, 0, "rays escaped a closed mesh");
}

/// A ray from outside towards the unit sphere at the origin, with a uniform impact
/// parameter, or one within 1e-3 of the rim (grazing) when `grazing`.
fn aim_at_unit_sphere(s: &mut Sampler, grazing: bool) -> Ray {
    let side = random_direction(s);
    let impact = if grazing { 1.0 - 1e-3 * s.next_1d() } else { s.next_1d() };
    let perp = side.cross(random_direction(s)).normalize();
    Ray { o: side * 3.0 + perp * impact, d: -side, tmax: f32::INFINITY }
}

#[test]
fn reflected_rays_never_re_hit_a_convex_sphere_even_at_grazing_angles() {
    reflections_leave(&sphere_scene(closed_sphere(1.0, 128, 256, 0.0)), Affine3A::IDENTITY);
}

#[test]
fn reflected_rays_never_re_hit_an_instanced_sphere_at_any_scale_and_far_from_the_origin() {
    let turn = Quat::from_euler(glam::EulerRot::XYZ, 0.3, 1.1, -0.7);
    // (scale, world offset, offset of the mesh in its own space that the placement undoes)
    let cases =
        [(1e-4, 0.0, 0.0), (1e4, 0.0, 0.0), (1.0, 1e5, 0.0), (1e-3, 1e3, 0.0), (3.0, -2e4, 0.0), (1.0, 0.0, 1e4)];
    for (scale, offset, own) in cases {
        let placement =
            Affine3A::from_scale_rotation_translation(Vec3::new(scale, scale * 0.7, scale), turn, Vec3::splat(offset));
        let mut mesh = closed_sphere(1.0, 128, 256, 0.0);
        mesh.positions.iter_mut().for_each(|p| *p += Vec3::splat(own));
        let undo = Affine3A::from_translation(Vec3::splat(-own));
        let scene = sphere_scene(MeshDesc { instances: vec![placement * undo], ..mesh });
        assert_eq!(scene.geometry.instance_count(), 1);
        reflections_leave(&scene, placement);
    }
}

/// A square of side `2 size` (two triangles) in the coordinate plane through the origin
/// normal to axis `axis`, facing its positive side, and `placement` of it (None: flattened).
fn square_through_the_origin(axis: usize, size: f32, placement: Option<Affine3A>) -> Scene {
    let corner = |x: f32, y: f32| {
        let mut c = [0.0; 3];
        (c[(axis + 1) % 3], c[(axis + 2) % 3]) = (x * size, y * size);
        Vec3::from_array(c)
    };
    let positions = vec![corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)];
    let square = MeshDesc {
        name: "square".into(),
        positions,
        indices: vec![0, 1, 2, 0, 2, 3],
        instances: placement.into_iter().collect(),
        ..MeshDesc::default()
    };
    sphere_scene(square)
}

#[test]
fn reflected_rays_never_re_hit_a_plane_through_the_origin() {
    // Points of a coordinate plane through the origin have no rounding error along its
    // normal, so their ray origins get no offset: only the triangle test's bound on the
    // error of a hit's distance keeps reflections from finding the plane again.
    let mut s = Sampler::new(UVec2::new(3, 4), 0, 11);
    for axis in 0..3 {
        // Instanced, turned about the plane's normal: the plane stays where it is.
        let turn = Affine3A::from_axis_angle(Vec3::AXES[axis], 0.7);
        for size in [1e-3f32, 1.0, 1e4] {
            for placement in [None, Some(turn)] {
                let scene = square_through_the_origin(axis, size, placement);
                let (mut hits, mut self_hits) = (0, 0);
                for _ in 0..200_000 {
                    // From above the square, towards a point on it (mostly near the origin,
                    // where the diagonal both triangles share runs).
                    let mut target = [0.0f32; 3];
                    let r = size * s.next_1d().powi(4);
                    let phi = 2.0 * PI * s.next_1d();
                    (target[(axis + 1) % 3], target[(axis + 2) % 3]) = (r * phi.cos(), r * phi.sin());
                    let d = uniform_hemisphere(s.next_2d());
                    let mut down = [0.0f32; 3];
                    (down[(axis + 1) % 3], down[(axis + 2) % 3], down[axis]) = (d.x, d.y, -d.z);
                    let d = Vec3::from_array(down);
                    let target = Vec3::from_array(target);
                    let ray = Ray { o: target - d * size, d, tmax: f32::INFINITY };
                    let Some(hit) = scene.geometry.intersect(&ray) else { continue };
                    hits += 1;
                    let surface = scene.surface(&hit);
                    let n = surface.ng;
                    let r = ray.d - 2.0 * ray.d.dot(n) * n;
                    let origin = lucent::math::float::offset_ray_origin(surface.p, surface.p_error, n, r);
                    self_hits +=
                        scene.geometry.intersect(&Ray { o: origin, d: r, tmax: f32::INFINITY }).is_some() as u32;
                }
                let label = format!("axis {axis}, size {size}, instanced {}", placement.is_some());
                assert!(hits > 190_000, "{label}: {hits} hits");
                assert_eq!(self_hits, 0, "{label}: reflections re-hit the plane they left ({self_hits} of {hits})");
            }
        }
    }
}

/// Rays aimed at the unit sphere placed by `placement` hit it, and their reflections,
/// leaving from the offset hit point, never hit it again.
fn reflections_leave(scene: &Scene, placement: Affine3A) {
    let mut s = Sampler::new(UVec2::new(5, 6), 0, 9);
    let (mut hits, mut self_hits) = (0, 0);
    for i in 0..50_000 {
        let ray = aim_at_unit_sphere(&mut s, i % 2 == 1);
        let ray = Ray { o: placement.transform_point3(ray.o), d: placement.transform_vector3(ray.d), ..ray };
        let Some(hit) = scene.geometry.intersect(&ray) else { continue };
        hits += 1;
        let surface = scene.surface(&hit);
        let n = if surface.ng.dot(ray.d) < 0.0 { surface.ng } else { -surface.ng };
        let r = ray.d - 2.0 * ray.d.dot(n) * n;
        let origin = lucent::math::float::offset_ray_origin(surface.p, surface.p_error, n, r);
        self_hits += scene.geometry.intersect(&Ray { o: origin, d: r, tmax: f32::INFINITY }).is_some() as u32;
    }
    // Every ray aimed at the inner part of the disc hits; at 1e5 from the origin f32 rounds
    // some grazing rays' origins by more than their 1e-3 margin, and they miss.
    assert!(hits >= 25_000, "{hits} hits, placed by {placement:?}");
    assert_eq!(self_hits, 0, "reflections re-hit the convex surface they left, placed by {placement:?}");
}

/// The Cornell box glTF under a new root node that scales it by `scale` and translates it
/// by `offset` on every axis, as a file placing a model far from the origin would.
fn cornell_placed(scale: f64, offset: f64) -> common::ScratchFile {
    let text = std::fs::read_to_string(common::cornell_box_file()).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let children = doc["scenes"][0]["nodes"].clone();
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(serde_json::json!({
        "name": "placement",
        "children": children,
        "scale": [scale, scale, scale],
        "translation": [offset, offset, offset]
    }));
    let root = nodes.len() - 1;
    doc["scenes"][0]["nodes"] = serde_json::json!([root]);
    let file = format!("cornell-{scale}-{offset}.gltf");
    common::scratch_file("robust", &file, &serde_json::to_vec(&doc).unwrap())
}

#[test]
fn the_cornell_box_renders_the_same_at_any_scale_and_far_from_the_origin() {
    let settings = Settings { width: 64, height: 64, target_spp: Some(32), seed: 11, ..Settings::default() };
    let render = |scale: f64, offset: f64| {
        let scene = Arc::new(Scene::build(gltf::load(&cornell_placed(scale, offset)).unwrap()));
        let camera: Camera = scene.default_camera(1.0);
        common::render(&scene, camera, settings, None)
    };
    let reference = render(1.0, 0.0);
    let variants = [(1e-4, 0.0), (1e4, 0.0), (1.0, 1e5), (1e-4, 1e5)];
    let z_max = common::sidak_z(1e-3, variants.len() * common::blocks(&reference, 8).len() * 3);
    for (scale, offset) in variants {
        let snap = render(scale, offset);
        common::assert_blocks_agree(&snap, &reference, 8, z_max, &format!("scale {scale}, offset {offset}"));
    }
}

#[test]
fn the_instanced_cornell_box_renders_the_same_at_any_scale_turn_and_offset() {
    let settings = Settings { width: 64, height: 64, target_spp: Some(32), seed: 11, ..Settings::default() };
    let render = |path: &Path| {
        let scene = Arc::new(Scene::build(gltf::load(path).unwrap()));
        common::render(&scene, scene.default_camera(1.0), settings, None)
    };
    let reference = render(&common::cornell_box_file());
    let variants = [(1e-4, 0.0), (1e4, 0.0), (1.0, 1e5), (1e-4, 1e5), (0.3, -2e3)];
    let z_max = common::sidak_z(1e-3, variants.len() * common::blocks(&reference, 8).len() * 3);
    for (scale, offset) in variants {
        let path = cornell_placed_twice(scale, offset);
        let scene = Scene::build(gltf::load(&path).unwrap());
        assert_eq!(scene.geometry.instance_count(), 16, "the 8 meshes, each placed twice");
        let snap = render(&path);
        common::assert_blocks_agree(&snap, &reference, 8, z_max, &format!("scale {scale}, offset {offset}"));
    }
}

/// The Cornell box placed twice by root nodes that turn it, scale it by `scale` and
/// translate it by `offset` on every axis, the second copy 2,000 box sizes behind the first
/// one's camera (what it sends back into the first box is below 1e-6 of its light), so that
/// every mesh is instanced. The first copy's camera is the file's first.
fn cornell_placed_twice(scale: f64, offset: f64) -> common::ScratchFile {
    let text = std::fs::read_to_string(common::cornell_box_file()).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let children = doc["scenes"][0]["nodes"].clone();
    let turn = Quat::from_euler(glam::EulerRot::XYZ, 0.4, -0.9, 0.2);
    let behind = turn.as_dquat() * DVec3::new(0.0, 0.0, -2000.0 * 0.56 * scale);
    let nodes = doc["nodes"].as_array_mut().unwrap();
    let first = nodes.len();
    for shift in [DVec3::ZERO, behind] {
        nodes.push(serde_json::json!({
            "children": children,
            "rotation": turn.to_array(),
            "scale": [scale, scale, scale],
            "translation": (DVec3::splat(offset) + shift).to_array()
        }));
    }
    // The walk visits the last root first: the first copy's camera comes first.
    doc["scenes"][0]["nodes"] = serde_json::json!([first + 1, first]);
    let file = format!("cornell-twice-{scale}-{offset}.gltf");
    common::scratch_file("robust", &file, &serde_json::to_vec(&doc).unwrap())
}

#[test]
fn a_million_samples_keep_the_exact_mean() {
    // Samples on a 2^-20 grid below 16 are exact in f32 and their sum is exact in integers.
    let mut film = Film::new(1, 1);
    let mut s = Sampler::new(UVec2::ZERO, 0, 5);
    let mut exact: u128 = 0;
    let n = 1_000_000u64;
    for _ in 0..n {
        let k = (s.next_1d() * (1u32 << 24) as f32) as u64;
        exact += k as u128;
        film.tiles[0].add(UVec2::ZERO, Spectrum::splat(k as f32 / (1u32 << 20) as f32));
    }
    let exact_mean = exact as f64 / (1u64 << 20) as f64 / n as f64;
    let mean = film.mean_image(None)[0].x as f64;
    assert!(((mean - exact_mean) / exact_mean).abs() < 1e-6, "{mean} vs {exact_mean}");
}

#[test]
fn obvhs_moller_trumbore_test_leaks_where_the_watertight_test_does_not() {
    // The same rays as the watertight test, aimed exactly at vertices and edge midpoints:
    // this is why the renderer uses its own test (and what `--without watertight` shows).
    let mesh = closed_sphere(1.0, 96, 192, 0.01);
    let (vertices, indices) = (mesh.positions.clone(), mesh.indices.clone());
    let scene = sphere_scene(mesh);
    let (mut leaks, mut watertight_leaks) = (0, 0);
    for tri in indices.chunks_exact(3) {
        let p = [0, 1, 2].map(|k| vertices[tri[k] as usize]);
        for target in [p[0], 0.5 * (p[0] + p[1])] {
            let ray = Ray { o: Vec3::ZERO, d: target.normalize(), tmax: f32::INFINITY };
            leaks += scene.geometry.intersect_with(&ray, false).is_none() as u32;
            watertight_leaks += scene.geometry.intersect_with(&ray, true).is_none() as u32;
        }
    }
    assert_eq!(watertight_leaks, 0);
    assert!(leaks > 0, "obvhs's test did not leak here; the watertight test may be unnecessary");
}

/// Snell refraction of `d` (unit, towards the surface) through unit normal `n` (against
/// `d`) with relative index `eta`; None under total internal reflection.
fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = -d.dot(n);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    (sin2_t < 1.0).then(|| (d / eta + (cos_i / eta - (1.0 - sin2_t).sqrt()) * n).normalize())
}

#[test]
fn refracted_and_internally_reflected_rays_neither_re_hit_nor_leak_at_grazing_angles() {
    // Glass (eta 1.5) sphere: rays refracted into it must cross it and leave through another
    // triangle; rays inside at grazing angles are totally reflected and must stay inside.
    let scene = sphere_scene(closed_sphere(1.0, 128, 256, 0.0));
    let mut s = Sampler::new(UVec2::new(8, 1), 0, 21);
    let (mut refracted, mut tir) = (0, 0);
    for i in 0..40_000 {
        let ray = aim_at_unit_sphere(&mut s, i % 2 == 1);
        let Some(hit) = scene.geometry.intersect(&ray) else { continue };
        let surface = scene.surface(&hit);
        let n = surface.ng; // outward; the ray arrives against it
        let Some(t) = refract(ray.d, n, 1.5) else { continue };
        let origin = lucent::math::float::offset_ray_origin(surface.p, surface.p_error, n, t);
        let inside = scene.geometry.intersect(&Ray { o: origin, d: t, tmax: f32::INFINITY });
        let exit = inside.expect("a refracted ray leaked out of the closed sphere");
        assert_ne!(exit.tri, hit.tri, "refracted ray re-hit its own triangle");
        refracted += 1;
        // Inside, at the exit point, reflect; from a grazing direction chosen so that glass
        // to air is totally reflected (sin > 1/1.5).
        let exit_surface = scene.surface(&exit);
        let n_in = -exit_surface.ng;
        let tangent = n_in.cross(random_direction(&mut s)).normalize();
        let d = (tangent * (1.0 - 1e-3 * s.next_1d()) - n_in * 0.02).normalize();
        if refract(d, n_in, 1.0 / 1.5).is_some() {
            continue;
        }
        let r = d - 2.0 * d.dot(n_in) * n_in;
        let o = lucent::math::float::offset_ray_origin(exit_surface.p, exit_surface.p_error, n_in, r);
        let again = scene.geometry.intersect(&Ray { o, d: r, tmax: f32::INFINITY });
        let again = again.expect("an internally reflected ray leaked out of the closed sphere");
        assert_ne!(again.tri, exit.tri, "internally reflected ray re-hit its own triangle");
        tir += 1;
    }
    assert!(refracted > 30_000 && tir > 10_000, "{refracted} refracted, {tir} reflected");
}

#[test]
fn the_terminator_offset_unshadows_points_the_shading_normals_light() {
    // A coarse sphere with smooth normals under a directional light: points whose shading
    // normal faces the light (cos > 0.05) but whose facet does not are shadowed by their own
    // facet unless the ray origin is lifted onto the smooth surface.
    let scene = Scene::build(SceneDesc {
        meshes: vec![lucent::scene::shapes::uv_sphere(Vec3::ZERO, 1.0, 7, 12, false, 0)],
        materials: vec![Material::lambert("grey", Vec3::splat(0.5))],
        ..SceneDesc::default()
    });
    let light = Vec3::new(0.8, 0.3, -0.5).normalize();
    let mut s = Sampler::new(UVec2::new(2, 2), 0, 13);
    let (mut lit, mut shadowed_plain, mut shadowed_lifted) = (0, 0, 0);
    for _ in 0..200_000 {
        let tri = (s.next_1d() * scene.geometry.len() as f32) as u32 % scene.geometry.len() as u32;
        let b = lucent::math::warp::uniform_triangle(s.next_2d());
        let surface = scene.surface(&lucent::scene::geometry::Hit { tri, t: 1.0, b });
        if surface.ns.dot(light) < 0.05 {
            continue;
        }
        lit += 1;
        for (terminator, count) in [(false, &mut shadowed_plain), (true, &mut shadowed_lifted)] {
            let o = scene.reflection_origin(&surface, true, terminator, true);
            *count += scene.geometry.occluded(&Ray { o, d: light, tmax: f32::INFINITY }) as u32;
        }
    }
    let (plain, lifted) = (shadowed_plain as f64 / lit as f64, shadowed_lifted as f64 / lit as f64);
    assert!(plain > 0.01, "the case is not exercised: {plain:.4} shadowed without the offset");
    assert!(lifted < 0.1 * plain, "terminator offset: {lifted:.4} shadowed vs {plain:.4} without");
}

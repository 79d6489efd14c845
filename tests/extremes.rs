//! Extreme inputs: material parameters at the ends of their ranges, lights far smaller and
//! brighter than anything else or seen edge-on, coincident and degenerate geometry, bad
//! vertices, a camera inside a closed mesh, an empty scene. None may produce a NaN, an Inf,
//! a panic, or more light than a furnace puts in.

mod common;

use glam::{Vec2, Vec3};
use lucent::integrator::{LightSampling, Settings};
use lucent::loader::{builtin, gltf};
use lucent::render::Snapshot;
use lucent::scene::{MeshDesc, Scene, SceneDesc, camera::Camera, material::Material, shapes::uv_sphere};
use std::sync::Arc;

fn assert_finite(snap: &Snapshot, label: &str) {
    assert_eq!(snap.rejected, 0, "{label}: NaN/Inf samples");
    assert!(snap.mean.iter().all(|p| p.is_finite()), "{label}: non-finite pixel");
}

fn quad(name: &str, corners: [Vec3; 4], material: u32) -> MeshDesc {
    MeshDesc {
        name: name.into(),
        positions: corners.to_vec(),
        normals: None,
        uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]),
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
        ..MeshDesc::default()
    }
}

/// Allowance for the error of the GGX albedo tables behind the dielectric layering.
const TABLE_ERROR: f64 = 1e-3;

#[test]
fn materials_at_their_extremes_give_no_nan_and_no_energy_gain_in_a_furnace() {
    // A coarse, smooth-shaded sphere (shading normals differ from the facets) inside an
    // enclosure emitting radiance 1: with every albedo at most 1, no pixel's expected value
    // exceeds 1. Every 4x4 block mean is z-tested one-sidedly against 1 + TABLE_ERROR: the
    // dielectric's base gets the energy its specular layer leaves, read from a table, so
    // an underestimate of the layer's albedo by e gives the base e more (the largest excess
    // measured without the allowance was 1e-4, at IOR 1e4, against 2.4e-2 with the spec's
    // unweighted Fresnel mix).
    let enclosure = Material { emissive: Vec3::ONE, ..Material::lambert("enclosure", Vec3::ZERO) };
    let mut variants = Vec::new();
    for roughness in [0.0, 1.0] {
        for metallic in [0.0, 0.5, 1.0] {
            for base in [0.0, 1.0] {
                for ior in [1.0, 1e4] {
                    variants.push(Material {
                        name: format!("roughness {roughness}, metallic {metallic}, base {base}, ior {ior}"),
                        base_color: Vec3::splat(base),
                        metallic,
                        roughness,
                        ior,
                        ..Material::default()
                    });
                }
            }
        }
    }
    let settings = Settings { width: 16, height: 16, max_depth: 5, target_spp: Some(256), ..Settings::default() };
    let z_max = common::sidak_z(1e-3, variants.len() * 16 * 3);
    for material in variants {
        let label = material.name.clone();
        let desc = SceneDesc {
            meshes: vec![uv_sphere(Vec3::ZERO, 4.0, 8, 16, true, 0), uv_sphere(Vec3::ZERO, 1.0, 6, 12, false, 1)],
            materials: vec![enclosure.clone(), material],
            ..SceneDesc::default()
        };
        let scene = Arc::new(Scene::build(desc));
        let camera = Camera::look_at(Vec3::new(0.0, 0.5, 3.0), Vec3::ZERO, 0.7);
        let snap = common::render(&scene, camera, settings, None);
        assert_finite(&snap, &label);
        for (b, (mean, var)) in common::blocks(&snap, 4).into_iter().enumerate() {
            for c in 0..3 {
                let z = (mean[c] - 1.0 - TABLE_ERROR) / var[c].sqrt().max(1e-12);
                assert!(z < z_max, "{label}: block {b} channel {c}: {:.4} > 1 (z {z:.1})", mean[c]);
            }
        }
    }
}

#[test]
fn tiny_bright_grazing_coincident_and_degenerate_emitters_stay_finite() {
    let mut desc = builtin::cornell_box();
    let m = desc.materials.len() as u32;
    desc.materials.push(Material { emissive: Vec3::splat(1e6), ..Material::lambert("tiny sun", Vec3::ZERO) });
    desc.materials.push(Material { emissive: Vec3::splat(5.0), ..Material::lambert("edge-on", Vec3::ZERO) });
    desc.materials.push(Material::lambert("red", Vec3::new(0.9, 0.1, 0.1)));
    let (lo, hi) = (Scene::build(builtin::cornell_box()).bounds.0, Scene::build(builtin::cornell_box()).bounds.1);
    let (c, size) = ((lo + hi) * 0.5, (hi - lo).max_element());
    // A light much smaller than a pixel and 1e6 times brighter than the ceiling lamp.
    let t = size * 1e-5;
    let p = c + Vec3::new(0.0, 0.3 * size, 0.0);
    desc.meshes.push(MeshDesc {
        name: "tiny sun".into(),
        positions: vec![p, p + Vec3::new(t, 0.0, 0.0), p + Vec3::new(0.0, 0.0, t)],
        indices: vec![0, 1, 2, 0, 2, 1],
        material: m,
        ..MeshDesc::default()
    });
    // A light in a plane through the camera's view and through shading points on the floor:
    // every view of it and every light sample towards it is at a grazing angle.
    let y = lo.y + 1e-4 * size;
    let e = 0.2 * size;
    desc.meshes.push(quad(
        "edge-on",
        [c + Vec3::new(-e, 0.0, -e), c + Vec3::new(e, 0.0, -e), c + Vec3::new(e, 0.0, e), c + Vec3::new(-e, 0.0, e)]
            .map(|v| Vec3::new(v.x, y, v.z)),
        m + 1,
    ));
    // A quad coincident with the floor (z-fighting), and zero-area emitters and triangles.
    let floor = [lo, Vec3::new(hi.x, lo.y, lo.z), Vec3::new(hi.x, lo.y, hi.z), Vec3::new(lo.x, lo.y, hi.z)];
    desc.meshes.push(quad("coincident", floor, m + 2));
    desc.meshes.push(MeshDesc {
        name: "degenerate".into(),
        positions: vec![c, c + Vec3::X * size * 0.1, c + Vec3::X * size * 0.2, c],
        indices: vec![0, 1, 2, 0, 3, 1],
        material: m,
        ..MeshDesc::default()
    });
    let scene = Arc::new(Scene::build(desc));
    assert!(scene.warnings.iter().any(|w| w.contains("dropped 2 degenerate")), "{:?}", scene.warnings);
    let camera = scene.default_camera(1.0);
    for lights in [LightSampling::Off, LightSampling::Explicit, LightSampling::Mis] {
        let settings =
            Settings { width: 32, height: 32, light_sampling: lights, target_spp: Some(16), ..Settings::default() };
        assert_finite(&common::render(&scene, camera, settings, None), &format!("{lights:?}"));
    }
}

#[test]
fn nan_infinite_and_huge_vertices_are_dropped_with_a_warning() {
    let good = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let mut positions = good.to_vec();
    positions.extend([Vec3::new(f32::NAN, 0.0, 0.0), Vec3::new(0.0, f32::INFINITY, 0.0), Vec3::splat(-1.7e38)]);
    let desc = SceneDesc {
        meshes: vec![MeshDesc {
            name: "bad".into(),
            positions,
            indices: vec![0, 1, 2, 0, 1, 3, 4, 1, 2, 0, 1, 9, 0, 5, 1],
            ..MeshDesc::default()
        }],
        ..SceneDesc::default()
    };
    let scene = Scene::build(desc);
    assert_eq!(scene.geometry.len(), 1);
    assert!(
        scene.warnings.iter().any(|w| w.contains("dropped 4 triangles with missing, NaN, infinite or out-of-range"))
    );
    assert!(scene.bounds.0.is_finite() && scene.bounds.1.is_finite());
}

#[test]
fn nan_vertices_in_a_gltf_file_are_dropped_with_a_warning() {
    // The built-in Cornell box with one vertex of its first mesh overwritten by NaN.
    let text = std::fs::read_to_string(common::cornell_box_file()).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let uri = doc["buffers"][0]["uri"].as_str().unwrap().to_owned();
    let (head, data) = uri.split_once(',').unwrap();
    use base64::Engine;
    let mut bytes = base64::engine::general_purpose::STANDARD.decode(data).unwrap();
    let accessor = doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"].as_u64().unwrap() as usize;
    let view = doc["accessors"][accessor]["bufferView"].as_u64().unwrap() as usize;
    let offset = doc["bufferViews"][view]["byteOffset"].as_u64().unwrap_or(0) as usize
        + doc["accessors"][accessor]["byteOffset"].as_u64().unwrap_or(0) as usize;
    bytes[offset..offset + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    doc["buffers"][0]["uri"] = format!("{head},{}", base64::engine::general_purpose::STANDARD.encode(&bytes)).into();
    let desc = gltf::load_slice(&serde_json::to_vec(&doc).unwrap(), "nan-vertex").unwrap();
    let scene = Arc::new(Scene::build(desc));
    assert!(scene.warnings.iter().any(|w| w.contains("NaN")), "{:?}", scene.warnings);
    assert!(scene.bounds.0.is_finite() && scene.bounds.1.is_finite());
    let settings = Settings { width: 16, height: 16, target_spp: Some(4), ..Settings::default() };
    assert_finite(&common::render(&scene, scene.default_camera(1.0), settings, None), "NaN vertex");
}

#[test]
fn a_camera_inside_a_closed_mesh_sees_its_inside_without_nan() {
    // Inside a grey sphere with a light outside: no light reaches the camera.
    let lamp = Material { emissive: Vec3::splat(10.0), ..Material::lambert("lamp", Vec3::ZERO) };
    let desc = SceneDesc {
        meshes: vec![
            uv_sphere(Vec3::ZERO, 1.0, 12, 24, false, 0),
            quad(
                "lamp",
                [Vec3::new(-1., 3., -1.), Vec3::new(1., 3., -1.), Vec3::new(1., 3., 1.), Vec3::new(-1., 3., 1.)],
                1,
            ),
        ],
        materials: vec![Material::lambert("grey", Vec3::splat(0.5)), lamp],
        ..SceneDesc::default()
    };
    let scene = Arc::new(Scene::build(desc));
    let camera = Camera::look_at(Vec3::ZERO, Vec3::new(0.2, 0.3, -1.0), 1.0);
    let settings = Settings { width: 16, height: 16, target_spp: Some(16), ..Settings::default() };
    let snap = common::render(&scene, camera, settings, None);
    assert_finite(&snap, "inside");
    assert!(snap.mean.iter().all(|p| *p == Vec3::ZERO), "light leaked into a closed sphere");
}

#[test]
fn an_empty_scene_renders_black() {
    let scene = Arc::new(Scene::build(SceneDesc::default()));
    let settings = Settings { width: 8, height: 8, target_spp: Some(2), ..Settings::default() };
    let snap = common::render(&scene, scene.default_camera(1.0), settings, None);
    assert_finite(&snap, "empty");
    assert!(snap.mean.iter().all(|p| *p == Vec3::ZERO));
    let file = br#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[]}],"scene":0}"#;
    let scene = Arc::new(Scene::build(gltf::load_slice(file, "empty").unwrap()));
    let snap = common::render(&scene, scene.default_camera(1.0), settings, None);
    assert_finite(&snap, "empty file");
}

#[test]
fn a_smooth_metal_brushed_into_a_rough_lobe_stays_finite() {
    // Roughness 0 with KHR_materials_anisotropy: the lobe is rough along the anisotropy
    // direction and smooth across it, where a GGX of zero width would divide by zero.
    let enclosure = Material { emissive: Vec3::ONE, ..Material::lambert("enclosure", Vec3::ZERO) };
    let brushed = Material {
        name: "brushed".into(),
        base_color: Vec3::ONE,
        metallic: 1.0,
        roughness: 0.0,
        anisotropy_strength: 0.8,
        ..Material::default()
    };
    let desc = SceneDesc {
        meshes: vec![uv_sphere(Vec3::ZERO, 4.0, 8, 16, true, 0), uv_sphere(Vec3::ZERO, 1.0, 12, 24, false, 1)],
        materials: vec![enclosure, brushed],
        ..SceneDesc::default()
    };
    let scene = Arc::new(Scene::build(desc));
    let camera = Camera::look_at(Vec3::new(0.0, 0.5, 3.0), Vec3::ZERO, 0.7);
    let settings = Settings { width: 16, height: 16, max_depth: 5, target_spp: Some(64), ..Settings::default() };
    assert_finite(&common::render(&scene, camera, settings, None), "brushed");
}

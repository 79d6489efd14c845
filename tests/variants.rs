//! glTF files re-encoded by glTF Transform (tests/assets/quantized, see its INDEX.md) load
//! into the scene their source describes: KHR_mesh_quantization's integer attributes
//! dequantize to the source's within the quantization step, and render alike.

mod common;

use glam::Vec3;
use lucent::integrator::Settings;
use lucent::loader::gltf;
use lucent::scene::environment::{EnvSettings, Environment};
use lucent::scene::{Scene, SceneDesc};
use std::sync::Arc;

fn load(rel: &str) -> SceneDesc {
    gltf::load(&common::asset(rel)).unwrap_or_else(|e| panic!("{e}"))
}

/// glTF Transform's default bit depths: positions 14, normals and tangents 10, texture
/// coordinates 12. One step of a b-bit code over an extent is extent / (2^b - 1).
fn step(extent: f32, bits: i32) -> f32 {
    extent / (2f32.powi(bits) - 1.0)
}

/// Asserts that every corner of every triangle of `q` is the corresponding corner of `p`
/// within one quantization step: positions measured against the scene's extent (each
/// mesh's own step is smaller, and re-centring on the bounds moves by at most half a step),
/// unit vectors and texture coordinates per component.
fn assert_same_meshes(p: &SceneDesc, q: &SceneDesc, label: &str) {
    let extent = p
        .meshes
        .iter()
        .flat_map(|m| &m.positions)
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    let extent = (extent.1 - extent.0).max_element();
    let (dp, dn, duv) = (step(extent, 14), step(2.0, 10), step(1.0, 12));
    assert_eq!(p.meshes.len(), q.meshes.len(), "{label}: meshes");
    let mut corners = 0;
    for (m, (a, b)) in p.meshes.iter().zip(&q.meshes).enumerate() {
        assert_eq!(a.indices.len(), b.indices.len(), "{label}: mesh {m}: indices");
        assert_eq!(a.material, b.material, "{label}: mesh {m}: material");
        for (&i, &j) in a.indices.iter().zip(&b.indices) {
            let (i, j) = (i as usize, j as usize);
            let d = (a.positions[i] - b.positions[j]).abs().max_element();
            assert!(d <= dp, "{label}: mesh {m} vertex {i}: position off by {d:e} > {dp:e}");
            if let (Some(na), Some(nb)) = (&a.normals, &b.normals) {
                let d = (na[i] - nb[j]).abs().max_element();
                assert!(d <= dn, "{label}: mesh {m} vertex {i}: normal off by {d:e} > {dn:e}");
            }
            if let (Some(ta), Some(tb)) = (&a.tangents, &b.tangents) {
                let d = (ta[i] - tb[j]).abs().max_element();
                assert!(d <= dn, "{label}: mesh {m} vertex {i}: tangent off by {d:e} > {dn:e}");
            }
            if let (Some(ua), Some(ub)) = (&a.uvs, &b.uvs) {
                let d = (ua[i] - ub[j]).abs().max_element();
                assert!(d <= duv, "{label}: mesh {m} vertex {i}: uv off by {d:e} > {duv:e}");
            }
            corners += 1;
        }
        assert_eq!(a.normals.is_some(), b.normals.is_some(), "{label}: mesh {m}: normals");
        assert_eq!(a.tangents.is_some(), b.tangents.is_some(), "{label}: mesh {m}: tangents");
        assert_eq!(a.uvs.is_some(), b.uvs.is_some(), "{label}: mesh {m}: uvs");
    }
    assert!(corners > 0, "{label}: no triangles");
}

#[test]
fn quantized_cornell_glass_has_its_sources_triangles_within_a_step() {
    let (p, q) = (load("cornell-box-glass.gltf"), load("quantized/cornell-box-glass.gltf"));
    assert_same_meshes(&p, &q, "Cornell glass");
    let names = |d: &SceneDesc| d.materials.iter().map(|m| m.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(&p), names(&q));
}

#[test]
fn quantized_water_bottle_has_its_sources_attributes_within_a_step_and_renders_alike() {
    let (p, q) = (load("WaterBottle/glTF/WaterBottle.gltf"), load("quantized/WaterBottle.glb"));
    assert!(q.meshes[0].tangents.is_some() && q.meshes[0].uvs.is_some(), "the variant has integer tangents and uvs");
    assert_same_meshes(&p, &q, "WaterBottle");
    let sky = || Environment::load(EnvSettings { background: Vec3::ONE, ..EnvSettings::default() }).unwrap();
    let (p, q) = (
        Arc::new(Scene::build(p).with_environment(Some(sky()))),
        Arc::new(Scene::build(q).with_environment(Some(sky()))),
    );
    let camera = p.default_camera(1.0);
    let settings = |seed| Settings { width: 48, height: 48, seed, target_spp: Some(64), ..Settings::default() };
    let a = common::render(&p, camera, settings(1), None);
    let b = common::render(&q, camera, settings(2), None);
    common::assert_blocks_agree(&b, &a, common::sidak_z(1e-3, 36 * 3), "quantized WaterBottle");
}

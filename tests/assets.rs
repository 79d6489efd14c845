//! Real Khronos models that use only what the renderer supports render without a single
//! NaN or infinite sample. Scenes without punctual lights get a sun, so that every BSDF path
//! is exercised (emissive textures light only small parts of most models).

mod common;

use glam::Vec3;
use lucent::integrator::Settings;
use lucent::scene::{
    Scene,
    light::{PunctualKind, PunctualLight},
};
use std::sync::Arc;

fn render_without_nan(rel: &str) {
    let mut desc = common::load(rel);
    if desc.lights.is_empty() {
        desc.lights.push(PunctualLight {
            name: "sun".into(),
            kind: PunctualKind::Directional,
            position: Vec3::ZERO,
            direction: Vec3::new(-0.3, -1.0, -0.5).normalize(),
            color: Vec3::ONE,
            intensity: 3.0,
            range: None,
            source: None,
        });
    }
    let scene = Arc::new(Scene::build(desc));
    let camera = scene.default_camera(1.0);
    let settings = Settings { width: 48, height: 48, target_spp: Some(8), ..Settings::default() };
    let snap = common::render(&scene, camera, settings, None);
    assert_eq!(snap.rejected, 0, "{rel}: NaN/Inf samples");
    assert!(snap.mean.iter().all(|p| p.is_finite() && p.min_element() >= 0.0));
    let mean: f32 = snap.mean.iter().map(|p| p.max_element()).sum::<f32>() / snap.mean.len() as f32;
    assert!(mean > 1e-4, "{rel}: the lit model is visible (mean {mean})");
}

#[test]
fn box_renders_without_nan() {
    render_without_nan("Box/glTF-Binary/Box.glb");
}

#[test]
fn textured_models_render_without_nan() {
    render_without_nan("BoxTextured/glTF-Binary/BoxTextured.glb");
    render_without_nan("Cube/glTF/Cube.gltf");
}

#[test]
fn emissive_strength_test_renders_without_nan() {
    render_without_nan("EmissiveStrengthTest/glTF-Binary/EmissiveStrengthTest.glb");
}

#[test]
fn specular_test_renders_without_nan() {
    render_without_nan("SpecularTest/glTF-Binary/SpecularTest.glb");
}

#[test]
fn metal_rough_spheres_render_without_nan() {
    render_without_nan("MetalRoughSpheresNoTextures/glTF-Binary/MetalRoughSpheresNoTextures.glb");
}

#[test]
fn every_other_model_renders_without_nan() {
    for rel in [
        "TwoSidedPlane/glTF/TwoSidedPlane.gltf",
        "WaterBottle/glTF/WaterBottle.gltf",
        "TransmissionTest/glTF-Binary/TransmissionTest.glb",
        "TransmissionRoughnessTest/glTF-Binary/TransmissionRoughnessTest.glb",
        "AttenuationTest/glTF-Binary/AttenuationTest.glb",
        "GlassVaseFlowers/glTF-Binary/GlassVaseFlowers.glb",
        "LightsPunctualLamp/glTF/LightsPunctualLamp.gltf",
        "ToyCar/glTF/ToyCar.gltf",
        "NormalTangentTest/glTF-Binary/NormalTangentTest.glb",
        "NormalTangentMirrorTest/glTF-Binary/NormalTangentMirrorTest.glb",
        "TextureCoordinateTest/glTF-Binary/TextureCoordinateTest.glb",
        "TextureSettingsTest/glTF-Binary/TextureSettingsTest.glb",
        "AlphaBlendModeTest/glTF-Binary/AlphaBlendModeTest.glb",
    ] {
        render_without_nan(rel);
    }
}

//! The glTF loader on real files (counts of triangles, materials, lights, cameras), on the
//! built-in Cornell box, on node transforms, and on malformed input (errors, not panics).

mod common;

use base64::Engine;
use glam::Vec3;
use lucent::integrator::Settings;
use lucent::loader::{builtin, gltf};
use lucent::scene::{Scene, SceneDesc, instances::Instancing, texture::Texels};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::sync::Arc;

fn triangles(desc: &SceneDesc) -> usize {
    desc.meshes.iter().map(|m| m.indices.len() / 3).sum()
}

fn temp(name: &str, bytes: &[u8]) -> common::ScratchFile {
    common::scratch_file("gltf", name, bytes)
}

/// A one-triangle glTF with an embedded buffer; `node` and `indices` are spliced in.
fn one_triangle(node: Value, indices: [u32; 3]) -> Vec<u8> {
    let mut bytes = Vec::new();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        v.iter().for_each(|c| bytes.extend_from_slice(&c.to_le_bytes()));
    }
    for _ in 0..3 {
        [1.0f32, 0.0, 1.0].map(|c: f32| c / 2f32.sqrt()).iter().for_each(|c| bytes.extend_from_slice(&c.to_le_bytes()));
    }
    indices.iter().for_each(|i| bytes.extend_from_slice(&i.to_le_bytes()));
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bytes));
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [node],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
        "buffers": [{"byteLength": bytes.len(), "uri": uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 36},
            {"buffer": 0, "byteOffset": 72, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": 3, "type": "SCALAR"}
        ]
    });
    serde_json::to_vec(&doc).unwrap()
}

#[test]
fn box_glb_has_its_twelve_triangles_and_one_material() {
    let desc = common::load("Box/glTF-Binary/Box.glb");
    assert_eq!((triangles(&desc), desc.materials.len(), desc.lights.len(), desc.cameras.len()), (12, 1, 0, 0));
    let scene = Scene::build(desc);
    assert_eq!(scene.geometry.len(), 12);
    assert!(!scene.features.emissive && !scene.features.textures && scene.features.glossy);
}

#[test]
fn emissive_strength_test_reads_strengths_above_one() {
    let desc = common::load("EmissiveStrengthTest/glTF-Binary/EmissiveStrengthTest.glb");
    assert_eq!((triangles(&desc), desc.materials.len()), (90, 6));
    let brightest = desc.materials.iter().map(|m| m.emitted().max_element()).fold(0.0f32, f32::max);
    assert!(brightest > 1.0, "emissiveFactor x emissiveStrength exceeds 1: {brightest}");
    let scene = Scene::build(desc);
    assert!(scene.features.emissive && !scene.light_sampler.is_empty());
}

#[test]
fn lights_punctual_lamp_has_five_point_lights_and_a_transmissive_shade() {
    let desc = common::load("LightsPunctualLamp/glTF/LightsPunctualLamp.gltf");
    assert_eq!((triangles(&desc), desc.materials.len(), desc.lights.len()), (6000, 3, 5));
    assert!(desc.lights.iter().all(|l| l.kind == lucent::scene::light::PunctualKind::Point));
    let max_cd = desc.lights.iter().map(|l| l.emitted().max_element()).fold(0.0f32, f32::max);
    assert!((max_cd - 180.0).abs() < 1.0, "intensity in candela, used 1:1: {max_cd}");
    assert!(desc.warnings.iter().all(|w| !w.contains("KHR_materials_transmission")), "{:?}", desc.warnings);
    assert!(desc.materials.iter().any(|m| m.is_transmissive() && m.volume.is_none()), "a thin-walled shade");
    assert!(Scene::build(desc).features.punctual);
}

#[test]
fn metal_rough_spheres_load_all_triangles_and_the_default_material() {
    let desc = common::load("MetalRoughSpheresNoTextures/glTF-Binary/MetalRoughSpheresNoTextures.glb");
    assert_eq!(triangles(&desc), 1_040_409);
    assert_eq!(desc.materials.len(), 99, "98 materials plus the glTF default for one unassigned primitive");
    let scene = Scene::build(desc);
    let dropped: usize = scene
        .warnings
        .iter()
        .filter_map(|w| {
            w.strip_prefix("dropped ").and_then(|r| r.split(' ').next()).and_then(|n| n.parse::<usize>().ok())
        })
        .sum();
    assert_eq!(scene.geometry.len() + dropped, 1_040_409);
}

#[test]
fn the_built_in_scene_is_the_cornell_box_file() {
    let file = gltf::load(&common::cornell_box_file()).unwrap();
    let builtin = builtin::cornell_box();
    assert_eq!(triangles(&file), triangles(&builtin));
    assert_eq!(triangles(&builtin), 32);
    assert_eq!(file.materials, builtin.materials);
    assert_eq!(file.cameras, builtin.cameras);
    for (a, b) in file.meshes.iter().zip(&builtin.meshes) {
        assert_eq!((&a.positions, &a.indices), (&b.positions, &b.indices));
    }
    let light = builtin.materials.iter().find(|m| m.name == "light").unwrap();
    assert!((light.emitted() - Vec3::new(17.0, 12.0, 4.0)).abs().max_element() < 1e-4);
    let white = builtin.materials.iter().find(|m| m.name == "white").unwrap();
    assert_eq!((white.specular, white.metallic), (0.0, 0.0), "exactly Lambertian walls");
    let (_, cam) = &builtin.cameras[0];
    let min = builtin.meshes.iter().flat_map(|m| &m.positions).fold(Vec3::INFINITY, |a, &b| a.min(b));
    assert!((cam.position - min - Vec3::new(0.278, 0.273, -0.8)).length() < 1e-6, "relative to the box's corner");
    assert!((cam.rotation * -Vec3::Z - Vec3::Z).length() < 1e-6, "looks into the box along +z");
}

#[test]
fn node_transforms_flatten_with_inverse_transpose_normals_and_mirrored_winding() {
    let path = temp("mirror.gltf", &one_triangle(json!({"mesh": 0, "scale": [-2.0, 1.0, 1.0]}), [0, 1, 2]));
    let scene = Scene::build(gltf::load(&path).unwrap());
    let attrs = scene.geometry.attrs(0);
    // Mirroring flips the winding back, so the front still faces +z.
    assert!((attrs.ng - Vec3::Z).length() < 1e-6, "ng {}", attrs.ng);
    // Normal (1, 0, 1)/sqrt 2 under diag(-2, 1, 1): inverse transpose diag(-1/2, 1, 1).
    let want = Vec3::new(-0.5, 0.0, 1.0).normalize();
    assert!((attrs.normals[0] - want).length() < 1e-6, "n {}", attrs.normals[0]);
    let xs = scene.geometry.positions(0).map(|p| p.x);
    assert_eq!(xs.iter().fold(f32::MIN, |a, &b| a.max(b)) - xs.iter().fold(f32::MAX, |a, &b| a.min(b)), 2.0);
}

#[test]
fn malformed_files_give_one_line_errors() {
    let dir = common::scratch("gltf-malformed");
    let cases: Vec<(&str, PathBuf)> = vec![
        ("no such file", common::asset("Box/glTF-Binary/Missing.glb")),
        ("truncated", {
            let bytes = std::fs::read(common::asset("Box/glTF-Binary/Box.glb")).unwrap();
            dir.write("truncated.glb", &bytes[..bytes.len() / 2])
        }),
        ("dangling accessor", {
            let text = std::fs::read_to_string(common::cornell_box_file()).unwrap();
            let mut doc: Value = serde_json::from_str(&text).unwrap();
            doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(999);
            dir.write("dangling.gltf", &serde_json::to_vec(&doc).unwrap())
        }),
        ("index out of range", dir.write("index.gltf", &one_triangle(json!({"mesh": 0}), [0, 1, 7]))),
        ("not json", dir.write("garbage.gltf", b"{ this is not glTF")),
    ];
    for (what, path) in cases {
        let err = gltf::load(&path).err().unwrap_or_else(|| panic!("{what}: loaded")).to_string();
        assert!(!err.contains('\n'), "{what}: one line: {err}");
        assert!(err.contains(&*path.to_string_lossy()), "{what}: names the file: {err}");
    }
}

#[test]
fn bad_files_are_refused_in_the_users_words() {
    let triangle = || -> Value { serde_json::from_slice(&one_triangle(json!({"mesh": 0}), [0, 1, 2])).unwrap() };
    let with = |edit: &dyn Fn(&mut Value)| {
        let mut doc = triangle();
        edit(&mut doc);
        serde_json::to_vec(&doc).unwrap()
    };
    let png = std::fs::read(common::asset("Cube/glTF/Cube_MetallicRoughness.png")).unwrap();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("empty.gltf", Vec::new(), "not a glTF or GLB file (the file is empty)"),
        ("picture.gltf", png, "not a glTF or GLB file (neither JSON nor binary glTF)"),
        ("object.gltf", b"{\"scenes\": []}".to_vec(), "not a glTF or GLB file (JSON, but missing field `asset`"),
        (
            "cut.gltf",
            b"{\"asset\": {\"version\": \"2.0\"},\n\"scenes\": [".to_vec(),
            "invalid JSON: EOF while parsing a list at line 2",
        ),
        (
            "missing-buffer.gltf",
            with(&|d| d["buffers"][0]["uri"] = json!("missing.bin")),
            "buffer 0: cannot read missing.bin (no such file), named by ",
        ),
        (
            "missing-image.gltf",
            with(&|d| {
                d["images"] = json!([{"uri": "missing.png"}]);
                d["textures"] = json!([{"source": 0}]);
            }),
            "image 0: cannot read missing.png (no such file), named by ",
        ),
        (
            "device.gltf",
            with(&|d| d["buffers"][0]["uri"] = json!("file:///dev/zero")),
            "buffer 0: cannot read file:///dev/zero (not a regular file)",
        ),
        (
            "short.gltf",
            with(&|d| d["buffers"][0]["byteLength"] = json!(1000)),
            "buffer 0 (a data URI) has 84 bytes, fewer than its byteLength of 1000",
        ),
        (
            "no-count.gltf",
            with(&|d| d["accessors"][2]["count"] = json!(0)),
            "invalid glTF: accessors[2].count is 0 (at least 1 is required)",
        ),
    ];
    for (name, bytes, want) in cases {
        let path = temp(name, &bytes);
        let err = gltf::load(&path).err().unwrap_or_else(|| panic!("{name}: loaded")).to_string();
        assert!(err.contains(want), "{name}: {err}");
        assert!(
            err.contains(&*path.to_string_lossy()) && !err.contains('\n'),
            "{name}: one line naming the file: {err}"
        );
    }
}

/// A one-triangle glTF with integer attributes: POSITION i8 (0, 0, 0), (2, 0, 0), (0, 2, 0)
/// not normalized, at stride 4, under a node scale of 0.5; NORMAL i8 normalized (127, 0, 127);
/// TEXCOORD_0 u8 (0, 0), (3, 0), (0, 3) not normalized; TEXCOORD_1 i16 normalized
/// (-32768, 32767). `root` is merged into the document (extensionsUsed and so on).
fn quantized_triangle(root: Value) -> Vec<u8> {
    let mut bytes: Vec<u8> = Vec::new();
    for p in [[0i8, 0, 0], [2, 0, 0], [0, 2, 0]] {
        bytes.extend(p.iter().map(|&c| c as u8).chain([0]));
    }
    for _ in 0..3 {
        bytes.extend([127u8, 0, 127, 0]);
    }
    for uv in [[0u8, 0], [3, 0], [0, 3]] {
        bytes.extend(uv.iter().chain(&[0, 0]));
    }
    for _ in 0..3 {
        bytes.extend(i16::MIN.to_le_bytes().iter().chain(&i16::MAX.to_le_bytes()));
    }
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bytes));
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "scale": [0.5, 0.5, 0.5]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "TEXCOORD_1": 3}}]}],
        "buffers": [{"byteLength": bytes.len(), "uri": uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 12, "byteStride": 4},
            {"buffer": 0, "byteOffset": 12, "byteLength": 12, "byteStride": 4},
            {"buffer": 0, "byteOffset": 24, "byteLength": 12, "byteStride": 4},
            {"buffer": 0, "byteOffset": 36, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5120, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [2, 2, 0]},
            {"bufferView": 1, "componentType": 5120, "normalized": true, "count": 3, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5121, "count": 3, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5122, "normalized": true, "count": 3, "type": "VEC2"}
        ]
    });
    if let (Value::Object(doc), Value::Object(root)) = (&mut doc, root) {
        doc.extend(root);
    }
    serde_json::to_vec(&doc).unwrap()
}

#[test]
fn quantized_attributes_dequantize_as_the_spec_says() {
    let used = json!({"extensionsUsed": ["KHR_mesh_quantization"], "extensionsRequired": ["KHR_mesh_quantization"]});
    let desc = gltf::load(&temp("quantized.gltf", &quantized_triangle(used))).unwrap_or_else(|e| panic!("{e}"));
    let mesh = &desc.meshes[0];
    let span = |axis: usize| {
        let v: Vec<f32> = mesh.positions.iter().map(|p| p[axis]).collect();
        v.iter().fold(f32::MIN, |a, &b| a.max(b)) - v.iter().fold(f32::MAX, |a, &b| a.min(b))
    };
    assert_eq!((span(0), span(1), span(2)), (1.0, 1.0, 0.0), "i8 codes 0 and 2, not normalized, under scale 0.5");
    let n = mesh.normals.as_ref().unwrap()[0];
    assert!((n - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6, "normal {n}");
    assert_eq!(mesh.uvs.as_ref().unwrap(), &[glam::Vec2::ZERO, glam::Vec2::new(3.0, 0.0), glam::Vec2::new(0.0, 3.0)]);
    assert_eq!(mesh.uvs1.as_ref().unwrap()[0], glam::Vec2::new(-1.0, 1.0), "i16 -32768 and 32767 normalized");
}

#[test]
fn required_extensions_are_decided_by_lucents_own_list() {
    let load = |name: &str, root: Value| {
        gltf::load(&temp(name, &quantized_triangle(root))).map(|_| ()).map_err(|e| e.to_string())
    };
    let err = load("unquantized.gltf", json!({})).unwrap_err();
    assert!(err.contains("accessor 0 is Vec3 of I8, which POSITION cannot be"), "{err}");
    let glossiness = json!({
        "extensionsUsed": ["KHR_mesh_quantization", "KHR_texture_basisu"],
        "extensionsRequired": ["KHR_mesh_quantization", "KHR_materials_pbrSpecularGlossiness"]
    });
    let err = load("glossiness.gltf", glossiness).unwrap_err();
    assert!(
        err.ends_with("requires the glTF extension KHR_materials_pbrSpecularGlossiness, which Lucent does not support"),
        "{err}"
    );
    // gltf-json's own list leaves out extensions Lucent renders, such as KHR_materials_volume.
    let volume = json!({
        "extensionsUsed": ["KHR_mesh_quantization", "KHR_materials_volume"],
        "extensionsRequired": ["KHR_mesh_quantization", "KHR_materials_volume"]
    });
    load("volume.gltf", volume).unwrap();
}

/// A 3x2 RGBA image encoded as a data URI by the image crate (`format`: PNG or lossless WebP).
fn image_uri(texels: &[u8], format: image::ImageFormat) -> String {
    use image::ImageEncoder;
    let mut bytes = Vec::new();
    let cursor = &mut std::io::Cursor::new(&mut bytes);
    match format {
        image::ImageFormat::WebP => image::codecs::webp::WebPEncoder::new_lossless(cursor)
            .encode(texels, 3, 2, image::ExtendedColorType::Rgba8)
            .unwrap(),
        _ => image::codecs::png::PngEncoder::new(cursor)
            .write_image(texels, 3, 2, image::ExtendedColorType::Rgba8)
            .unwrap(),
    }
    let mime = if format == image::ImageFormat::WebP { "image/webp" } else { "image/png" };
    format!("data:{mime};base64,{}", base64::engine::general_purpose::STANDARD.encode(&bytes))
}

#[test]
fn webp_textures_are_shown_and_images_no_texture_shows_are_not_read() {
    let texels: Vec<u8> = (0..24u8).map(|i| i.wrapping_mul(37)).collect();
    let mut doc: Value = serde_json::from_slice(&one_triangle(json!({"mesh": 0}), [0, 1, 2])).unwrap();
    doc["extensionsUsed"] = json!(["EXT_texture_webp"]);
    doc["images"] = json!([
        {"uri": image_uri(&[255; 24], image::ImageFormat::Png)},
        {"uri": image_uri(&texels, image::ImageFormat::WebP)},
        {"uri": "missing.ktx2"}
    ]);
    doc["textures"] = json!([
        {"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}},
        {"extensions": {"EXT_texture_webp": {"source": 1}}}
    ]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}}]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let desc = gltf::load(&temp("webp.gltf", &serde_json::to_vec(&doc).unwrap())).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(desc.textures.iter().map(|t| t.image).collect::<Vec<_>>(), [1, 1], "both textures show the WebP");
    let webp = &desc.images[1];
    assert_eq!((webp.width, webp.height), (3, 2));
    let want: Vec<[u8; 4]> = texels.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
    assert_eq!(webp.texels, Texels::Bytes(want), "lossless WebP decodes to its source");
}

#[test]
fn morph_targets_apply_at_the_nodes_or_meshs_weights_with_a_warning() {
    // The target's position deltas are the positions themselves (accessor 0), so weight w
    // scales the triangle by 1 + w.
    let morphed = |node: Value| {
        let mut doc: Value = serde_json::from_slice(&one_triangle(node, [0, 1, 2])).unwrap();
        doc["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": 0}]);
        doc["meshes"][0]["weights"] = json!([0.5]);
        let desc =
            gltf::load(&temp("morph.gltf", &serde_json::to_vec(&doc).unwrap())).unwrap_or_else(|e| panic!("{e}"));
        let xs: Vec<f32> = desc.meshes[0].positions.iter().map(|p| p.x).collect();
        let span = xs.iter().fold(f32::MIN, |a, &b| a.max(b)) - xs.iter().fold(f32::MAX, |a, &b| a.min(b));
        assert!(desc.warnings.iter().any(|w| w.contains("morph targets are applied")), "{:?}", desc.warnings);
        span
    };
    assert_eq!(morphed(json!({"mesh": 0})), 1.5, "the mesh's default weight");
    assert_eq!(morphed(json!({"mesh": 0, "weights": [1.0]})), 2.0, "the node's weights override the mesh's");
    // A sparse accessor without a buffer view is zeros but for its few entries: a file of a
    // few kB can name a million vertices and 3,000 targets over them, 3e9 vertex updates,
    // refused before the work.
    let mut doc: Value = serde_json::from_slice(&one_triangle(json!({"mesh": 0}), [0, 1, 2])).unwrap();
    let zeros = doc["accessors"].as_array().unwrap().len();
    doc["accessors"].as_array_mut().unwrap().push(json!({
        "componentType": 5126, "count": 1_000_000, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0],
        "sparse": {"count": 1, "indices": {"bufferView": 2, "componentType": 5125}, "values": {"bufferView": 0}}
    }));
    doc["meshes"][0]["primitives"][0] =
        json!({"attributes": {"POSITION": zeros}, "targets": vec![json!({"POSITION": zeros}); 3000]});
    doc["meshes"][0]["weights"] = json!(vec![0.5; 3000]);
    let err = gltf::load(&temp("morphs.gltf", &serde_json::to_vec(&doc).unwrap())).err().expect("refused").to_string();
    assert!(
        err.contains("meshes[0].primitives[0]: its 3000 morph target attributes over 1000000 vertices and 1 copies ask for 3000000000 vertex updates, over the limit of 268435456"),
        "{err}"
    );
}

#[test]
fn ktx2_textures_transcode_as_basis_universals_own_transcoder_does() {
    let png = |name: &str| -> Vec<[u8; 4]> {
        let image = image::open(common::asset(format!("ktx2/{name}"))).unwrap().into_rgba8();
        image.pixels().map(|p| p.0).collect()
    };
    let ktx2 = |bytes: &[u8], name: &str| {
        let uri = format!("data:image/ktx2;base64,{}", base64::engine::general_purpose::STANDARD.encode(bytes));
        let mut doc: Value = serde_json::from_slice(&one_triangle(json!({"mesh": 0}), [0, 1, 2])).unwrap();
        doc["extensionsUsed"] = json!(["KHR_texture_basisu"]);
        doc["extensionsRequired"] = json!(["KHR_texture_basisu"]);
        doc["images"] = json!([{"uri": uri}]);
        doc["textures"] = json!([{"extensions": {"KHR_texture_basisu": {"source": 0}}}]);
        gltf::load(&temp(&format!("{name}.gltf"), &serde_json::to_vec(&doc).unwrap()))
    };
    let bytes = std::fs::read(common::asset("ktx2/uastc.ktx2")).unwrap();
    for (name, cut) in [("truncated", &bytes[..bytes.len() / 2]), ("header", &bytes[..40])] {
        let err = ktx2(cut, name).err().unwrap_or_else(|| panic!("{name}: loaded")).to_string();
        assert!(err.contains("image 0 (a data URI): ") && err.contains("KTX2") && !err.contains('\n'), "{name}: {err}");
    }
    // Level 0's index entry (KTX 2.0, 3.9: byteOffset, byteLength, uncompressedByteLength at
    // bytes 80, 88 and 96) lying: the transcoder would inflate the zstd level into a buffer
    // of the declared length (1 TB) before finding the stream short.
    let lie = |at: usize, value: u64| {
        let mut b = bytes.clone();
        b[at..at + 8].copy_from_slice(&value.to_le_bytes());
        b
    };
    for (name, lying, needle) in [
        ("inflated", lie(96, 1 << 40), "declares 1.1 TB once inflated, more than its 64x64 texels need (4.1 kB)"),
        ("outside", lie(88, 1 << 40), "(1099511627776 bytes at 184) lies outside the file"),
        ("wrapping", lie(80, u64::MAX), "(2542 bytes at 18446744073709551615) lies outside the file"),
    ] {
        let err = ktx2(&lying, name).err().unwrap_or_else(|| panic!("{name}: loaded")).to_string();
        assert!(err.contains("image 0 (a data URI): KTX2 level 0") && err.contains(needle), "{name}: {err}");
    }
    for mode in ["uastc", "etc1s"] {
        let bytes = std::fs::read(common::asset(format!("ktx2/{mode}.ktx2"))).unwrap();
        let desc = ktx2(&bytes, mode).unwrap_or_else(|e| panic!("{mode}: {e}"));
        let image = &desc.images[desc.textures[0].image as usize];
        assert_eq!((image.width, image.height), (64, 64), "{mode}");
        assert!(
            image.texels == Texels::Bytes(png(&format!("{mode}.reference.png"))),
            "{mode}: as the reference transcoder decodes it"
        );
    }
}

/// The one-triangle file under a node with EXT_mesh_gpu_instancing: translations (0, 0, 0),
/// (2, 0, 0) and (0, 0, -3) as f32, and rotations as normalized i16, the third half a turn
/// about z; `edit` changes the document.
fn instanced_triangle(edit: impl Fn(&mut Value)) -> Vec<u8> {
    let mut doc: Value = serde_json::from_slice(&one_triangle(json!({"mesh": 0}), [0, 1, 2])).unwrap();
    let mut bytes = Vec::new();
    for t in [[0.0f32, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, -3.0]] {
        t.iter().for_each(|c| bytes.extend_from_slice(&c.to_le_bytes()));
    }
    for q in [[0i16, 0, 0, i16::MAX], [0, 0, 0, i16::MAX], [0, 0, i16::MAX, 0]] {
        q.iter().for_each(|c| bytes.extend_from_slice(&c.to_le_bytes()));
    }
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bytes));
    doc["buffers"].as_array_mut().unwrap().push(json!({"byteLength": bytes.len(), "uri": uri}));
    doc["bufferViews"].as_array_mut().unwrap().extend([
        json!({"buffer": 1, "byteOffset": 0, "byteLength": 36}),
        json!({"buffer": 1, "byteOffset": 36, "byteLength": 24}),
    ]);
    doc["accessors"].as_array_mut().unwrap().extend([
        json!({"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC3"}),
        json!({"bufferView": 4, "componentType": 5122, "normalized": true, "count": 3, "type": "VEC4"}),
    ]);
    doc["extensionsUsed"] = json!(["EXT_mesh_gpu_instancing"]);
    doc["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    doc["nodes"][0]["extensions"] =
        json!({"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 3, "ROTATION": 4}}});
    edit(&mut doc);
    serde_json::to_vec(&doc).unwrap()
}

#[test]
fn instanced_copies_render_as_their_flattened_copies() {
    // The Cornell box with its blocks placed again: the short one mirrored across the box,
    // the tall one squashed, stretched and turned.
    let text = std::fs::read_to_string(common::cornell_box_file()).unwrap();
    let mut doc: Value = serde_json::from_str(&text).unwrap();
    let short = doc["nodes"].as_array().unwrap().iter().position(|n| n["name"] == "short_block").unwrap();
    let tall = doc["nodes"].as_array().unwrap().iter().position(|n| n["name"] == "tall_block").unwrap();
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(json!({"mesh": nodes[short]["mesh"], "scale": [-1.0, 1.0, 1.0], "translation": [0.556, 0.0, 0.0]}));
    nodes.push(json!({
        "mesh": nodes[tall]["mesh"],
        "scale": [0.25, 0.3, 1.2],
        "rotation": [0.0, 0.3826834, 0.0, 0.9238795],
        "translation": [-0.213, 0.0, -0.113]
    }));
    let n = nodes.len();
    doc["scenes"][0]["nodes"].as_array_mut().unwrap().extend([json!(n - 2), json!(n - 1)]);
    let path = temp("cornell-instanced.gltf", &serde_json::to_vec(&doc).unwrap());
    let settings = Settings { width: 64, height: 64, target_spp: Some(64), seed: 3, ..Settings::default() };
    let render = |policy: Instancing| {
        let mut desc = gltf::load(&path).unwrap();
        desc.apply_instancing(policy, u64::MAX).unwrap();
        let scene = Arc::new(Scene::build(desc));
        let placements = scene.geometry.instance_count();
        (common::render(&scene, scene.default_camera(1.0), settings, None), placements)
    };
    let ((instanced, placements), (flattened, none)) = (render(Instancing::Always), render(Instancing::Never));
    assert_eq!((placements, none), (4, 0));
    let z = common::sidak_z(1e-3, common::blocks(&flattened, 8).len() * 3);
    common::assert_blocks_agree(&instanced, &flattened, 8, z, "instanced against flattened");
}

#[test]
fn gpu_instancing_places_the_mesh_once_per_instance() {
    let mut desc = gltf::load(&temp("instanced.gltf", &instanced_triangle(|_| ()))).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((triangles(&desc), desc.meshes[0].instances.len()), (1, 3), "stored once, placed thrice");
    desc.apply_instancing(Instancing::Never, 3).unwrap();
    assert_eq!(triangles(&desc), 3, "one triangle per instance");
    let mut got: Vec<Vec3> =
        desc.meshes.iter().flat_map(|m| m.indices.iter().map(|&i| m.positions[i as usize])).collect();
    // The triangle (0,0,0), (1,0,0), (0,1,0) at each instance, the third turned half about z.
    let corners = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let mut want: Vec<Vec3> = corners
        .iter()
        .copied()
        .chain(corners.iter().map(|&c| c + Vec3::new(2.0, 0.0, 0.0)))
        .chain(corners.iter().map(|&c| Vec3::new(-c.x, -c.y, c.z) + Vec3::new(0.0, 0.0, -3.0)))
        .collect();
    let centre = |v: &[Vec3]| {
        let (lo, hi) = v.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        0.5 * (lo + hi)
    };
    let (cg, cw) = (centre(&got), centre(&want));
    let key = |v: &Vec3| {
        (v.x * 1e4).round() as i64 * 1_000_000_000 + (v.y * 1e4).round() as i64 * 100_000 + (v.z * 1e4).round() as i64
    };
    got.iter_mut().for_each(|v| *v -= cg);
    want.iter_mut().for_each(|v| *v -= cw);
    got.sort_by_key(key);
    want.sort_by_key(key);
    for (g, w) in got.iter().zip(&want) {
        assert!((*g - *w).length() < 1e-6, "{g} against {w}");
    }
    let bad = |edit: &dyn Fn(&mut Value), want: &str| {
        let err = gltf::load(&temp("bad-instances.gltf", &instanced_triangle(edit))).err().unwrap().to_string();
        assert!(err.contains(want) && !err.contains('\n'), "{err}");
    };
    bad(
        &|d| d["accessors"][4]["componentType"] = json!(5121),
        "accessor 4 is Vec4 of U8, which an instance rotation cannot be",
    );
    bad(&|d| d["accessors"][3]["count"] = json!(2), "nodes[0]: instance attributes have different counts");
}

#[test]
fn material_variants_switch_the_materials_they_name() {
    let mut doc: Value = serde_json::from_slice(&one_triangle(json!({"mesh": 0}), [0, 1, 2])).unwrap();
    doc["extensionsUsed"] = json!(["KHR_materials_variants"]);
    doc["extensions"] =
        json!({"KHR_materials_variants": {"variants": [{"name": "red"}, {"name": "blue"}, {"name": "plain"}]}});
    doc["materials"] = json!([
        {"name": "white"},
        {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1]}},
        {"name": "blue", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 1, 1]}}
    ]);
    let primitive = &mut doc["meshes"][0]["primitives"][0];
    primitive["material"] = json!(0);
    primitive["extensions"] = json!({"KHR_materials_variants": {"mappings": [
        {"material": 1, "variants": [0]},
        {"material": 2, "variants": [1]}
    ]}});
    let path = temp("variants.gltf", &serde_json::to_vec(&doc).unwrap());
    let load = || gltf::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let desc = load();
    assert_eq!(desc.variants, ["red", "blue", "plain"]);
    assert_eq!(desc.meshes[0].material, 0, "the default material without a variant");
    for (variant, material) in [("red", 1), ("blue", 2), ("plain", 0)] {
        let mut desc = load();
        desc.select_variant(variant).unwrap();
        assert_eq!(desc.meshes[0].material, material, "{variant}");
    }
    let err = load().select_variant("green").unwrap_err();
    assert_eq!(err, "the scene has no material variant \"green\" (its variants: red, blue, plain)");
    let options = lucent::open::OpenOptions { variant: Some("blue".into()), ..Default::default() };
    let scene = lucent::open::open(Some(&path), &options, &mut |_| {}).unwrap();
    assert_eq!(scene.geometry.attrs(0).material, 2, "open() applies the variant");
    assert_eq!(scene.variants, ["red", "blue", "plain"]);
}

#[test]
fn punctual_light_ranges_are_read_and_window_the_light() {
    let mut doc: Value = serde_json::from_slice(&one_triangle(json!({"mesh": 0}), [0, 1, 2])).unwrap();
    doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "intensity": 10.0, "range": 0.5},
        {"type": "point", "intensity": 10.0}
    ]}});
    doc["nodes"] = json!([
        {"mesh": 0},
        {"translation": [0.25, 0.25, 1.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"translation": [0.25, 0.25, 1.0], "extensions": {"KHR_lights_punctual": {"light": 1}}}
    ]);
    doc["scenes"] = json!([{"nodes": [0, 1, 2]}]);
    let path = temp("range.gltf", &serde_json::to_vec(&doc).unwrap());
    let desc = gltf::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let mut ranges: Vec<Option<f32>> = desc.lights.iter().map(|l| l.range).collect();
    ranges.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(ranges, [None, Some(0.5)]);
    // The triangle lies 1 m below both lights: past the first's range, within the second's.
    let ranged = |range: Option<f32>| {
        let mut desc = gltf::load(&path).unwrap();
        desc.lights.retain(|l| l.range == range);
        let scene = Arc::new(Scene::build(desc));
        let camera = scene.default_camera(1.0);
        let settings = Settings { width: 8, height: 8, target_spp: Some(4), ..Settings::default() };
        let snap = common::render(&scene, camera, settings, None);
        snap.mean.iter().map(|c| c.element_sum() as f64).sum::<f64>()
    };
    assert_eq!(ranged(Some(0.5)), 0.0, "out of range: no light");
    assert!(ranged(None) > 0.0, "without a range the triangle is lit");
}

#[test]
fn sixteen_bit_pngs_keep_their_sixteen_bits() {
    use image::ImageEncoder;
    // Codes that differ only in their low byte, which 8 bits would merge.
    let codes: [u16; 4] = [0x1200, 0x12ff, 0x8001, 0xfffe];
    let raw: Vec<u8> = codes.iter().flat_map(|&c| [c, c, c, u16::MAX]).flat_map(u16::to_ne_bytes).collect();
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png).write_image(&raw, 4, 1, image::ExtendedColorType::Rgba16).unwrap();
    let uri = format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&png));
    let mut doc: Value = serde_json::from_slice(&one_triangle(json!({"mesh": 0}), [0, 1, 2])).unwrap();
    doc["images"] = json!([{"uri": uri}]);
    doc["textures"] = json!([{"source": 0}]);
    let desc = gltf::load(&temp("deep.gltf", &serde_json::to_vec(&doc).unwrap())).unwrap_or_else(|e| panic!("{e}"));
    let want: Vec<[u16; 4]> = codes.iter().map(|&c| [c, c, c, u16::MAX]).collect();
    assert_eq!(desc.images[0].texels, Texels::Words(want));
}

#[test]
fn unlit_materials_show_their_base_colour_to_the_camera_and_light_nothing() {
    let mut doc: Value = serde_json::from_slice(&one_triangle(json!({"mesh": 0}), [0, 1, 2])).unwrap();
    doc["extensionsUsed"] = json!(["KHR_materials_unlit"]);
    doc["materials"] = json!([
        {"pbrMetallicRoughness": {"baseColorFactor": [0.25, 0.5, 0.75, 1.0]}, "extensions": {"KHR_materials_unlit": {}}},
        {"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0}}
    ]);
    doc["meshes"] = json!([
        {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]},
        {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 1}]}
    ]);
    // The white triangle beside the unlit one, turned to face it.
    doc["nodes"] = json!([{"mesh": 0}, {"mesh": 1, "translation": [1.2, 0.0, 0.3], "rotation": [0.0, -0.38268343, 0.0, 0.9238795]}]);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    let path = temp("unlit.gltf", &serde_json::to_vec(&doc).unwrap());
    let both = gltf::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert!(both.materials[0].unlit && !both.materials[1].unlit);
    let mut alone = gltf::load(&path).unwrap();
    alone.meshes.retain(|m| m.material == 0);
    let both = Arc::new(Scene::build(both));
    let alone = Arc::new(Scene::build(alone));
    let camera = both.default_camera(1.0);
    let settings = Settings { width: 32, height: 32, target_spp: Some(16), ..Settings::default() };
    let (a, b) = (common::render(&both, camera, settings, None), common::render(&alone, camera, settings, None));
    // Pixels wholly inside the unlit triangle show its base colour exactly.
    let base = Vec3::new(0.25, 0.5, 0.75);
    assert!(a.mean.iter().any(|&m| (m - base).abs().max_element() < 1e-6), "the base colour is seen");
    // Nothing lights the white triangle: the image is the unlit triangle's alone.
    assert_eq!(a.mean, b.mean, "the unlit triangle lights nothing");
}

/// A one-triangle glTF with one 1x1 image and `textures` textures of it, whose meshes use
/// `materials` in turn (one node each).
fn with_materials(materials: Value, textures: usize) -> common::ScratchFile {
    use image::ImageEncoder;
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&[128; 4], 1, 1, image::ExtendedColorType::Rgba8)
        .unwrap();
    let uri = format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&png));
    let mut doc: Value = serde_json::from_slice(&one_triangle(json!({"mesh": 0}), [0, 1, 2])).unwrap();
    let n = materials.as_array().unwrap().len();
    doc["extensionsUsed"] = json!([
        "KHR_materials_anisotropy",
        "KHR_materials_iridescence",
        "KHR_materials_clearcoat",
        "KHR_texture_transform"
    ]);
    doc["images"] = json!([{"uri": uri}]);
    doc["textures"] = Value::Array(vec![json!({"source": 0}); textures]);
    doc["materials"] = materials;
    doc["meshes"] = (0..n)
        .map(|m| json!({"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": m}]}))
        .collect();
    doc["nodes"] = (0..n).map(|m| json!({"mesh": m})).collect();
    doc["scenes"] = json!([{"nodes": (0..n).collect::<Vec<_>>()}]);
    temp("materials.gltf", &serde_json::to_vec(&doc).unwrap())
}

#[test]
fn anisotropy_iridescence_and_clearcoat_normals_are_read_with_the_specs_defaults_and_ranges() {
    use lucent::scene::material::TexRef;
    let materials = json!([
        {"name": "given", "extensions": {
            "KHR_materials_anisotropy": {"anisotropyStrength": 0.6, "anisotropyRotation": 1.25,
                "anisotropyTexture": {"index": 1, "texCoord": 1}},
            "KHR_materials_iridescence": {"iridescenceFactor": 0.75, "iridescenceIor": 1.8,
                "iridescenceThicknessMinimum": 250, "iridescenceThicknessMaximum": 650,
                "iridescenceTexture": {"index": 2},
                "iridescenceThicknessTexture": {"index": 3,
                    "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.25]}}}}}},
        {"name": "empty", "extensions": {"KHR_materials_anisotropy": {}, "KHR_materials_iridescence": {}}},
        {"name": "readme spelling", "extensions": {"KHR_materials_iridescence": {"iridescenceFactor": 1, "iridescenceIOR": 2.0}}},
        {"name": "wild", "extensions": {
            "KHR_materials_anisotropy": {"anisotropyStrength": 1.5, "anisotropyTexture": {"index": 9}},
            "KHR_materials_iridescence": {"iridescenceFactor": -0.5, "iridescenceIor": 0.8,
                "iridescenceThicknessMinimum": -10, "iridescenceThicknessMaximum": -1}}},
        {"name": "coat", "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1,
            "clearcoatNormalTexture": {"index": 1, "scale": 0.25}}}},
        {"name": "plain coat", "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1}}}
    ]);
    let desc = gltf::load(&with_materials(materials, 4)).unwrap_or_else(|e| panic!("{e}"));
    let [given, empty, readme, wild, coat, plain_coat] = [0, 1, 2, 3, 4, 5].map(|i| &desc.materials[i]);
    assert_eq!((given.anisotropy_strength, given.anisotropy_rotation), (0.6, 1.25));
    assert_eq!(given.anisotropy_tex.map(|t| (t.texture, t.set)), Some((1, 1)));
    assert_eq!((given.iridescence, given.iridescence_ior), (0.75, 1.8));
    assert_eq!((given.iridescence_thickness_min, given.iridescence_thickness_max), (250.0, 650.0));
    assert_eq!(given.iridescence_tex, Some(TexRef::plain(2)));
    let thickness = given.iridescence_thickness_tex.expect("thickness texture");
    assert_eq!(thickness.texture, 3);
    assert_eq!(thickness.transform.translation, glam::Vec2::new(0.5, 0.25), "KHR_texture_transform read");
    // The specs' defaults: no anisotropy, no film; a film of index 1.3 between 100 and 400 nm.
    assert_eq!((empty.anisotropy_strength, empty.anisotropy_rotation, empty.anisotropy_tex), (0.0, 0.0, None));
    assert_eq!((empty.iridescence, empty.iridescence_ior, empty.iridescence_tex), (0.0, 1.3, None));
    assert_eq!((empty.iridescence_thickness_min, empty.iridescence_thickness_max), (100.0, 400.0));
    assert_eq!(empty.iridescence_thickness_tex, None);
    assert_eq!((readme.iridescence, readme.iridescence_ior), (1.0, 2.0), "the README's iridescenceIOR");
    // Out of range: factors clamped, an index below 1 and negative thicknesses replaced by
    // the defaults, each with one warning naming the material; a missing texture is dropped.
    assert_eq!((wild.anisotropy_strength, wild.anisotropy_tex), (1.0, None));
    assert_eq!((wild.iridescence, wild.iridescence_ior), (0.0, 1.3));
    assert_eq!((wild.iridescence_thickness_min, wild.iridescence_thickness_max), (100.0, 400.0));
    for expected in [
        "\"wild\": anisotropyStrength 1.5 is outside [0, 1]: 1 used",
        "\"wild\": iridescenceFactor -0.5 is outside [0, 1]: 0 used",
        "\"wild\": iridescenceIor 0.8 is below 1: 1.3 used",
        "\"wild\": iridescenceThicknessMinimum -10 is below 0: 100 used",
        "\"wild\": iridescenceThicknessMaximum -1 is below 0: 400 used",
        "texture index 9 is out of range",
    ] {
        assert_eq!(desc.warnings.iter().filter(|w| w.contains(expected)).count(), 1, "{expected}: {:?}", desc.warnings);
    }
    assert!(desc.warnings.iter().all(|w| !w.contains("\"given\"") && !w.contains("\"empty\"")), "{:?}", desc.warnings);
    assert!(desc.warnings.iter().all(|w| !w.contains('\n')), "one line each");
    // KHR_materials_clearcoat's clearcoatNormalTexture, with its scale (1 by default).
    assert_eq!((coat.clearcoat_normal_tex, coat.clearcoat_normal_scale), (Some(TexRef::plain(1)), 0.25));
    assert_eq!((plain_coat.clearcoat_normal_tex, plain_coat.clearcoat_normal_scale), (None, 1.0));
    assert!(desc.warnings.iter().all(|w| !w.contains("not supported")), "{:?}", desc.warnings);
}

#[test]
fn what_a_material_leaves_out_is_gltfs_default() {
    use lucent::scene::{edit::Section, material::Material};
    let empty: serde_json::Map<String, Value> =
        Section::MATERIAL.iter().filter_map(|s| s.extension()).map(|e| (e.to_string(), json!({}))).collect();
    let materials = json!([{"name": "bare"}, {"name": "empty extensions", "extensions": empty}]);
    let desc = gltf::load(&with_materials(materials, 0)).unwrap_or_else(|e| panic!("{e}"));
    for m in &desc.materials[..2] {
        // glTF's default material is single-sided; Lucent's own default is double-sided.
        let default =
            Material { name: m.name.clone(), file_index: m.file_index, double_sided: false, ..Material::default() };
        assert_eq!(*m, default, "{}", m.name);
    }
    assert!(desc.warnings.iter().all(|w| !w.contains("material")), "{:?}", desc.warnings);
}

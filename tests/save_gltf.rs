//! Saving edited materials and lights as glTF (`loader::save`), view files' edits and the
//! viewer's edit API: an unedited save loads to the same scene; a save with every kind of
//! parameter and light edited loads to the edited values; everything but the edited
//! materials, lights and their nodes is kept; the Khronos glTF validator finds no error in
//! the saved files (when node and gltf-validator are installed, required where
//! LUCENT_REQUIRE_GLTF_VALIDATOR is set); bad output paths fail in one line and leave nothing.

mod common;

use glam::Vec3;
use lucent::config::ViewFile;
use lucent::film::tonemap::Display;
use lucent::integrator::Settings;
use lucent::loader::{builtin, gltf, save};
use lucent::scene::edit::{Kind, LIGHT_PARAMS, MATERIAL_PARAMS, Param, ParamValue, find, light_problem};
use lucent::scene::light::{Cone, PunctualKind, PunctualLight};
use lucent::scene::material::Material;
use lucent::scene::{Scene, SceneDesc};
use lucent::viewer::state::ViewerState;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The Cornell box with KHR_lights_punctual lights of every kind: a point and a spot light
/// under a rotated, non-uniformly scaled parent (one node with TRS, one with a matrix), a
/// directional light, the point light's entry placed again by a second node, the spot's by
/// a node that also holds a mesh; and a primitive without a material (glTF's default).
fn lights_scene(dir: &Path) -> PathBuf {
    let mut doc: Value = serde_json::from_slice(builtin::cornell_box_gltf()).unwrap();
    let nodes = doc["nodes"].as_array().unwrap().len();
    let n = |i: usize| json!(nodes + i);
    let (s, c) = (0.3f64.sin(), 0.3f64.cos());
    let matrix = [c, 0.0, -s, 0.0, 0.0, 1.0, 0.0, 0.0, s, 0.0, c, 0.0, 0.1, 0.05, 0.2, 1.0];
    let added = [
        json!({ "name": "rig", "translation": [0.2, 0.3, 0.1], "rotation": [0.0, 0.2588190451, 0.0, 0.9659258263],
                "scale": [1.5, 0.75, 1.0], "children": [n(1), n(2)] }),
        json!({ "name": "bulb", "translation": [0.05, 0.2, 0.1], "extensions": { "KHR_lights_punctual": { "light": 0 } } }),
        json!({ "name": "spot", "matrix": matrix, "extensions": { "KHR_lights_punctual": { "light": 1 } } }),
        json!({ "name": "sun", "rotation": [-0.3826834324, 0.0, 0.0, 0.9238795325], "extensions": { "KHR_lights_punctual": { "light": 2 } } }),
        json!({ "name": "bulb 2", "translation": [0.4, 0.4, 0.3], "extensions": { "KHR_lights_punctual": { "light": 0 } } }),
        json!({ "name": "lamp stand", "mesh": 6, "translation": [0.0, -1.0, 0.0],
                "extensions": { "KHR_lights_punctual": { "light": 1 } } }),
    ];
    doc["nodes"].as_array_mut().unwrap().extend(added);
    doc["scenes"][0]["nodes"].as_array_mut().unwrap().extend([n(0), n(3), n(4), n(5)]);
    doc["extensions"] = json!({ "KHR_lights_punctual": { "lights": [
        { "name": "bulb", "type": "point", "color": [1.0, 0.9, 0.8], "intensity": 2.0 },
        { "name": "spot", "type": "spot", "intensity": 5.0, "spot": { "innerConeAngle": 0.2, "outerConeAngle": 0.6 } },
        { "name": "sun", "type": "directional", "color": [1.0, 1.0, 0.9], "intensity": 3.0 },
    ] } });
    doc["extensionsUsed"].as_array_mut().unwrap().push(json!("KHR_lights_punctual"));
    doc["meshes"][7]["primitives"][0].as_object_mut().unwrap().remove("material");
    let path = dir.join("lights.gltf");
    std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    path
}

/// The scenes saved: (name, source, output extension).
fn sources(dir: &Path) -> Vec<(&'static str, Option<PathBuf>, &'static str)> {
    vec![
        ("cornell-box", None, "gltf"),
        ("cornell-box-glass", Some(common::asset("cornell-box-glass.gltf")), "gltf"),
        ("GlassVaseFlowers", Some(common::asset("GlassVaseFlowers/glTF-Binary/GlassVaseFlowers.glb")), "glb"),
        ("LightsPunctualLamp", Some(common::asset("LightsPunctualLamp/glTF/LightsPunctualLamp.gltf")), "gltf"),
        ("lights", Some(lights_scene(dir)), "gltf"),
    ]
}

/// Writes `source` with `edited` materials and lights (against `original`) to `out`.
fn save(source: Option<&Path>, original: &SceneDesc, edited: (&[Material], &[PunctualLight]), out: &Path) {
    let edits = save::Edits { original: (&original.materials, &original.lights), edited };
    let bytes = save::patched(source, edits, out).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(out, bytes).unwrap();
}

/// A valid value of `p` other than `current`, varied by `k`.
fn other_value<T>(p: &Param<T>, current: ParamValue, k: usize) -> ParamValue {
    let t = (k as f32 * 0.618_034 + 0.3).fract() * 0.8 + 0.1;
    match (p.kind, current) {
        (Kind::Number { min, max }, ParamValue::Number(x)) => {
            let (lo, hi) = (min.max(-1.0), if max < 100.0 { max } else { min.max(0.0) + 4.0 });
            let v = lo + t * (hi - lo);
            ParamValue::Number(if v == x { lo + (1.0 - t) * (hi - lo) } else { v })
        }
        (Kind::Colour { .. }, ParamValue::Triple(c)) => {
            let v = Vec3::new(t, 1.0 - t, 0.5 * t);
            ParamValue::Triple(if v == c { Vec3::new(0.5 * t, t, 1.0 - t) } else { v })
        }
        (Kind::Position, ParamValue::Triple(p)) => ParamValue::Triple(p + Vec3::new(0.1, -0.05, 0.02 * t)),
        (Kind::Direction, ParamValue::Triple(d)) => ParamValue::Triple((d + Vec3::new(0.3, 0.2 * t, -0.1)).normalize()),
        (Kind::Switch, ParamValue::Switch(b)) => ParamValue::Switch(!b),
        (Kind::Choice(names), ParamValue::Choice(c)) => {
            let i = names.iter().position(|n| *n == c).unwrap_or(0);
            ParamValue::Choice(names[(i + 1) % names.len()])
        }
        _ => unreachable!("a value of its kind"),
    }
}

/// Every applicable parameter of every material and light changed; the number changed.
/// But anisotropyStrength: above 0 it makes the loader generate tangents, which splits
/// vertices (`a_fields_range_and_path_are_the_tables_in_the_reader_view_files_and_the_writer`
/// saves it).
fn edit_everything(materials: &mut [Material], lights: &mut [PunctualLight]) -> usize {
    let mut count = 0;
    for (k, m) in materials.iter_mut().enumerate() {
        for (j, p) in MATERIAL_PARAMS.iter().enumerate().filter(|(_, p)| p.key != "anisotropy_strength") {
            if (p.applies)(m) {
                p.try_set(m, other_value(p, (p.get)(m), 7 * k + j)).unwrap_or_else(|e| panic!("{e}"));
                count += 1;
            }
        }
    }
    for (k, l) in lights.iter_mut().enumerate() {
        for (j, p) in LIGHT_PARAMS.iter().enumerate().filter(|(_, p)| !p.key.ends_with("cone_angle")) {
            if (p.applies)(l) {
                p.try_set(l, other_value(p, (p.get)(l), 5 * k + j)).unwrap_or_else(|e| panic!("{e}"));
                count += 1;
            }
        }
        if let PunctualKind::Spot(cone) = l.kind {
            l.kind = PunctualKind::Spot(Cone::new(cone.inner() + 0.05 * (k + 1) as f32, 0.9 + 0.1 * k as f32));
            assert_eq!(light_problem(l), None);
            count += 2;
        }
    }
    count
}

/// The loaded materials are the edited ones (an added default material now has its index).
fn assert_same_materials(loaded: &[Material], expected: &[Material], name: &str) {
    assert_eq!(loaded.len(), expected.len(), "{name}");
    for (i, (a, b)) in loaded.iter().zip(expected).enumerate() {
        let b = Material { file_index: b.file_index.or(Some(i as u32)), ..b.clone() };
        assert_eq!(*a, b, "{name}: material {i}");
    }
}

/// The loaded lights are the edited ones: colour, intensity and cone exactly, position and
/// direction within the f32 rounding of the node's transform (relative 1e-5 of the scene).
fn assert_same_lights(loaded: &[PunctualLight], expected: &[PunctualLight], scale: f32, name: &str) {
    assert_eq!(loaded.len(), expected.len(), "{name}");
    for (a, b) in loaded.iter().zip(expected) {
        assert_eq!((&a.name, a.kind, a.color, a.intensity), (&b.name, b.kind, b.color, b.intensity), "{name}");
        if a.kind != PunctualKind::Directional {
            assert!(
                (a.position - b.position).length() <= 1e-5 * scale,
                "{name}: {} at {} not {}",
                a.name,
                a.position,
                b.position
            );
        }
        assert!(
            (a.direction - b.direction).length() <= 1e-5,
            "{name}: {} along {} not {}",
            a.name,
            a.direction,
            b.direction
        );
    }
}

fn extent(desc: &SceneDesc) -> f32 {
    let points = desc.meshes.iter().flat_map(|m| &m.positions).chain(desc.lights.iter().map(|l| &l.position));
    points.fold(1.0f32, |r, p| r.max(p.abs().max_element()))
}

#[test]
fn an_unedited_save_loads_to_the_same_scene_and_keeps_every_byte_of_data() {
    let dir = common::scratch("save-unedited");
    for (name, source, ext) in sources(&dir) {
        let original = source.as_deref().map_or_else(builtin::cornell_box, common::load);
        let out = dir.join(format!("{name}.saved.{ext}"));
        save(source.as_deref(), &original, (&original.materials, &original.lights), &out);
        let loaded = gltf::load(&out).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(loaded.materials, original.materials, "{name}");
        assert_eq!(loaded.lights, original.lights, "{name}");
        assert_eq!(loaded.cameras, original.cameras, "{name}");
        assert_eq!(loaded.meshes.len(), original.meshes.len(), "{name}");
        for (a, b) in loaded.meshes.iter().zip(&original.meshes) {
            assert_eq!((&a.positions, &a.indices, &a.normals, &a.uvs), (&b.positions, &b.indices, &b.normals, &b.uvs));
        }
        assert_eq!(loaded.images.len(), original.images.len(), "{name}");
        for (a, b) in loaded.images.iter().zip(&original.images) {
            assert_eq!(a.texels, b.texels, "{name}: the images are the same files");
        }
        let (before, after) = (json_of(source.as_deref()), json_of(Some(&out)));
        if name == "LightsPunctualLamp" {
            // Saved in another folder: only its buffer's and images' URIs change.
            assert_kept(&before, &after, &[], name);
            assert_eq!(after["materials"], before["materials"], "{name}");
            assert_eq!(
                after["buffers"][0]["uri"],
                json!(relative_to(&dir, source.as_deref().unwrap(), "LightsPunctualLamp.data.bin"))
            );
        } else {
            assert_eq!(after, before, "{name}: nothing edited, nothing changed");
        }
        if ext == "glb" {
            let bin = |p: &Path| glb_bin(&std::fs::read(p).unwrap());
            assert_eq!(bin(&out), bin(source.as_deref().unwrap()), "{name}: the BIN chunk is the same bytes");
        }
    }
}

/// The URI of file `name` beside `source`, seen from folder `from` (both under the temporary
/// folder's and the repository's common ancestors).
fn relative_to(from: &Path, source: &Path, name: &str) -> String {
    let from = std::fs::canonicalize(from).unwrap();
    let target = std::fs::canonicalize(source.parent().unwrap()).unwrap().join(name);
    let common = from.components().zip(target.components()).take_while(|(a, b)| a == b).count();
    let up = vec![".."; from.components().count() - common];
    let down: Vec<String> =
        target.components().skip(common).map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    [up.into_iter().map(String::from).collect::<Vec<_>>(), down].concat().join("/")
}

/// The BIN chunk of a GLB (glTF 2.0 section 4.4: a 12-byte header, then chunks of length,
/// type and data).
fn glb_bin(bytes: &[u8]) -> Vec<u8> {
    let mut at = 12;
    while at + 8 <= bytes.len() {
        let len = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        if &bytes[at + 4..at + 8] == b"BIN\0" {
            return bytes[at + 8..at + 8 + len].to_vec();
        }
        at += 8 + len;
    }
    panic!("no BIN chunk")
}

/// The JSON of a .gltf or .glb (None: the built-in Cornell box).
fn json_of(path: Option<&Path>) -> Value {
    let bytes = path.map_or_else(|| builtin::cornell_box_gltf().to_vec(), |p| std::fs::read(p).unwrap());
    if bytes.starts_with(b"glTF") {
        let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        serde_json::from_slice(&bytes[20..20 + len]).unwrap()
    } else {
        serde_json::from_slice(&bytes).unwrap()
    }
}

#[test]
fn every_edited_parameter_and_light_loads_back_as_edited_and_everything_else_is_kept() {
    let dir = common::scratch("save-edited");
    for (name, source, ext) in sources(&dir) {
        let original = source.as_deref().map_or_else(builtin::cornell_box, common::load);
        let (mut materials, mut lights) = (original.materials.clone(), original.lights.clone());
        let edits = edit_everything(&mut materials, &mut lights);
        assert!(edits > 20 * materials.len(), "{name}: {edits} edits");
        let out = dir.join(format!("{name}.tuned.{ext}"));
        save(source.as_deref(), &original, (&materials, &lights), &out);
        let loaded = gltf::load(&out).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_same_materials(&loaded.materials, &materials, name);
        assert_same_lights(&loaded.lights, &lights, extent(&original), name);
        assert_eq!(loaded.meshes.len(), original.meshes.len(), "{name}");
        for (a, b) in loaded.meshes.iter().zip(&original.meshes) {
            assert_eq!((&a.positions, &a.indices, &a.normals), (&b.positions, &b.indices, &b.normals), "{name}");
        }
        assert_kept(&json_of(source.as_deref()), &json_of(Some(&out)), &original.lights, name);
    }
}

/// Everything outside the materials, the lights and the nodes placing them is as it was
/// (buffers and images but for their URIs, which may be rebased).
fn assert_kept(before: &Value, after: &Value, lights: &[PunctualLight], name: &str) {
    let light_nodes: Vec<usize> = lights.iter().filter_map(|l| l.source).map(|s| s.node as usize).collect();
    for (key, value) in before.as_object().unwrap() {
        match key.as_str() {
            "materials" => {}
            "extensionsUsed" => {
                let used = after[key].as_array().unwrap();
                assert!(value.as_array().unwrap().iter().all(|e| used.contains(e)), "{name}: extensions kept");
            }
            "extensions" => {
                for (ext, v) in value.as_object().unwrap() {
                    if ext != "KHR_lights_punctual" {
                        assert_eq!(&after[key][ext], v, "{name}: {ext}");
                    }
                }
            }
            "nodes" => {
                for (i, node) in value.as_array().unwrap().iter().enumerate() {
                    if !light_nodes.contains(&i) {
                        assert_eq!(&after[key][i], node, "{name}: node {i}");
                    }
                }
            }
            "meshes" => {
                // Primitives without a material name the added default material.
                let mut meshes = after[key].clone();
                for (m, mesh) in value.as_array().unwrap().iter().enumerate() {
                    for (p, prim) in mesh["primitives"].as_array().unwrap().iter().enumerate() {
                        if prim.get("material").is_none() {
                            let added = meshes[m]["primitives"][p].as_object_mut().unwrap().remove("material");
                            assert_eq!(added, Some(json!(before["materials"].as_array().unwrap().len())), "{name}");
                        }
                    }
                }
                assert_eq!(&meshes, value, "{name}: meshes");
            }
            "buffers" | "images" => {
                let strip = |v: &Value| {
                    let mut v = v.clone();
                    v.as_array_mut()
                        .unwrap()
                        .iter_mut()
                        .for_each(|item| _ = item.as_object_mut().unwrap().remove("uri"));
                    v
                };
                assert_eq!(strip(&after[key]), strip(value), "{name}: {key}");
            }
            _ => assert_eq!(&after[key], value, "{name}: {key}"),
        }
    }
}

/// The validator's error count per file: None (the test is skipped, saying so) without node
/// and gltf-validator, unless LUCENT_REQUIRE_GLTF_VALIDATOR is set.
fn validate(files: &[PathBuf]) -> Option<Vec<(usize, String)>> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/gltf-validate.js");
    let global = Command::new("npm").args(["root", "-g"]).output().ok().filter(|o| o.status.success());
    let node_path = global.map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string()).unwrap_or_default();
    let run = Command::new("node").arg(&script).args(files).env("NODE_PATH", node_path).output();
    let required = std::env::var_os("LUCENT_REQUIRE_GLTF_VALIDATOR").is_some();
    match run {
        Ok(out) if out.status.success() => {
            let text = String::from_utf8_lossy(&out.stdout).into_owned();
            let mut reports: Vec<(usize, String)> = Vec::new();
            for line in text.lines() {
                match line.strip_prefix("  ") {
                    Some(issue) => reports.last_mut().unwrap().1 += &format!("; {issue}"),
                    None => reports.push((line.split(' ').next().unwrap().parse().unwrap(), line.into())),
                }
            }
            assert_eq!(reports.len(), files.len(), "{text}");
            Some(reports)
        }
        other => {
            let why = match other {
                Ok(out) => String::from_utf8_lossy(&out.stderr).trim().to_string(),
                Err(e) => format!("node: {e}"),
            };
            assert!(!required, "LUCENT_REQUIRE_GLTF_VALIDATOR is set but the validator cannot run: {why}");
            eprintln!("skipping the glTF validator check: {why}");
            None
        }
    }
}

#[test]
fn the_khronos_validator_finds_no_error_in_saved_files() {
    let dir = common::scratch("save-validate");
    let mut files = Vec::new();
    for (name, source, ext) in sources(&dir) {
        let original = source.as_deref().map_or_else(builtin::cornell_box, common::load);
        let (mut materials, mut lights) = (original.materials.clone(), original.lights.clone());
        edit_everything(&mut materials, &mut lights);
        let out = dir.join(format!("{name}.tuned.{ext}"));
        save(source.as_deref(), &original, (&materials, &lights), &out);
        files.push(out);
    }
    let Some(reports) = validate(&files) else { return };
    for (errors, report) in reports {
        assert_eq!(errors, 0, "{report}");
    }
    // And the check can fail: a material with a roughness of 2 is an error.
    let mut doc = json_of(Some(&files[0]));
    doc["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = json!(2.0);
    let bad = dir.join("bad.gltf");
    std::fs::write(&bad, serde_json::to_vec(&doc).unwrap()).unwrap();
    let reports = validate(std::slice::from_ref(&bad)).unwrap();
    assert!(reports[0].0 > 0, "{}", reports[0].1);
}

/// clearcoatRoughnessFactor's range and place are `MATERIAL_PARAMS`' in all three places:
/// the reader clamps a file's value beyond the range into it with a warning naming the
/// range, a view file refuses that value with the same range, and the writer refuses it too
/// and writes an edit where KHR_materials_clearcoat keeps it (with anisotropyStrength,
/// which `edit_everything` leaves out).
#[test]
fn a_fields_range_and_path_are_the_tables_in_the_reader_view_files_and_the_writer() {
    let dir = common::scratch("save-table");
    let p = find(MATERIAL_PARAMS, "clearcoat_roughness").unwrap();
    let Kind::Number { min, max } = p.kind else { panic!("clearcoat_roughness is a number") };
    let beyond = max + 0.5;
    let mut doc: Value = serde_json::from_slice(builtin::cornell_box_gltf()).unwrap();
    let coat = json!({ "clearcoatFactor": 1.0, "clearcoatRoughnessFactor": beyond });
    doc["materials"][0]["extensions"] = json!({ "KHR_materials_clearcoat": coat });
    let source = dir.join("coat.gltf");
    std::fs::write(&source, serde_json::to_vec(&doc).unwrap()).unwrap();
    let desc = gltf::load(&source).unwrap_or_else(|e| panic!("{e}"));
    let name = &desc.materials[0].name;
    assert_eq!(desc.materials[0].clearcoat_roughness, max, "clamped into the table's range");
    let warning = format!("material {name:?}: clearcoatRoughnessFactor {beyond} is outside [{min}, {max}]: {max} used");
    assert!(desc.warnings.contains(&warning), "{warning}: {:?}", desc.warnings);

    let view = |value: f32| {
        let path = dir.join("v.toml");
        std::fs::write(&path, format!("[[materials]]\nindex = 0\nname = {name:?}\nclearcoat_roughness = {value:?}\n"))
            .unwrap();
        ViewFile::load(&path).and_then(|v| v.apply_edits(&mut desc.materials.clone(), &mut desc.lights.clone()))
    };
    let refused = view(beyond).unwrap_err();
    assert!(refused.contains(&format!("clearcoat_roughness: {beyond} is not {}", p.kind.range())), "{refused}");
    view(max).unwrap_or_else(|e| panic!("{e}"));

    let out = dir.join("saved.gltf");
    let mut edited = desc.materials.clone();
    let patched = |edited: &[Material]| {
        save::patched(
            Some(&source),
            save::Edits { original: (&desc.materials, &desc.lights), edited: (edited, &desc.lights) },
            &out,
        )
    };
    edited[0].clearcoat_roughness = beyond;
    let refused = patched(&edited).unwrap_err();
    assert!(refused.contains(&format!("clearcoatRoughnessFactor: {beyond} is not {}", p.kind.range())), "{refused}");
    edited[0].clearcoat_roughness = (min + max) / 2.0;
    edited[0].anisotropy_strength = 0.75;
    std::fs::write(&out, patched(&edited).unwrap_or_else(|e| panic!("{e}"))).unwrap();
    let saved = &json_of(Some(&out))["materials"][0]["extensions"];
    let written = saved["KHR_materials_clearcoat"]["clearcoatRoughnessFactor"].as_f64();
    assert_eq!(written.map(|x| x as f32), Some((min + max) / 2.0));
    assert_eq!(saved["KHR_materials_anisotropy"]["anisotropyStrength"], json!(0.75));
    let loaded = gltf::load(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_same_materials(&loaded.materials, &edited, "coat");
}

#[test]
fn bad_output_paths_fail_in_one_line_and_leave_nothing() {
    let dir = common::scratch("save-hostile");
    let desc = builtin::cornell_box();
    let mut materials = desc.materials.clone();
    materials[0].roughness = 0.25;
    let edits = save::Edits { original: (&desc.materials, &desc.lights), edited: (&materials, &desc.lights) };
    let err = save::patched(None, edits, &dir.join("box.glb")).unwrap_err();
    assert!(err.contains("must end in .gltf") && !err.contains('\n'), "{err}");
    let glb = common::asset("Box/glTF-Binary/Box.glb");
    let boxed = gltf::load(&glb).unwrap();
    let box_edits =
        save::Edits { original: (&boxed.materials, &boxed.lights), edited: (&boxed.materials, &boxed.lights) };
    assert!(save::patched(Some(&glb), box_edits, &dir.join("box.gltf")).unwrap_err().contains("must end in .glb"));
    let lucent = |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_lucent")).args(args).output().unwrap();
    let view = dir.join("v.toml");
    std::fs::write(&view, "[[materials]]\nindex = 0\nname = \"white\"\nroughness = 0.25\n").unwrap();
    let blocker = dir.join("a-file");
    std::fs::write(&blocker, b"x").unwrap();
    for out in [dir.join("missing/box.gltf"), blocker.join("box.gltf"), dir.to_path_buf(), dir.join("box.glb")] {
        let run = lucent(&["render", "--view", view.to_str().unwrap(), "--save-gltf", out.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{}", out.display());
        assert_eq!(stderr.trim().lines().count(), 1, "one line: {stderr}");
        assert!(stderr.starts_with("error: ") && stderr.contains(&*out.to_string_lossy()), "{stderr}");
    }
    let left: Vec<_> = std::fs::read_dir(&*dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left.len(), 2, "only the view file and the blocker, no partial file: {left:?}");
}

#[test]
fn render_applies_a_view_files_edits_as_the_saved_gltf_holds_them() {
    let dir = common::scratch("save-view");
    let lucent = |args: &[&str]| {
        let run = Command::new(env!("CARGO_BIN_EXE_lucent")).args(args).output().unwrap();
        (run.status.success(), String::from_utf8_lossy(&run.stderr).into_owned())
    };
    let path = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let edits = "[[materials]]\nindex = 1\nname = \"red\"\nbase_color = [0.1, 0.2, 0.9]\nroughness = 0.3\n\n\
                 [[materials]]\nindex = 3\nname = \"light\"\nemissive_strength = 8.5\n";
    std::fs::write(dir.join("edits.toml"), edits).unwrap();
    let common = ["--spp", "4", "--width", "24", "--height", "24", "--threads", "1"];
    let (ok, err) = lucent(
        &[
            &["render", "--view", &path("edits.toml"), "--save-gltf", &path("tuned.gltf")][..],
            &common,
            &["--out", &path("edited.exr")],
        ]
        .concat(),
    );
    assert!(ok, "{err}");
    let (ok, err) = lucent(&[&["render", &path("tuned.gltf")][..], &common, &["--out", &path("saved.exr")]].concat());
    assert!(ok, "{err}");
    let (ok, err) = lucent(&[&["render"][..], &common, &["--out", &path("plain.exr")]].concat());
    assert!(ok, "{err}");
    let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
    assert!(read("edited.exr") == read("saved.exr"), "the view file's edits render as the saved file does");
    assert!(read("edited.exr") != read("plain.exr"), "the edits change the image");
    // --save-gltf alone renders nothing.
    let (ok, err) = lucent(&["render", "--view", &path("edits.toml"), "--save-gltf", &path("only.gltf")]);
    assert!(ok && dir.join("only.gltf").is_file(), "{err}");
    // A material the scene does not have is named in one line.
    std::fs::write(dir.join("bad.toml"), "[[materials]]\nindex = 7\nname = \"Gold\"\nroughness = 0.1\n").unwrap();
    let (ok, err) =
        lucent(&[&["render", "--view", &path("bad.toml")][..], &common, &["--out", &path("x.png")]].concat());
    assert!(!ok && err.trim().lines().count() == 1 && err.contains("material 7 \"Gold\""), "{err}");
    std::fs::write(dir.join("bad.toml"), "[[materials]]\nindex = 1\nname = \"red\"\nroughnes = 0.1\n").unwrap();
    let (ok, err) =
        lucent(&[&["render", "--view", &path("bad.toml")][..], &common, &["--out", &path("x.png")]].concat());
    assert!(!ok && err.contains("unknown parameter \"roughnes\""), "{err}");
}

#[test]
fn the_viewer_state_saves_and_reloads_its_edits_through_view_files_and_gltf() {
    let dir = common::scratch("save-viewer");
    let source = lights_scene(&dir);
    let scene = lucent::open(Some(&source), &Default::default(), &mut |_| {}).unwrap();
    let settings = Settings { width: 16, height: 16, ..Settings::default() };
    let viewer = |scene: Scene| {
        ViewerState::new(scene, Some(source.clone()), settings, true, Display::default(), None, Some(1)).unwrap()
    };
    let mut state = viewer(scene);
    assert_eq!(state.gltf_path, dir.join("lights.tuned.gltf").display().to_string(), "beside the scene");
    let geometry = std::sync::Arc::clone(&state.scene.geometry);
    state.edit(|materials, lights| _ = edit_everything(materials, lights));
    assert!(state.edited() && std::sync::Arc::ptr_eq(&geometry, &state.scene.geometry));
    let edited = (state.scene.materials.clone(), state.scene.lights.clone());
    state.view_path = dir.join("view.toml").display().to_string();
    state.save_view().unwrap();
    let saved = state.save_gltf().unwrap();
    state.reset_edits();
    assert!(!state.edited());
    state.load_view().unwrap();
    assert_eq!(state.scene.materials, edited.0, "a view file holds every material edit");
    assert_same_lights(&state.scene.lights, &edited.1, 1.0, "view file");
    let view = ViewFile::load(Path::new(&state.view_path)).unwrap();
    assert_eq!(view.materials.len(), edited.0.len());
    let loaded = gltf::load(&saved).unwrap();
    assert_same_materials(&loaded.materials, &edited.0, "viewer");
    assert_same_lights(&loaded.lights, &edited.1, extent(&loaded), "viewer");
    // A view file naming a material the scene lacks is refused and changes nothing.
    std::fs::write(&state.view_path, "[[materials]]\nindex = 0\nname = \"marble\"\nroughness = 0.5\n").unwrap();
    let err = state.load_view().unwrap_err();
    assert!(err.contains("material 0 \"marble\"") && err.contains("\"white\""), "{err}");
    assert_eq!(state.scene.materials, edited.0);
    // A bad path shows its error and writes nothing.
    state.gltf_path = dir.join("nowhere/x.gltf").display().to_string();
    assert!(state.save_gltf().unwrap_err().contains("nowhere"));
}

//! glTF files re-encoded by glTF Transform (tests/assets/quantized, see its INDEX.md) load
//! into the scene their source describes: KHR_mesh_quantization's integer attributes
//! dequantize to the source's within the quantization step, and render alike.

mod common;

use base64::Engine;
use glam::{IVec3, Vec3};
use lucent::integrator::Settings;
use lucent::loader::gltf;
use lucent::scene::environment::{EnvSettings, Environment};
use lucent::scene::{Scene, SceneDesc};
use serde_json::{Value, json};
use std::collections::HashMap;
use std::sync::Arc;

/// How far a re-encoded attribute may be from its source: one step of a b-bit code over an
/// extent is extent / (2^b - 1). glTF Transform's defaults: positions 14 bits over each mesh's
/// box, texture coordinates 12 bits over [0, 1], and unit vectors 10 bits per component as
/// plain integers or, under meshopt's octahedral filter at 4 bytes, 8-bit codes (127 steps per
/// unit) in two components, which the octahedral map stretches by at most 3 (sqrt 3 for the
/// lift onto the octahedron, sqrt 3 for the projection onto the sphere), with rounding of at
/// most half a step in each: 3 x sqrt(2) / 2 / 127. Draco quantizes positions and texture
/// coordinates at the same depths over each attribute's range.
struct Steps {
    normal: f32,
}

const QUANTIZE: Steps = Steps { normal: 2.0 / 1023.0 };
/// Draco stores normals as 10-bit octahedral codes (2 / 1023 per step over [-1, 1]).
const DRACO: Steps = Steps { normal: 3.0 * std::f32::consts::FRAC_1_SQRT_2 * 2.0 / 1023.0 };
const MESHOPT: Steps = Steps { normal: 3.0 * std::f32::consts::FRAC_1_SQRT_2 / 127.0 };

fn step(extent: f32, bits: i32) -> f32 {
    extent / (2f32.powi(bits) - 1.0)
}

/// A triangle's corners, for matching: (mesh, vertex indices).
type Corners = (usize, [usize; 3]);

/// Asserts that each triangle of `q` is one of `p`'s, the same corners in the same cyclic
/// order (the winding), matched one to one, with positions within one step of the scene's
/// extent (each mesh's own step is smaller, and re-centring on the bounds moves by at most
/// half a step), and normals, tangents and texture coordinates within `steps` per component.
/// Re-encoders may reorder vertices and triangles, so triangles are matched by their centroid
/// on a grid.
fn assert_same_meshes(p: &SceneDesc, q: &SceneDesc, steps: &Steps, label: &str) {
    let bounds = p
        .meshes
        .iter()
        .flat_map(|m| &m.positions)
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    let extent = (bounds.1 - bounds.0).max_element();
    let (dp, duv) = (step(extent, 14), step(1.0, 12));
    assert_eq!(p.meshes.len(), q.meshes.len(), "{label}: meshes");
    let triangles = |d: &SceneDesc| -> Vec<Corners> {
        d.meshes
            .iter()
            .enumerate()
            .flat_map(|(m, mesh)| {
                mesh.indices.chunks_exact(3).map(move |t| (m, [t[0] as usize, t[1] as usize, t[2] as usize]))
            })
            .collect()
    };
    let corner = |d: &SceneDesc, (m, t): Corners, k: usize| d.meshes[m].positions[t[k]];
    let centroid = |d: &SceneDesc, c: Corners| (corner(d, c, 0) + corner(d, c, 1) + corner(d, c, 2)) / 3.0;
    let cell_size = 4.0 * dp;
    let cell = |v: Vec3| (v / cell_size).floor().as_ivec3();
    let (tp, tq) = (triangles(p), triangles(q));
    assert_eq!(tp.len(), tq.len(), "{label}: triangles");
    let mut grid: HashMap<IVec3, Vec<usize>> = HashMap::new();
    for (i, &c) in tp.iter().enumerate() {
        grid.entry(cell(centroid(p, c))).or_default().push(i);
    }
    let mut used = vec![false; tp.len()];
    let near = |a: Vec3, b: Vec3, d: f32| (a - b).abs().max_element() <= d;
    for &cq in &tq {
        let home = cell(centroid(q, cq));
        let found = (-1..=1)
            .flat_map(|x| (-1..=1).flat_map(move |y| (-1..=1).map(move |z| home + IVec3::new(x, y, z))))
            .flat_map(|c| grid.get(&c).into_iter().flatten())
            .flat_map(|&i| (0..3).map(move |r| (i, r)))
            .find(|&(i, r)| {
                !used[i] && tp[i].0 == cq.0 && (0..3).all(|k| near(corner(p, tp[i], (k + r) % 3), corner(q, cq, k), dp))
            });
        let Some((i, r)) = found else {
            panic!("{label}: mesh {} triangle at {} has no match within {dp:e}", cq.0, centroid(q, cq));
        };
        used[i] = true;
        let (a, b) = (&p.meshes[cq.0], &q.meshes[cq.0]);
        for k in 0..3 {
            let (vi, vj) = (tp[i].1[(k + r) % 3], cq.1[k]);
            if let (Some(na), Some(nb)) = (&a.normals, &b.normals) {
                assert!(near(na[vi], nb[vj], steps.normal), "{label}: normal {} against {}", nb[vj], na[vi]);
            }
            if let (Some(ta), Some(tb)) = (&a.tangents, &b.tangents) {
                let same = near(ta[vi].truncate(), tb[vj].truncate(), steps.normal) && ta[vi].w == tb[vj].w;
                assert!(same, "{label}: tangent {} against {}", tb[vj], ta[vi]);
            }
            if let (Some(ua), Some(ub)) = (&a.uvs, &b.uvs) {
                assert!((ua[vi] - ub[vj]).abs().max_element() <= duv, "{label}: uv {} against {}", ub[vj], ua[vi]);
            }
        }
    }
    for (m, (a, b)) in p.meshes.iter().zip(&q.meshes).enumerate() {
        assert_eq!(a.material, b.material, "{label}: mesh {m}: material");
        assert_eq!(a.normals.is_some(), b.normals.is_some(), "{label}: mesh {m}: normals");
        assert_eq!(a.tangents.is_some(), b.tangents.is_some(), "{label}: mesh {m}: tangents");
        assert_eq!(a.uvs.is_some(), b.uvs.is_some(), "{label}: mesh {m}: uvs");
    }
}

#[test]
fn re_encoded_cornell_glass_has_its_sources_triangles_within_a_step() {
    let p = common::load("cornell-box-glass.gltf");
    let variants = [
        ("quantized/cornell-box-glass.gltf", QUANTIZE),
        ("meshopt/cornell-box-glass.gltf", MESHOPT),
        ("draco/cornell-box-glass.gltf", DRACO),
    ];
    for (file, steps) in variants {
        let q = common::load(file);
        assert_same_meshes(&p, &q, &steps, file);
        let names = |d: &SceneDesc| d.materials.iter().map(|m| m.name.clone()).collect::<Vec<_>>();
        assert_eq!(names(&p), names(&q), "{file}");
    }
}

#[test]
fn re_encoded_water_bottles_have_their_sources_attributes_within_a_step_and_render_alike() {
    let p = common::load("WaterBottle/glTF/WaterBottle.gltf");
    let sky = || Environment::load(EnvSettings { background: Vec3::ONE, ..EnvSettings::default() }).unwrap();
    let settings = |seed| Settings { width: 48, height: 48, seed, target_spp: Some(64), ..Settings::default() };
    let plain = Arc::new(Scene::build(common::load("WaterBottle/glTF/WaterBottle.gltf")).with_environment(Some(sky())));
    let camera = plain.default_camera(1.0);
    let reference = common::render(&plain, camera, settings(1), None);
    let variants = [
        ("quantized/WaterBottle.glb", QUANTIZE),
        ("meshopt/WaterBottle.glb", MESHOPT),
        ("draco/WaterBottle.glb", DRACO),
    ];
    let z_max = common::sidak_z(1e-3, variants.len() * 36 * 3);
    for (seed, (file, steps)) in variants.into_iter().enumerate() {
        let q = common::load(file);
        assert!(q.meshes[0].tangents.is_some() && q.meshes[0].uvs.is_some(), "{file}: integer tangents and uvs");
        assert_same_meshes(&p, &q, &steps, file);
        let q = Arc::new(Scene::build(q).with_environment(Some(sky())));
        let image = common::render(&q, camera, settings(2 + seed as u64), None);
        common::assert_blocks_agree(&image, &reference, 8, z_max, file);
    }
}

/// A one-triangle glTF whose EXT_meshopt_compression views hold f32 positions under the
/// exponential filter (stride 12), u32 indices as an index sequence, and an unread stream of
/// quaternions, over a fallback buffer without data; `edit` changes the document.
fn meshopt_triangle(positions: [[f32; 3]; 3], edit: impl Fn(&mut Value)) -> Vec<u8> {
    use meshopt::encoding::{self as codec, EncodeExpMode};
    let exp = codec::encode_filter_exp(&positions, 24, EncodeExpMode::Separate);
    let vertices = codec::encode_vertex_buffer(&exp).unwrap();
    let indices = codec::encode_index_sequence(&[0, 1, 2], 3).unwrap();
    let quaternions = codec::encode_vertex_buffer(&codec::encode_filter_quat(&[[0.0, 0.0, 0.0, 1.0]], 12)).unwrap();
    let mut bytes = Vec::new();
    let mut append = |b: &[u8]| {
        let at = bytes.len();
        bytes.extend_from_slice(b);
        bytes.resize(bytes.len().next_multiple_of(4), 0);
        (at, b.len())
    };
    let (v, i, q) = (append(&vertices), append(&indices), append(&quaternions));
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bytes));
    let ext = |(at, len): (usize, usize), stride: u32, mode: &str, filter: &str| {
        json!({"EXT_meshopt_compression": {
            "buffer": 0, "byteOffset": at, "byteLength": len, "byteStride": stride, "count": 3 - 2 * u32::from(stride == 8),
            "mode": mode, "filter": filter
        }})
    };
    let (lo, hi) = positions.iter().fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), p| {
        (std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k])))
    });
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["EXT_meshopt_compression"],
        "extensionsRequired": ["EXT_meshopt_compression"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [
            {"byteLength": bytes.len(), "uri": uri},
            {"byteLength": 56, "extensions": {"EXT_meshopt_compression": {"fallback": true}}}
        ],
        "bufferViews": [
            {"buffer": 1, "byteOffset": 0, "byteLength": 36, "byteStride": 12, "extensions": ext(v, 12, "ATTRIBUTES", "EXPONENTIAL")},
            {"buffer": 1, "byteOffset": 36, "byteLength": 12, "extensions": ext(i, 4, "INDICES", "NONE")},
            {"buffer": 1, "byteOffset": 48, "byteLength": 8, "extensions": ext(q, 8, "ATTRIBUTES", "QUATERNION")}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}
        ]
    });
    edit(&mut doc);
    serde_json::to_vec(&doc).unwrap()
}

fn temp(name: &str, bytes: &[u8]) -> common::ScratchFile {
    common::scratch_file("variants", name, bytes)
}

#[test]
fn meshopt_filters_and_index_sequences_decode_to_the_encoded_values() {
    let positions = [[0.0, 0.0, 0.0], [1.5, 0.0, 0.0], [0.0, 0.25, -3.0]];
    let desc =
        gltf::load(&temp("meshopt.gltf", &meshopt_triangle(positions, |_| ()))).unwrap_or_else(|e| panic!("{e}"));
    let mesh = &desc.meshes[0];
    assert_eq!(mesh.indices.len(), 3);
    let corners: Vec<Vec3> = mesh.indices.iter().map(|&i| mesh.positions[i as usize]).collect();
    // Re-centred on the bounds, the exponential filter's 24-bit mantissas keep these exactly.
    let centre = Vec3::new(0.75, 0.125, -1.5);
    for (got, want) in corners.iter().zip(positions) {
        assert_eq!(*got, Vec3::from(want) - centre);
    }
}

#[test]
fn bad_meshopt_streams_are_refused_in_one_line() {
    let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "count.gltf",
            meshopt_triangle(p, |d| {
                d["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["count"] = json!(1u64 << 40)
            }),
            "bufferViews[0].extensions.EXT_meshopt_compression: 1099511627776 elements of 12 bytes do not fit the view's byteLength",
        ),
        (
            // Within the view's (lying) byteLength, but no meshopt stream of its few bytes
            // decodes to 805 MB: refused before anything is allocated.
            "lying.gltf",
            meshopt_triangle(p, |d| {
                d["bufferViews"][0]["byteLength"] = json!(12u64 << 26);
                d["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["count"] = json!(1u64 << 26)
            }),
            "bufferViews[0].extensions.EXT_meshopt_compression: 67108864 elements of 12 bytes cannot come from",
        ),
        (
            "outside.gltf",
            meshopt_triangle(p, |d| {
                d["bufferViews"][1]["extensions"]["EXT_meshopt_compression"]["byteOffset"] = json!(1 << 20)
            }),
            "bufferViews[1].extensions.EXT_meshopt_compression names bytes outside a readable buffer",
        ),
        (
            "stride.gltf",
            meshopt_triangle(p, |d| {
                let e = &mut d["bufferViews"][1]["extensions"]["EXT_meshopt_compression"];
                e["byteStride"] = json!(3);
            }),
            "(mode INDICES, filter NONE): byteStride 3 is not one this mode and filter allow",
        ),
        (
            "garbage.gltf",
            meshopt_triangle(p, |d| {
                d["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["byteLength"] = json!(3)
            }),
            "bufferViews[0].extensions.EXT_meshopt_compression (mode ATTRIBUTES, filter EXPONENTIAL): ",
        ),
    ];
    for (name, bytes, want) in cases {
        let err = gltf::load(&temp(name, &bytes)).err().unwrap_or_else(|| panic!("{name}: loaded")).to_string();
        assert!(err.contains(want) && !err.contains('\n'), "{name}: {err}");
    }
}

/// The Draco glass box with `edit` applied to its JSON and `garble` to its buffer, written
/// beside a copy of its buffer.
fn draco_box(name: &str, edit: impl Fn(&mut Value), garble: impl Fn(&mut Vec<u8>, &Value)) -> common::ScratchFile {
    let dir = common::asset("draco");
    let mut doc: Value = serde_json::from_slice(&std::fs::read(dir.join("cornell-box-glass.gltf")).unwrap()).unwrap();
    let mut bin = std::fs::read(dir.join("cornell-box-glass.bin")).unwrap();
    edit(&mut doc);
    garble(&mut bin, &doc);
    let out = temp(&format!("{name}.gltf"), &serde_json::to_vec(&doc).unwrap());
    std::fs::write(out.with_file_name("cornell-box-glass.bin"), &bin).unwrap();
    out
}

#[test]
fn bad_draco_streams_are_refused_in_one_line() {
    let ext = |d: &mut Value| -> Value {
        d["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"].clone()
    };
    let cases: Vec<(&str, common::ScratchFile, &str)> = vec![
        (
            "short",
            draco_box(
                "short",
                |d| {
                    let view = ext(d)["bufferView"].as_u64().unwrap() as usize;
                    d["bufferViews"][view]["byteLength"] = json!(12);
                },
                |_, _| (),
            ),
            "the Draco stream does not decode",
        ),
        (
            "uid",
            draco_box(
                "uid",
                |d| {
                    d["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"]["POSITION"] =
                        json!(99)
                },
                |_, _| (),
            ),
            "attribute POSITION: no Draco attribute 99",
        ),
    ];
    for (name, path, want) in cases {
        let err = gltf::load(&path).err().unwrap_or_else(|| panic!("{name}: loaded")).to_string();
        assert!(err.contains(want) && !err.contains('\n'), "{name}: {err}");
    }
    // Garbled streams may still decode (to other geometry); each sphere's, garbled eight
    // ways, must load or be refused in one line, and never panic.
    for mesh in [6, 7] {
        for seed in 0..8u8 {
            let path = draco_box(
                &format!("garbled-{mesh}-{seed}"),
                |_| (),
                |bin, d| {
                    let view =
                        d["meshes"][mesh]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["bufferView"]
                            .as_u64()
                            .unwrap();
                    let view = &d["bufferViews"][view as usize];
                    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize;
                    let end = start + view["byteLength"].as_u64().unwrap() as usize;
                    let span = &mut bin[start + 8 * usize::from(seed)..end];
                    span.iter_mut()
                        .enumerate()
                        .for_each(|(i, b)| *b ^= (i as u8).wrapping_mul(97).wrapping_add(seed) | 1);
                },
            );
            if let Err(e) = gltf::load(&path) {
                assert!(!e.to_string().contains('\n'), "garbled {mesh} {seed}: {e}");
            }
        }
    }
}

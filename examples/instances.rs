//! Writes a glTF scene of many instances: a sphere and a torus of about 2,000 triangles
//! each, in four materials, scattered over a ground plane by COUNT nodes (default 20,000),
//! or with `--gpu` by four nodes using EXT_mesh_gpu_instancing:
//!
//!     cargo run --release --example instances -- OUT.gltf [COUNT] [--gpu]
//!
//! The buffer is written beside it (OUT.bin). Placements come from a fixed hash, so the
//! file is the same on every run.

use serde_json::{Value, json};
use std::f32::consts::{PI, TAU};
use std::path::PathBuf;

/// Vertices (position, normal) and triangle indices of a mesh.
struct Mesh {
    vertices: Vec<([f32; 3], [f32; 3])>,
    indices: Vec<u32>,
}

/// A UV sphere of radius 1 standing on y = 0 (`stacks` x `slices` quads, 1,984 triangles at 32 x 32).
fn sphere(stacks: u32, slices: u32) -> Mesh {
    let mut vertices = Vec::new();
    for i in 0..=stacks {
        let theta = PI * i as f32 / stacks as f32;
        for j in 0..=slices {
            let phi = TAU * j as f32 / slices as f32;
            let n = [theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()];
            vertices.push(([n[0], n[1] + 1.0, n[2]], n));
        }
    }
    Mesh { vertices, indices: grid_indices(stacks, slices, true) }
}

/// A torus of radii 0.7 and 0.3 lying on y = 0 (`rings` x `sides` quads).
fn torus(rings: u32, sides: u32) -> Mesh {
    let (big, small) = (0.7f32, 0.3f32);
    let mut vertices = Vec::new();
    for i in 0..=rings {
        let u = TAU * i as f32 / rings as f32;
        for j in 0..=sides {
            let v = TAU * j as f32 / sides as f32;
            let n = [v.cos() * u.cos(), v.sin(), v.cos() * u.sin()];
            let r = big + small * v.cos();
            vertices.push(([r * u.cos(), small + small * v.sin(), r * u.sin()], n));
        }
    }
    Mesh { vertices, indices: grid_indices(rings, sides, false) }
}

/// Counter-clockwise triangles over a (rows + 1) x (cols + 1) vertex grid; a sphere's pole
/// rows have one triangle per quad.
fn grid_indices(rows: u32, cols: u32, poles: bool) -> Vec<u32> {
    let at = |i: u32, j: u32| i * (cols + 1) + j;
    let mut out = Vec::new();
    for i in 0..rows {
        for j in 0..cols {
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
            if !(poles && i == 0) {
                out.extend([a, b, c]);
            }
            if !(poles && i == rows - 1) {
                out.extend([a, c, d]);
            }
        }
    }
    out
}

/// Where an instance goes: translation, rotation (quaternion x, y, z, w) and uniform scale.
type Placement = ([f32; 3], [f32; 4], f32);

/// A uniform number in [0, 1) from `i` and a stream (SplitMix64).
fn hash(i: u64, stream: u64) -> f32 {
    let mut z = i.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ stream.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
}

/// Appends `data` to the buffer as a view and an accessor; returns the accessor's index.
fn push(buffer: &mut Vec<u8>, doc: &mut Value, data: &[f32], ty: &str, extra: Value) -> usize {
    let offset = buffer.len();
    data.iter().for_each(|v| buffer.extend_from_slice(&v.to_le_bytes()));
    let components = match ty {
        "VEC3" => 3,
        "VEC4" => 4,
        _ => 1,
    };
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len() * 4}));
    let mut accessor =
        json!({"bufferView": views.len() - 1, "componentType": 5126, "count": data.len() / components, "type": ty});
    if let (Some(a), Some(e)) = (accessor.as_object_mut(), extra.as_object()) {
        a.extend(e.clone());
    }
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(accessor);
    accessors.len() - 1
}

/// Adds a mesh's accessors; returns its primitive's attributes and indices.
fn add_mesh(buffer: &mut Vec<u8>, doc: &mut Value, mesh: &Mesh) -> (usize, usize, usize) {
    let positions: Vec<f32> = mesh.vertices.iter().flat_map(|v| v.0).collect();
    let (lo, hi) = mesh.vertices.iter().fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), (p, _)| {
        (std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k])))
    });
    let p = push(buffer, doc, &positions, "VEC3", json!({"min": lo, "max": hi}));
    let normals: Vec<f32> = mesh.vertices.iter().flat_map(|v| v.1).collect();
    let n = push(buffer, doc, &normals, "VEC3", json!({}));
    let offset = buffer.len();
    mesh.indices.iter().for_each(|i| buffer.extend_from_slice(&i.to_le_bytes()));
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": mesh.indices.len() * 4}));
    let view = views.len() - 1;
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(json!({"bufferView": view, "componentType": 5125, "count": mesh.indices.len(), "type": "SCALAR"}));
    (p, n, accessors.len() - 1)
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let gpu = args.iter().any(|a| a == "--gpu");
    let mut plain = args.iter().filter(|a| !a.starts_with("--"));
    let out = PathBuf::from(plain.next().ok_or("usage: instances OUT.gltf [COUNT] [--gpu]")?);
    let count: usize = plain.next().map_or(Ok(20_000), |c| c.parse().map_err(|_| format!("not a count: {c}")))?;
    let bin = out.with_extension("bin");
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": "lucent examples/instances.rs"},
        "scene": 0,
        "scenes": [{"nodes": []}],
        "nodes": [], "meshes": [], "bufferViews": [], "accessors": [],
        "materials": [
            {"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.78, 0.34, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.25}},
            {"name": "blue plastic", "pbrMetallicRoughness": {"baseColorFactor": [0.05, 0.2, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.3}},
            {"name": "white", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.88, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.6}},
            {"name": "copper", "pbrMetallicRoughness": {"baseColorFactor": [0.95, 0.64, 0.54, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.4}},
            {"name": "ground", "pbrMetallicRoughness": {"baseColorFactor": [0.35, 0.33, 0.3, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.9}}
        ]
    });
    let mut buffer = Vec::new();
    let shapes = [add_mesh(&mut buffer, &mut doc, &sphere(32, 32)), add_mesh(&mut buffer, &mut doc, &torus(32, 32))];
    // Four meshes: the sphere in gold and blue, the torus in white and copper.
    for (k, material) in [0, 1, 2, 3].into_iter().enumerate() {
        let (p, n, i) = shapes[k / 2];
        let name = ["gold sphere", "blue sphere", "white torus", "copper torus"][k];
        doc["meshes"].as_array_mut().unwrap().push(json!({
            "name": name,
            "primitives": [{"attributes": {"POSITION": p, "NORMAL": n}, "indices": i, "material": material}]
        }));
    }
    // Placements on a square field, jittered, turned about y and tilted a little.
    let side = (count as f32).sqrt().ceil() as usize;
    let spacing = 3.0f32;
    let half = 0.5 * spacing * side as f32;
    let mut placements: [Vec<Placement>; 4] = Default::default();
    for i in 0..count {
        let (x, z) = ((i % side) as f32, (i / side) as f32);
        let jitter = |s| (hash(i as u64, s) - 0.5) * 0.8 * spacing;
        let scale = 0.6 + 0.8 * hash(i as u64, 3);
        let (yaw, tilt) = (TAU * hash(i as u64, 4), 0.3 * (hash(i as u64, 5) - 0.5));
        let (sy, cy, st, ct) = ((0.5 * yaw).sin(), (0.5 * yaw).cos(), (0.5 * tilt).sin(), (0.5 * tilt).cos());
        // rotation = yaw about y, then tilt about x: q = q_y * q_x.
        let q = [cy * st, sy * ct, -sy * st, cy * ct];
        let t = [x * spacing - half + jitter(1), 0.0, z * spacing - half + jitter(2)];
        placements[(hash(i as u64, 6) * 4.0) as usize % 4].push((t, q, scale));
    }
    if gpu {
        for (mesh, list) in placements.iter().enumerate() {
            let t: Vec<f32> = list.iter().flat_map(|p| p.0).collect();
            let r: Vec<f32> = list.iter().flat_map(|p| p.1).collect();
            let s: Vec<f32> = list.iter().flat_map(|p| [p.2; 3]).collect();
            let (t, r, s) = (
                push(&mut buffer, &mut doc, &t, "VEC3", json!({})),
                push(&mut buffer, &mut doc, &r, "VEC4", json!({})),
                push(&mut buffer, &mut doc, &s, "VEC3", json!({})),
            );
            doc["nodes"].as_array_mut().unwrap().push(json!({
                "mesh": mesh,
                "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": t, "ROTATION": r, "SCALE": s}}}
            }));
        }
        doc["extensionsUsed"] = json!(["EXT_mesh_gpu_instancing"]);
        doc["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    } else {
        for (mesh, list) in placements.iter().enumerate() {
            for &(t, q, s) in list {
                doc["nodes"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!({"mesh": mesh, "translation": t, "rotation": q, "scale": [s, s, s]}));
            }
        }
    }
    // The ground, a quad under the field.
    let g = half + 2.0 * spacing;
    let quad = Mesh {
        vertices: [[-g, 0.0, -g], [g, 0.0, -g], [g, 0.0, g], [-g, 0.0, g]].map(|p| (p, [0.0, 1.0, 0.0])).to_vec(),
        indices: vec![0, 2, 1, 0, 3, 2],
    };
    let (p, n, i) = add_mesh(&mut buffer, &mut doc, &quad);
    doc["meshes"].as_array_mut().unwrap().push(json!({
        "name": "ground",
        "primitives": [{"attributes": {"POSITION": p, "NORMAL": n}, "indices": i, "material": 4}]
    }));
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(json!({"mesh": 4}));
    // A camera above one corner, looking across the field.
    let (pitch, yaw) = (-0.32f32, -0.75f32 * PI);
    let (sp, cp, sy, cy) = ((0.5 * pitch).sin(), (0.5 * pitch).cos(), (0.5 * yaw).sin(), (0.5 * yaw).cos());
    nodes.push(json!({
        "camera": 0,
        "translation": [-0.55 * half, 0.12 * half + 6.0, -0.55 * half],
        "rotation": [cy * sp, sy * cp, -sy * sp, cy * cp]
    }));
    let roots: Vec<usize> = (0..nodes.len()).collect();
    doc["scenes"][0]["nodes"] = json!(roots);
    doc["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1}}]);
    let name = bin.file_name().and_then(|n| n.to_str()).ok_or("the output needs a file name")?.to_owned();
    doc["buffers"] = json!([{"byteLength": buffer.len(), "uri": name}]);
    std::fs::write(&bin, &buffer).map_err(|e| format!("{}: {e}", bin.display()))?;
    let text = serde_json::to_vec(&doc).map_err(|e| e.to_string())?;
    std::fs::write(&out, text).map_err(|e| format!("{}: {e}", out.display()))?;
    println!("wrote {} ({count} placements{})", out.display(), if gpu { ", EXT_mesh_gpu_instancing" } else { "" });
    Ok(())
}

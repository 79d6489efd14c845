//! Bad input: a proptest generator mutates real glTF files from tests/assets and assets/
//! (bytes flipped, inserted or cut; JSON values replaced or deleted, inside .gltf and inside
//! a .glb's JSON chunk), and each mutant goes through loading, scene building and a few
//! pixel samples. Every step may refuse the input with an error; none may panic. The case
//! count is fixed (LUCENT_FUZZ_CASES overrides it), so the run is bounded and reproducible.
//! Inputs that once crashed are kept in tests/fuzz-corpus and replayed first.

use glam::UVec2;
use lucent::integrator::{Settings, View, sample_pixel};
use lucent::loader::{Limits, gltf};
use lucent::scene::Scene;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use serde_json::Value;
use std::path::PathBuf;

/// Small, self-contained seed files (.glb, or .gltf with embedded buffers), relative to the
/// repository root.
const SEEDS: &[&str] = &[
    "tests/assets/Box/glTF-Binary/Box.glb",
    "tests/assets/BoxTextured/glTF-Binary/BoxTextured.glb",
    "tests/assets/TextureCoordinateTest/glTF-Binary/TextureCoordinateTest.glb",
    "tests/assets/EmissiveStrengthTest/glTF-Binary/EmissiveStrengthTest.glb",
    "assets/cornell-box.gltf",
];

/// The memory limit the fuzzer loads with, fixed so that the run does not depend on the
/// machine's memory (the default limit is half of it).
const LIMITS: Limits = Limits { memory: 1 << 30 };

/// Loads, builds and samples a few pixels; errors are fine, panics are not.
fn exercise(bytes: &[u8]) {
    let Ok(desc) = gltf::load_slice_with_limits(bytes, "fuzz", &LIMITS) else { return };
    let scene = Scene::build(desc);
    let settings = Settings { width: 4, height: 4, max_depth: 4, ..Settings::default() };
    let view = View::new(&scene, &scene.default_camera(1.0), settings.width, settings.height);
    for i in 0..16u32 {
        let out = sample_pixel(&scene, &settings, &view, UVec2::new(i % 4, i / 4), i as u64, false, &mut |_, _| {});
        // Non-finite radiance is allowed only if the film would drop it; it must not panic.
        let _ = out.radiance.is_finite();
    }
}

/// The JSON chunk of a .glb as (json, rest of the file after it), or None.
fn split_glb(bytes: &[u8]) -> Option<(Value, Vec<u8>)> {
    if bytes.len() < 20 || &bytes[0..4] != b"glTF" {
        return None;
    }
    let len = u32::from_le_bytes(bytes[12..16].try_into().ok()?) as usize;
    let json = serde_json::from_slice(bytes.get(20..20 + len)?).ok()?;
    Some((json, bytes[20 + len..].to_vec()))
}

/// A .glb with the given JSON chunk and the remaining chunks unchanged.
fn join_glb(json: &Value, rest: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(json).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let total = 12 + 8 + text.len() + rest.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(rest);
    out
}

/// Every path to a leaf or object member in the JSON, for choosing a mutation site.
fn sites(v: &Value, path: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    match v {
        Value::Object(m) => {
            for (k, child) in m {
                path.push(Value::String(k.clone()));
                out.push(path.clone());
                sites(child, path, out);
                path.pop();
            }
        }
        Value::Array(a) => {
            for (i, child) in a.iter().enumerate() {
                path.push(Value::from(i));
                out.push(path.clone());
                sites(child, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

/// Values that break assumptions: negative, zero, huge, fractional, wrong type.
fn hostile(k: u8) -> Value {
    match k % 12 {
        0 => Value::from(-1),
        1 => Value::from(0),
        2 => Value::from(u32::MAX),
        3 => Value::from(1u64 << 40),
        4 => Value::from(-0.5),
        5 => Value::from(1e30),
        6 => Value::from(7),
        7 => Value::Null,
        8 => Value::from("x"),
        9 => Value::Array(vec![]),
        10 => serde_json::json!({}),
        _ => Value::from(1e-30),
    }
}

/// Applies one JSON mutation at site `which` (an index into all sites).
fn mutate_json(json: &mut Value, which: usize, k: u8, delete: bool) {
    let mut all = Vec::new();
    sites(json, &mut Vec::new(), &mut all);
    if all.is_empty() {
        return;
    }
    let path = &all[which % all.len()];
    let (last, parent_path) = path.split_last().unwrap();
    let mut parent = &mut *json;
    for step in parent_path {
        parent = match step {
            Value::String(s) => &mut parent[s.as_str()],
            _ => &mut parent[step.as_u64().unwrap() as usize],
        };
    }
    match (parent, last) {
        (Value::Object(m), Value::String(key)) if delete => {
            m.remove(key);
        }
        (Value::Object(m), Value::String(key)) => {
            m.insert(key.clone(), hostile(k));
        }
        (Value::Array(a), i) => {
            let i = i.as_u64().unwrap() as usize;
            if delete {
                a.remove(i)
            } else {
                std::mem::replace(&mut a[i], hostile(k))
            };
        }
        _ => {}
    }
}

#[derive(Debug, Clone)]
enum Mutation {
    Flip { at: usize, xor: u8 },
    Truncate { at: usize },
    Insert { at: usize, bytes: Vec<u8> },
    Json { which: usize, value: u8, delete: bool },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1u8..).prop_map(|(at, xor)| Mutation::Flip { at, xor }),
        any::<usize>().prop_map(|at| Mutation::Truncate { at }),
        (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(at, bytes)| Mutation::Insert { at, bytes }),
        (any::<usize>(), any::<u8>(), any::<bool>()).prop_map(|(which, value, delete)| Mutation::Json {
            which,
            value,
            delete
        }),
        (any::<usize>(), any::<u8>(), any::<bool>()).prop_map(|(which, value, delete)| Mutation::Json {
            which,
            value,
            delete
        }),
    ]
}

fn apply(seed: &[u8], mutations: &[Mutation]) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    for m in mutations {
        match m {
            Mutation::Flip { at, xor } if !bytes.is_empty() => {
                let i = at % bytes.len();
                bytes[i] ^= xor;
            }
            Mutation::Truncate { at } => bytes.truncate(at % (bytes.len() + 1)),
            Mutation::Insert { at, bytes: b } => {
                let i = at % (bytes.len() + 1);
                bytes.splice(i..i, b.iter().copied());
            }
            Mutation::Json { which, value, delete } => {
                if let Some((mut json, rest)) = split_glb(&bytes) {
                    mutate_json(&mut json, *which, *value, *delete);
                    bytes = join_glb(&json, &rest);
                } else if let Ok(mut json) = serde_json::from_slice::<Value>(&bytes) {
                    mutate_json(&mut json, *which, *value, *delete);
                    bytes = serde_json::to_vec(&json).unwrap();
                }
            }
            _ => {}
        }
    }
    bytes
}

fn corpus_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus")
}

#[test]
fn inputs_that_once_crashed_the_loader_now_give_errors_or_images() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(corpus_dir()).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    assert!(!files.is_empty(), "the crash corpus is missing");
    for path in files {
        let bytes = std::fs::read(&path).unwrap();
        let result = std::panic::catch_unwind(|| exercise(&bytes));
        assert!(result.is_ok(), "{} panics again", path.display());
    }
}

#[test]
fn mutated_real_gltf_files_never_panic() {
    let cases = std::env::var("LUCENT_FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(4000);
    for (k, seed) in SEEDS.iter().enumerate() {
        let bytes = std::fs::read(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(seed)).unwrap();
        let config = Config { cases, failure_persistence: None, ..Config::default() };
        let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[k as u8 + 1; 32]);
        let mut runner = TestRunner::new_with_rng(config, rng);
        let result = runner.run(&proptest::collection::vec(mutation(), 1..4), |mutations| {
            exercise(&apply(&bytes, &mutations));
            Ok(())
        });
        if let Err(e) = result {
            panic!("{seed}: {e}");
        }
    }
}

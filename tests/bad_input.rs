//! Bad input is refused, never panics and never allocates without bound. A counting global
//! allocator (wrapping System) tracks the peak of live heap bytes, so that these tests can
//! check: that the loader's estimate of a scene's peak is above what loading and building
//! it really take, and within 2x of it (real scenes are not refused for nothing); that
//! structurally mutated glTF files (accessor and sparse counts, views, indices, image
//! sizes, node graphs, primitive counts) are refused or loaded within the memory limit and a
//! time bound; that the committed hostile inputs are refused for the reasons they deserve;
//! and that a render session's film estimate covers what a session allocates.

mod common;

use base64::Engine;
use lucent::integrator::Settings;
use lucent::loader::{Limits, LoadError, builtin, gltf};
use lucent::render::{Job, RenderSession, SessionError, film_bytes};
use lucent::scene::{Scene, geometry::Ray, instances::Instancing};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use serde_json::{Value, json};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::sync::{Arc, Mutex, MutexGuard, mpsc};
use std::time::{Duration, Instant};

/// Counts live heap bytes and their peak; realloc counts the change in size (glibc grows
/// large blocks in place with mremap).
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(n: usize) {
    let now = LIVE.fetch_add(n, Relaxed) + n;
    PEAK.fetch_max(now, Relaxed);
}

// SAFETY: every call is passed to System unchanged; only the counters are updated.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            if new_size >= layout.size() {
                grew(new_size - layout.size());
            } else {
                LIVE.fetch_sub(layout.size() - new_size, Relaxed);
            }
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// The counters are global: tests that measure take turns.
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// Runs `f`; returns its result and the peak of live bytes above those live when it started.
fn peak_of<T>(f: impl FnOnce() -> T) -> (T, u64) {
    let start = LIVE.load(Relaxed);
    PEAK.store(start, Relaxed);
    let out = f();
    (out, PEAK.load(Relaxed).saturating_sub(start) as u64)
}

const MB: u64 = 1_000_000;

#[test]
fn the_estimate_covers_what_loading_and_building_take_and_is_not_far_above() {
    let _turn = serial();
    let models = [
        "Box/glTF-Binary/Box.glb",
        "BoxTextured/glTF-Binary/BoxTextured.glb",
        "Cube/glTF/Cube.gltf",
        "MetalRoughSpheresNoTextures/glTF-Binary/MetalRoughSpheresNoTextures.glb",
        "NormalTangentTest/glTF-Binary/NormalTangentTest.glb",
        "NormalTangentMirrorTest/glTF-Binary/NormalTangentMirrorTest.glb",
        "ToyCar/glTF/ToyCar.gltf",
        "WaterBottle/glTF/WaterBottle.gltf",
        "LightsPunctualLamp/glTF/LightsPunctualLamp.gltf",
        "AttenuationTest/glTF-Binary/AttenuationTest.glb",
        "EmissiveStrengthTest/glTF-Binary/EmissiveStrengthTest.glb",
    ];
    let generous = Limits { memory: 1 << 40 };
    let mut files: Vec<(String, PathBuf)> = models.iter().map(|m| (m.to_string(), common::asset(m))).collect();
    let dir = common::scratch("bad-input-estimate");
    for (name, doc) in [
        ("grid-320k.gltf", Grid { n: 400, ..Grid::default() }.file()),
        ("grid-normal-mapped-100k.gltf", Grid { n: 224, normal_mapped: true, ..Grid::default() }.file()),
        ("grid-strip-100k.gltf", Grid { n: 224, strips: true, ..Grid::default() }.file()),
        ("grid-emissive-100k.gltf", Grid { n: 224, emissive: true, ..Grid::default() }.file()),
        ("grid-2k-placed-20k-times.gltf", Grid { n: 32, copies: 20_000, ..Grid::default() }.file()),
        (
            "grid-emissive-8k-placed-500-times.gltf",
            Grid { n: 64, copies: 500, emissive: true, ..Grid::default() }.file(),
        ),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, doc).unwrap();
        files.push((name.into(), path));
    }
    for (name, path) in files {
        let estimate = gltf::estimate(&path, &generous).unwrap_or_else(|e| panic!("{name}: {e}"));
        let limits = Limits { memory: estimate };
        let (scene, peak) =
            peak_of(|| Scene::build(gltf::load_with_limits(&path, &limits).unwrap_or_else(|e| panic!("{name}: {e}"))));
        let triangles = scene.geometry.len();
        drop(scene);
        eprintln!(
            "{name}: {triangles} triangles, estimate {estimate}, peak {peak}, ratio {:.2}",
            estimate as f64 / peak as f64
        );
        assert!(
            peak <= estimate,
            "{name}: loading and building peaked at {peak} bytes, over the estimate of {estimate}"
        );
        assert!(
            estimate <= 2 * peak + 2 * MB,
            "{name}: the estimate of {estimate} bytes is over twice the peak of {peak}"
        );
    }
}

#[test]
fn a_mesh_placed_many_times_is_stored_once_and_loads_in_bounded_memory() {
    let _turn = serial();
    // 2,048 triangles under 20,000 nodes: 41 M placed triangles, some 14 GB flattened.
    let dir = common::scratch("bad-input-instanced");
    let path = dir.join("grid-2k-x-20k.gltf");
    std::fs::write(&path, Grid { n: 32, copies: 20_000, ..Grid::default() }.file()).unwrap();
    let limits = Limits { memory: 200 * MB };
    let (scene, peak) = peak_of(|| {
        let desc = gltf::load_with_limits(&path, &limits).unwrap_or_else(|e| panic!("{e}"));
        Scene::build(desc)
    });
    assert_eq!(scene.geometry.len(), 2_048 * 20_000);
    assert_eq!((scene.geometry.unique_len(), scene.geometry.instance_count()), (2_048, 20_000));
    assert!(peak < 100 * MB, "loading and building peaked at {peak} bytes");
    assert!(scene.geometry.bytes() < 20 * MB as usize, "{} bytes", scene.geometry.bytes());
    // Rays down onto the first and the last copy hit them, and one between copies misses.
    let (lo, hi) = scene.bounds;
    let down = |x: f32, y: f32| Ray { o: glam::Vec3::new(x, y, hi.z + 1.0), d: -glam::Vec3::Z, tmax: f32::INFINITY };
    assert!(scene.geometry.intersect(&down(lo.x + 10.3, lo.y + 10.7)).is_some());
    assert!(scene.geometry.intersect(&down(hi.x - 10.3, hi.y - 10.7)).is_some());
    assert!(scene.geometry.intersect(&down(lo.x + 32.5, lo.y + 10.7)).is_none());
    // Flattened, the same scene is refused in one line.
    let mut desc = gltf::load_with_limits(&path, &limits).unwrap();
    let err = desc.apply_instancing(Instancing::Never, limits.memory / 400).unwrap_err();
    assert!(err.contains("40960000 triangles") && !err.contains('\n'), "{err}");
}

#[test]
fn a_limit_below_the_estimate_refuses_the_scene_before_it_is_allocated() {
    let _turn = serial();
    let path = common::asset("MetalRoughSpheresNoTextures/glTF-Binary/MetalRoughSpheresNoTextures.glb");
    let estimate = gltf::estimate(&path, &Limits { memory: 1 << 40 }).unwrap();
    let limits = Limits { memory: estimate - 1 };
    let (result, peak) = peak_of(|| gltf::load_with_limits(&path, &limits));
    let err = result.err().expect("one byte below the estimate is refused").to_string();
    assert!(err.starts_with("scene too large: ") && !err.contains('\n'), "{err}");
    assert!(err.contains("triangles") && err.contains("over the memory limit of"), "says how much and why: {err}");
    assert!(peak < estimate / 4, "refused after {peak} bytes, near the estimate of {estimate}");
}

// --- the structural fuzzer ---

/// Appends little-endian f32s.
fn put_f32(buffer: &mut Vec<u8>, values: &[f32]) {
    values.iter().for_each(|v| buffer.extend_from_slice(&v.to_le_bytes()));
}

/// A 2x2 RGBA8 PNG.
fn tiny_png() -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbaImage::from_pixel(2, 2, image::Rgba([128, 128, 255, 255]))
        .write_to(&mut out, image::ImageFormat::Png)
        .unwrap();
    out.into_inner()
}

/// The glTF file: the document with its buffer as a data URI.
fn encode(mut doc: Value, buffer: &[u8]) -> Vec<u8> {
    let uri = base64::engine::general_purpose::STANDARD.encode(buffer);
    doc["buffers"][0]["uri"] = Value::from(format!("data:application/octet-stream;base64,{uri}"));
    serde_json::to_vec(&doc).unwrap()
}

/// CRC-32 (ISO-HDLC, as PNG chunks use).
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xedb8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

#[derive(Clone, Debug)]
enum Mutation {
    /// Sets an accessor's count.
    Count { accessor: usize, count: u64 },
    /// Makes the vertex attributes' accessors (or the indices') sparse over the spare
    /// sparse views with one new count, maybe without views of their own.
    Sparse { indices: bool, count: u64, sparse_count: u64, keep_view: bool },
    /// Sets a bufferView's byteLength (0), byteOffset (1) or byteStride (2).
    View { view: usize, field: usize, value: u64 },
    /// Sets the buffer's byteLength.
    BufferLength { value: u64 },
    /// Overwrites one of the indices.
    Index { at: usize, value: u32 },
    /// Rewrites the PNG's header: size, bit depth and colour type (the CRC kept valid).
    ImageSize { width: u32, height: u32, format: usize },
    /// Replaces a node's children (cycles and self-references included).
    Children { node: usize, children: Vec<usize> },
    /// Adds a root above `levels` nodes, each naming the next `fan_out` times, over the mesh's node.
    Dag { levels: usize, fan_out: usize },
    /// Adds a root chain of `length` nodes over the mesh's node.
    Chain { length: usize },
    /// Repeats the mesh's primitive.
    Primitives { count: usize },
    /// Places the mesh from `count` more root nodes.
    Instances { count: usize },
    /// Sets the primitive's mode.
    Mode { mode: u64 },
}

/// Counts from small to absurd.
fn count() -> impl Strategy<Value = u64> {
    prop_oneof![
        0u64..8,
        prop::sample::select(vec![
            100u64,
            1000,
            50_000,
            200_000,
            400_000,
            1_000_000,
            100_000_000,
            1_000_000_000,
            1 << 32,
            1 << 40,
            1 << 53
        ])
    ]
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let sizes =
        prop::sample::select(vec![0u32, 1, 2, 3, 64, 1000, 2000, 8000, 16384, 65535, 1 << 20, 1 << 30, u32::MAX]);
    prop_oneof![
        (0..4usize, count()).prop_map(|(accessor, count)| Mutation::Count { accessor, count }),
        (any::<bool>(), count(), prop_oneof![Just(1u64), count()], any::<bool>()).prop_map(
            |(indices, count, sparse_count, keep_view)| Mutation::Sparse { indices, count, sparse_count, keep_view }
        ),
        (0..7usize, 0..3usize, prop_oneof![count(), prop::sample::select(vec![4u64, 12, 36, 48, 252, 256])])
            .prop_map(|(view, field, value)| Mutation::View { view, field, value }),
        count().prop_map(|value| Mutation::BufferLength { value }),
        (any::<usize>(), prop::sample::select(vec![0u32, 3, 4, 65535, 1 << 31, u32::MAX]))
            .prop_map(|(at, value)| Mutation::Index { at, value }),
        (sizes.clone(), sizes, 0..8usize).prop_map(|(width, height, format)| Mutation::ImageSize {
            width,
            height,
            format
        }),
        (0..64usize, proptest::collection::vec(0..64usize, 0..4))
            .prop_map(|(node, children)| Mutation::Children { node, children }),
        (1..40usize, 1..4usize).prop_map(|(levels, fan_out)| Mutation::Dag { levels, fan_out }),
        (1..600usize).prop_map(|length| Mutation::Chain { length }),
        prop::sample::select(vec![2usize, 10, 1000, 20_000]).prop_map(|count| Mutation::Primitives { count }),
        prop::sample::select(vec![2usize, 10, 1000, 20_000]).prop_map(|count| Mutation::Instances { count }),
        (0..8u64).prop_map(|mode| Mutation::Mode { mode }),
    ]
}

/// Adds nodes to the document; returns the index of the first added.
fn add_nodes(doc: &mut Value, nodes: impl IntoIterator<Item = Value>) -> usize {
    let list = doc["nodes"].as_array_mut().unwrap();
    let first = list.len();
    list.extend(nodes);
    first
}

/// The seed (a normal-mapped, textured grid of n x n quads) with the mutations applied.
fn apply(n: usize, mutations: &[Mutation]) -> Vec<u8> {
    let Parts { mut doc, mut buffer, indices_at, index_count, png_at } =
        Grid { n, normal_mapped: true, ..Grid::default() }.parts();
    for m in mutations {
        match m {
            Mutation::Count { accessor, count } => doc["accessors"][accessor]["count"] = json!(count),
            Mutation::Sparse { indices, count, sparse_count, keep_view } => {
                let accessors: &[usize] = if *indices { &[3] } else { &[0, 1, 2] };
                for &i in accessors {
                    let a = &mut doc["accessors"][i];
                    a["count"] = json!(count);
                    a["sparse"] = json!({
                        "count": sparse_count,
                        "indices": {"bufferView": 4, "componentType": 5125},
                        "values": {"bufferView": 5}
                    });
                    if !keep_view {
                        a.as_object_mut().unwrap().remove("bufferView");
                    }
                }
            }
            Mutation::View { view, field, value } => {
                let key = ["byteLength", "byteOffset", "byteStride"][*field];
                doc["bufferViews"][view][key] = json!(value);
            }
            Mutation::BufferLength { value } => doc["buffers"][0]["byteLength"] = json!(value),
            Mutation::Index { at, value } => {
                let i = indices_at + 4 * (at % index_count);
                buffer[i..i + 4].copy_from_slice(&value.to_le_bytes());
            }
            Mutation::ImageSize { width, height, format } => {
                let (depth, colour) = [(8u8, 6u8), (16, 6), (8, 2), (8, 0), (16, 0), (8, 4), (1, 0), (8, 3)][*format];
                let ihdr = png_at + 8;
                buffer[ihdr + 8..ihdr + 12].copy_from_slice(&width.to_be_bytes());
                buffer[ihdr + 12..ihdr + 16].copy_from_slice(&height.to_be_bytes());
                buffer[ihdr + 16] = depth;
                buffer[ihdr + 17] = colour;
                let crc = crc32(&buffer[ihdr + 4..ihdr + 21]);
                buffer[ihdr + 21..ihdr + 25].copy_from_slice(&crc.to_be_bytes());
            }
            Mutation::Children { node, children } => {
                let n = doc["nodes"].as_array().unwrap().len();
                doc["nodes"][node % n]["children"] = json!(children.iter().map(|c| c % n).collect::<Vec<_>>());
            }
            Mutation::Dag { levels, fan_out } => {
                let first = doc["nodes"].as_array().unwrap().len();
                let nodes = (0..*levels).map(|i| {
                    let next = if i + 1 == *levels { 0 } else { first + i + 1 };
                    json!({"children": vec![next; *fan_out]})
                });
                let root = add_nodes(&mut doc, nodes.collect::<Vec<_>>());
                doc["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(root));
            }
            Mutation::Chain { length } => {
                let first = doc["nodes"].as_array().unwrap().len();
                let nodes =
                    (0..*length).map(|i| json!({"children": [if i + 1 == *length { 0 } else { first + i + 1 }]}));
                let root = add_nodes(&mut doc, nodes.collect::<Vec<_>>());
                doc["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(root));
            }
            Mutation::Primitives { count } => {
                let prim = doc["meshes"][0]["primitives"][0].clone();
                doc["meshes"][0]["primitives"] = Value::Array(vec![prim; *count]);
            }
            Mutation::Instances { count } => {
                let root = add_nodes(&mut doc, vec![json!({"mesh": 0}); *count]);
                let roots = doc["scenes"][0]["nodes"].as_array_mut().unwrap();
                roots.extend((root..root + count).map(Value::from));
            }
            Mutation::Mode { mode } => doc["meshes"][0]["primitives"][0]["mode"] = json!(mode),
        }
    }
    encode(doc, &buffer)
}

/// The memory limit the fuzzer loads with.
const FUZZ_LIMIT: Limits = Limits { memory: 64 << 20 };

/// Most time one case may take (loading and building within 64 MiB takes well under a
/// second on one core; this leaves room for a loaded CI machine).
const CASE_TIME: Duration = Duration::from_secs(30);

/// What loading and building did: the number of triangles or the error, the peak of live
/// bytes, and the time taken.
struct Outcome {
    result: Result<usize, String>,
    peak: u64,
    time: Duration,
}

/// Loads and builds `bytes` within `limits` on a thread of its own, so that a hang is
/// reported as one after `CASE_TIME` instead of stalling the test; a panic is an error.
fn exercise(bytes: Vec<u8>, limits: Limits) -> Result<Outcome, String> {
    let start = Instant::now();
    let ((received, worker), peak) = peak_of(|| {
        let (tx, rx) = mpsc::channel();
        let worker = std::thread::spawn(move || {
            let result = gltf::load_slice_with_limits(&bytes, "fuzz", &limits)
                .map(|desc| Scene::build(desc).geometry.len())
                .map_err(|e| e.to_string());
            let _ = tx.send(result);
        });
        (rx.recv_timeout(CASE_TIME), worker)
    });
    let time = start.elapsed();
    match received {
        Ok(result) => {
            worker.join().map_err(|_| "the worker panicked after sending".to_string())?;
            Ok(Outcome { result, peak, time })
        }
        Err(mpsc::RecvTimeoutError::Timeout) => Err(format!("no answer within {CASE_TIME:?}: it hangs")),
        Err(mpsc::RecvTimeoutError::Disconnected) => {
            let payload = worker.join().expect_err("a worker that sent nothing panicked");
            let message = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()));
            Err(format!("panicked: {}", message.unwrap_or_default()))
        }
    }
}

/// The bound on what loading any input may take: the limit itself. The loader estimates
/// the parsed JSON, buffers, images, flattened geometry and built scene before allocating
/// them, so whatever it accepts fits in the limit, and what it refuses is refused before
/// the parts over the limit are allocated.
fn check_outcome(outcome: &Outcome, limits: &Limits, what: &str) -> Result<(), String> {
    if let Err(e) = &outcome.result
        && e.contains('\n')
    {
        return Err(format!("{what}: a refusal of more than one line: {e}"));
    }
    if outcome.peak > limits.memory {
        return Err(format!("{what}: peaked at {} bytes, over the limit of {}", outcome.peak, limits.memory));
    }
    Ok(())
}

#[test]
fn structurally_mutated_files_are_refused_or_loaded_within_the_limit_and_in_time() {
    let _turn = serial();
    let seed_outcome = exercise(apply(1, &[]), FUZZ_LIMIT).unwrap();
    assert_eq!(seed_outcome.result, Ok(2), "the unmutated seed loads its quad");
    let cases = std::env::var("LUCENT_FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(1000);
    // A hang costs CASE_TIME per shrinking step: shrinking stops after a minute.
    let config =
        Config { cases, failure_persistence: None, max_shrink_iters: 64, max_shrink_time: 60_000, ..Config::default() };
    let mut runner = TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]));
    let (refused, slowest, highest) = (Cell::new(0usize), Cell::new(Duration::ZERO), Cell::new(0u64));
    // Grids from one quad to 2 x 200^2 triangles straddle the limit with real (not
    // degenerate) geometry.
    let seeds = prop_oneof![Just(1usize), 2..200usize];
    let result = runner.run(&(seeds, proptest::collection::vec(mutation(), 0..5)), |(n, mutations)| {
        let bytes = apply(n, &mutations);
        let size = bytes.len();
        let outcome = exercise(bytes, FUZZ_LIMIT).map_err(TestCaseError::fail)?;
        check_outcome(&outcome, &FUZZ_LIMIT, &format!("{size}-byte file")).map_err(TestCaseError::fail)?;
        refused.set(refused.get() + outcome.result.is_err() as usize);
        slowest.set(slowest.get().max(outcome.time));
        highest.set(highest.get().max(outcome.peak));
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let (refused, slowest, highest) = (refused.get(), slowest.get(), highest.get());
    eprintln!("{cases} cases: {refused} refused; slowest {slowest:?}; highest peak {highest} bytes");
    assert!(
        refused > cases as usize / 10 && refused < cases as usize * 9 / 10,
        "the mutations reach both outcomes: {refused} of {cases} refused"
    );
}

// --- committed hostile inputs ---

fn corpus(name: &str) -> Vec<u8> {
    std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus").join(name)).unwrap()
}

#[test]
fn the_committed_hostile_inputs_are_refused_for_their_reasons_within_little_memory() {
    let _turn = serial();
    let limits = Limits { memory: 1 << 30 };
    for (name, reason) in [
        ("sparse-count-1e9.gltf", "read from accessors[0] (sparse), which expands to 1000000000 VEC3 elements"),
        ("dag-2pow30-placements.gltf", "nodes[30] alone is reached along 1073741824 paths"),
        ("node-cycle.gltf", "is its own descendant"),
    ] {
        let bytes = corpus(name);
        let size = bytes.len() as u64;
        let outcome = exercise(bytes, limits).unwrap_or_else(|e| panic!("{name}: {e}"));
        let err = outcome.result.expect_err(name);
        assert!(err.contains(reason) && !err.contains('\n'), "{name}: {err}");
        assert!(outcome.peak < 64 * size + MB, "{name}: refusing it took {} bytes", outcome.peak);
        assert!(outcome.time < Duration::from_secs(1), "{name}: refusing it took {:?}", outcome.time);
    }
    let sparse = gltf::load_slice_with_limits(&corpus("sparse-count-1e9.gltf"), "sparse", &limits);
    assert!(matches!(sparse, Err(LoadError::TooLarge { .. })), "{:?}", sparse.err());
}

// --- OpenVDB density grids ---

/// Values a hostile file puts in a length, count, position or flag field.
const HOSTILE_WORDS: [u64; 10] =
    [0, 1, 0x7fff_ffff, 0xffff_ffff, 0x8000_0000, 1 << 28, 1 << 40, i64::MAX as u64, i64::MIN as u64, u64::MAX];

/// Most memory reading a grid of the test's files may take beyond the grid it builds:
/// the file (40 kB), the reader's nodes (at most 16 bytes held per byte of the file) and
/// the reader's hash maps, with room to spare.
const GRID_READING: u64 = 32 * MB;

/// A fixed-seed stream of choices: `pick(n)` is uniform in 0..n.
fn choices(seed: u64) -> impl FnMut(usize) -> usize {
    let mut rng = rand_pcg::Pcg64::new(u128::from(seed), 0xda3e_39cb_94b9_5bdb);
    move |n| (rand_core::RngCore::next_u64(&mut rng) % n as u64) as usize
}

/// Mutates a file's bytes: 1 to 3 changes, each a hostile 4- or 8-byte word written, a bit
/// flipped or the file cut; half of them land in the first `hot` bytes (its headers).
fn mutate_bytes(bytes: &mut Vec<u8>, hot: usize, pick: &mut dyn FnMut(usize) -> usize) {
    for _ in 0..1 + pick(3) {
        if bytes.is_empty() {
            return;
        }
        let span = if pick(2) == 0 { hot.clamp(1, bytes.len()) } else { bytes.len() };
        let at = pick(span);
        match pick(4) {
            kind @ (0 | 1) => {
                let word = HOSTILE_WORDS[pick(HOSTILE_WORDS.len())].to_le_bytes();
                let end = (at + 4 + 4 * kind).min(bytes.len());
                bytes[at..end].copy_from_slice(&word[..end - at]);
            }
            2 => bytes[at] ^= 1 << pick(8),
            _ => bytes.truncate(at),
        }
    }
}

#[test]
fn mutated_openvdb_files_are_refused_or_read_within_memory_and_time() {
    let _turn = serial();
    let dir = common::scratch("vdb-fuzz");
    let mut pick = choices(41);
    let seeds =
        ["smoke.vdb", "constant.vdb", "affine.vdb"].map(|f| std::fs::read(common::asset("grids").join(f)).unwrap());
    let (mut refused, mut read) = (0, 0);
    for case in 0..1500 {
        let mut bytes = seeds[case % seeds.len()].clone();
        // The first 600 bytes hold the header, descriptors, metadata, transform and the
        // start of the topology.
        mutate_bytes(&mut bytes, 600, &mut pick);
        let path = dir.write("case.vdb", &bytes);
        let start = Instant::now();
        let (result, peak) = peak_of(|| lucent::medium::grid::DensityGrid::load_vdb(&path, None));
        let took = start.elapsed();
        let bound = GRID_READING + result.as_ref().map_or(0, |g| g.bytes());
        assert!(peak <= bound, "case {case}: reading took {peak} bytes at the peak, over {bound}");
        assert!(took < Duration::from_secs(10), "case {case}: reading took {took:?}");
        match result {
            Ok(_) => read += 1,
            Err(e) => {
                assert!(!e.contains('\n') && e.contains("case.vdb"), "case {case}: {e}");
                refused += 1;
            }
        }
    }
    // Both outcomes are exercised: a mutation in the leaf values still reads.
    assert!(refused > 100 && read > 100, "{refused} refused, {read} read");
}

/// Loads every mutant of `seeds` that `make` builds (from the seed's index and the choice
/// stream) within `FUZZ_LIMIT` and `CASE_TIME`, checking each outcome; returns how many
/// were refused and how many loaded.
fn fuzz_loads(
    what: &str,
    cases: usize,
    seed: u64,
    mut make: impl FnMut(usize, &mut dyn FnMut(usize) -> usize) -> Vec<u8>,
) -> (usize, usize) {
    let mut pick = choices(seed);
    let (mut refused, mut loaded) = (0, 0);
    for case in 0..cases {
        let bytes = make(case, &mut pick);
        let outcome = exercise(bytes, FUZZ_LIMIT).unwrap_or_else(|e| panic!("{what} case {case}: {e}"));
        check_outcome(&outcome, &FUZZ_LIMIT, &format!("{what} case {case}")).unwrap_or_else(|e| panic!("{e}"));
        match outcome.result {
            Ok(_) => loaded += 1,
            Err(_) => refused += 1,
        }
    }
    (refused, loaded)
}

/// A 16x16 lossless WebP of a gradient.
fn tiny_webp() -> Vec<u8> {
    let image = image::RgbaImage::from_fn(16, 16, |x, y| image::Rgba([(x * 16) as u8, (y * 16) as u8, 128, 255]));
    let mut out = Vec::new();
    image::codecs::webp::WebPEncoder::new_lossless(&mut out)
        .encode(image.as_raw(), 16, 16, image::ExtendedColorType::Rgba8)
        .unwrap();
    out
}

#[test]
fn mutated_ktx2_and_webp_textures_are_refused_or_loaded_within_the_limit_and_in_time() {
    let _turn = serial();
    let ktx2 = |name: &str| std::fs::read(common::asset("ktx2").join(name)).unwrap();
    let seeds = [
        ("KHR_texture_basisu", "image/ktx2", ktx2("uastc.ktx2")),
        ("KHR_texture_basisu", "image/ktx2", ktx2("etc1s.ktx2")),
        ("EXT_texture_webp", "image/webp", tiny_webp()),
    ];
    // The textured quad, its texture showing a second image (the mutant) through the
    // extension, as a file using it would.
    let (refused, loaded) = fuzz_loads("image", 900, 42, |case, pick| {
        let (extension, mime, seed) = &seeds[case % seeds.len()];
        let mut image = seed.clone();
        // KTX2's header and level index fill its first 104 bytes; a WebP's chunk headers
        // its first 30.
        mutate_bytes(&mut image, if mime.ends_with("ktx2") { 104 } else { 30 }, pick);
        let Parts { mut doc, buffer, .. } = Grid { n: 1, ..Grid::default() }.parts();
        let uri = format!("data:{mime};base64,{}", base64::engine::general_purpose::STANDARD.encode(&image));
        doc["images"].as_array_mut().unwrap().push(json!({"uri": uri}));
        doc["textures"][0]["extensions"] = json!({ *extension: {"source": 1} });
        doc["extensionsUsed"] = json!([extension]);
        encode(doc, &buffer)
    });
    assert!(refused > 100 && loaded > 30, "{refused} refused, {loaded} loaded");
}

#[test]
fn mutated_meshopt_and_draco_streams_are_refused_or_loaded_within_the_limit_and_in_time() {
    let _turn = serial();
    let seed = |dir: &str| {
        let doc: Value =
            serde_json::from_slice(&std::fs::read(common::asset(dir).join("cornell-box-glass.gltf")).unwrap()).unwrap();
        (doc, std::fs::read(common::asset(dir).join("cornell-box-glass.bin")).unwrap())
    };
    let seeds = [seed("meshopt"), seed("draco")];
    let (refused, loaded) = fuzz_loads("compressed mesh", 300, 43, |case, pick| {
        let (mut doc, mut buffer) = seeds[case % seeds.len()].clone();
        if pick(2) == 0 {
            mutate_bytes(&mut buffer, 0, pick);
        } else {
            // A number in a buffer view, mesh or accessor (a count, stride, length,
            // offset, index or attribute id) made hostile.
            let mut numbers = Vec::new();
            for key in ["bufferViews", "meshes", "accessors"] {
                number_paths(&doc[key], &mut vec![Value::from(key)], &mut numbers);
            }
            *value_at(&mut doc, &numbers[pick(numbers.len())]) = json!(HOSTILE_WORDS[pick(HOSTILE_WORDS.len())]);
        }
        encode(doc, &buffer)
    });
    assert!(refused > 50 && loaded > 30, "{refused} refused, {loaded} loaded");
}

/// The value at `path` (keys and indices, as `number_paths` lists them) under `v`.
fn value_at<'a>(v: &'a mut Value, path: &[Value]) -> &'a mut Value {
    path.iter().fold(v, |at, step| match step {
        Value::String(k) => &mut at[k.as_str()],
        Value::Number(i) => &mut at[i.as_u64().unwrap() as usize],
        _ => unreachable!("paths are keys and indices"),
    })
}

/// The paths (keys and indices) of every number under `v`.
fn number_paths(v: &Value, path: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    match v {
        Value::Number(_) => out.push(path.clone()),
        Value::Array(items) => {
            for (i, item) in items.iter().enumerate() {
                path.push(Value::from(i));
                number_paths(item, path, out);
                path.pop();
            }
        }
        Value::Object(map) => {
            for (k, item) in map {
                path.push(Value::from(k.as_str()));
                number_paths(item, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

/// What reading a view file or merging a small piece may take at the peak, with room to
/// spare (a 2 kB file parses in well under 1 MB; an 8x6 piece merges in less).
const SMALL_FILE_READING: u64 = 16 * MB;

/// A saved view with a camera, an environment, display settings and a material edit: every
/// table a view file has.
fn seed_view(dir: &Path) -> PathBuf {
    use lucent::config::{Edit, ViewFile};
    let mut view = ViewFile { camera: Some(builtin::cornell_box().cameras[0].1), ..ViewFile::default() };
    view.settings.width = 32;
    view.environment.background = glam::Vec3::new(0.2, 0.3, 0.4);
    view.display.exposure = 0.5;
    let values = [("roughness".to_string(), toml::Value::Float(0.25))].into_iter().collect();
    view.materials.push(Edit { index: 0, name: "white".into(), values });
    let path = dir.join("seed.toml");
    view.save(&path).unwrap();
    path
}

/// Hostile TOML values: not numbers, huge, negative, empty and of the wrong type.
fn hostile_toml(k: usize) -> toml::Value {
    use toml::Value as T;
    [
        T::Float(f64::NAN),
        T::Float(f64::INFINITY),
        T::Float(-1.0),
        T::Float(1e308),
        T::Integer(i64::MAX),
        T::Integer(-1),
        T::Integer(0),
        T::String("\u{0}".repeat(3)),
        T::Array(vec![]),
        T::Boolean(true),
    ][k]
        .clone()
}

/// The paths to every leaf value of a TOML table.
fn toml_leaves(v: &toml::Value, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        toml::Value::Table(t) => t.iter().for_each(|(k, item)| {
            path.push(k.clone());
            toml_leaves(item, path, out);
            path.pop();
        }),
        toml::Value::Array(items) => items.iter().enumerate().for_each(|(i, item)| {
            path.push(i.to_string());
            toml_leaves(item, path, out);
            path.pop();
        }),
        _ => out.push(path.clone()),
    }
}

#[test]
fn mutated_view_files_are_refused_in_one_line_or_load_to_a_view_that_saves_and_loads_again() {
    use lucent::config::ViewFile;
    let _turn = serial();
    let dir = common::scratch("view-fuzz");
    let text = std::fs::read_to_string(seed_view(&dir)).unwrap();
    let seed: toml::Value = toml::from_str(&text).unwrap();
    let mut leaves = Vec::new();
    toml_leaves(&seed, &mut Vec::new(), &mut leaves);
    let mut pick = choices(44);
    let (mut refused, mut loaded) = (0, 0);
    for case in 0..1500 {
        let bytes = if pick(4) == 0 {
            let mut bytes = text.clone().into_bytes();
            mutate_bytes(&mut bytes, text.len(), &mut pick);
            bytes
        } else {
            // A value replaced by a hostile one, or its key removed.
            let mut view = seed.clone();
            let path = &leaves[pick(leaves.len())];
            let mut at = &mut view;
            for step in &path[..path.len() - 1] {
                at = match at {
                    toml::Value::Array(items) => &mut items[step.parse::<usize>().unwrap()],
                    other => &mut other[step.as_str()],
                };
            }
            let last = &path[path.len() - 1];
            match (at, pick(11)) {
                (toml::Value::Table(t), 10) => drop(t.remove(last)),
                (toml::Value::Array(items), _) => items[last.parse::<usize>().unwrap()] = hostile_toml(pick(10)),
                (other, k) => other[last.as_str()] = hostile_toml(k % 10),
            }
            toml::to_string(&view).unwrap().into_bytes()
        };
        let path = dir.write("case.toml", &bytes);
        let (result, peak) = peak_of(|| ViewFile::load(&path));
        assert!(peak <= SMALL_FILE_READING, "case {case}: reading took {peak} bytes at the peak");
        match result {
            Ok(view) => {
                // What loads holds only values the tables allow: it writes and reads back
                // unchanged (a NaN would not compare equal, nor survive TOML).
                let again = dir.join("again.toml");
                view.save(&again).unwrap_or_else(|e| panic!("case {case}: {e}"));
                assert_eq!(ViewFile::load(&again).as_ref(), Ok(&view), "case {case}");
                loaded += 1;
            }
            Err(e) => {
                assert!(!e.contains('\n') && e.contains("case.toml"), "case {case}: {e}");
                refused += 1;
            }
        }
    }
    assert!(refused > 300 && loaded > 100, "{refused} refused, {loaded} loaded");
}

#[test]
fn mutated_render_pieces_are_refused_in_one_line_or_merge_within_memory() {
    let _turn = serial();
    let dir = common::scratch("piece-fuzz");
    let seed_path = dir.join("seed.part");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_lucent"))
        .args(["render", "--width", "8", "--height", "6", "--samples", "0..2", "--out"])
        .arg(&seed_path)
        .output()
        .unwrap();
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let seed = std::fs::read(&seed_path).unwrap();
    let header_len = seed.iter().position(|&b| b == b'\n').unwrap() + 1;
    let header: Value = serde_json::from_slice(&seed[..header_len]).unwrap();
    let mut numbers = Vec::new();
    number_paths(&header, &mut Vec::new(), &mut numbers);
    let mut pick = choices(45);
    let (mut refused, mut merged) = (0, 0);
    for case in 0..1000 {
        let bytes = if pick(2) == 0 {
            let mut bytes = seed.clone();
            mutate_bytes(&mut bytes, header_len, &mut pick);
            bytes
        } else {
            // A number of the header (frame, window, sample range, display) made hostile.
            let mut h = header.clone();
            *value_at(&mut h, &numbers[pick(numbers.len())]) = json!(HOSTILE_WORDS[pick(HOSTILE_WORDS.len())]);
            [format!("{h}\n").as_bytes(), &seed[header_len..]].concat()
        };
        let path = dir.write("case.part", &bytes);
        let (result, peak) = peak_of(|| lucent::film::merge::merge(std::slice::from_ref(&path), false, None));
        assert!(peak <= SMALL_FILE_READING, "case {case}: merging took {peak} bytes at the peak");
        match result {
            Ok(_) => merged += 1,
            Err(e) => {
                assert!(!e.contains('\n') && e.contains("case.part"), "case {case}: {e}");
                refused += 1;
            }
        }
    }
    assert!(refused > 300 && merged > 50, "{refused} refused, {merged} merged");
}

// --- the film ---

#[test]
fn the_film_estimate_covers_what_a_session_allocates_and_refuses_a_film_over_the_limit() {
    let _turn = serial();
    let scene = Arc::new(Scene::build(builtin::cornell_box()));
    let camera = scene.default_camera(1.0);
    let settings = Settings { width: 320, height: 240, target_spp: Some(4), ..Settings::default() };
    let job = || Job { scene: Arc::clone(&scene), camera, settings, window: None, aovs: false };
    let limits = Limits { memory: film_bytes(320, 240) };
    let (snapshot, peak) = peak_of(|| RenderSession::with_limits(job(), Some(2), limits).unwrap().wait_until_done());
    assert_eq!(snapshot.spp, 4);
    drop(snapshot);
    let film = film_bytes(320, 240);
    assert!(peak <= film + MB, "a session peaked at {peak} bytes, over its film estimate of {film} plus 1 MB");
    assert!(peak >= film / 2, "the film estimate of {film} bytes is far above the peak of {peak}");

    let too_small = Limits { memory: film - 1 };
    let (refused, peak) = peak_of(|| RenderSession::with_limits(job(), Some(2), too_small).err());
    let err = refused.expect("one byte short is refused");
    assert!(matches!(err, SessionError::TooLarge { width: 320, height: 240, .. }), "{err}");
    assert!(peak < MB, "refusing took {peak} bytes");
    let big = Settings { width: 16384, height: 16384, ..settings };
    let session = RenderSession::with_limits(job(), Some(1), Limits { memory: 12_000_000_000 }).unwrap();
    let err = session.set_job(Job { settings: big, ..job() }).unwrap_err().to_string();
    assert_eq!(
        err,
        "image too large: 16384x16384 needs about 34.6 GB for the film, over the memory limit of 12.0 GB: render it in windows (lucent render --region) and merge them"
    );
}

// --- synthetic scenes ---

/// A synthetic mesh: a grid of n x n quads (2 n^2 triangles, none degenerate) with normals
/// and UVs, textured by a 2x2 PNG.
#[derive(Clone, Copy, Default)]
struct Grid {
    n: usize,
    /// With a normal map, so that tangents are generated.
    normal_mapped: bool,
    /// As triangle strips (mode 5, one per row) instead of a list.
    strips: bool,
    /// With an emissive material, so that every triangle is a light.
    emissive: bool,
    /// Nodes placing the mesh, side by side (0 or 1: one node).
    copies: usize,
}

/// A grid's glTF document and buffer. Views: 0 positions, 1 normals, 2 UVs, 3 u32 indices,
/// 4 and 5 spare sparse indices (one u32) and values (12 bytes), 6 the PNG; accessors 0 to 3
/// read views 0 to 3.
struct Parts {
    doc: Value,
    buffer: Vec<u8>,
    /// Where the indices start in the buffer, and how many there are.
    indices_at: usize,
    index_count: usize,
    /// Where the PNG starts in the buffer.
    png_at: usize,
}

impl Grid {
    fn parts(self) -> Parts {
        let Grid { n, normal_mapped, strips, emissive, copies } = self;
        let side = n + 1;
        let mut buffer = Vec::new();
        for y in 0..side {
            for x in 0..side {
                put_f32(&mut buffer, &[x as f32, y as f32, ((x * y) % 7) as f32 * 0.01]);
            }
        }
        let normals_at = buffer.len();
        (0..side * side).for_each(|_| put_f32(&mut buffer, &[0., 0., 1.]));
        let uvs_at = buffer.len();
        for y in 0..side {
            for x in 0..side {
                put_f32(&mut buffer, &[x as f32 / n as f32, y as f32 / n as f32]);
            }
        }
        let indices_at = buffer.len();
        let at = |x: usize, y: usize| (y * side + x) as u32;
        let mut indices = Vec::new();
        for y in 0..n {
            if strips {
                // One strip per row, joined to the next by repeated vertices.
                (0..side).for_each(|x| indices.extend([at(x, y), at(x, y + 1)]));
                indices.extend([at(n, y + 1), at(0, y + 1)]);
            } else {
                for x in 0..n {
                    indices.extend([
                        at(x, y),
                        at(x + 1, y),
                        at(x + 1, y + 1),
                        at(x, y),
                        at(x + 1, y + 1),
                        at(x, y + 1),
                    ]);
                }
            }
        }
        indices.iter().for_each(|i| buffer.extend_from_slice(&i.to_le_bytes()));
        let sparse_at = buffer.len();
        buffer.extend_from_slice(&1u32.to_le_bytes());
        put_f32(&mut buffer, &[2., 0., 0.]);
        let png_at = buffer.len();
        let png = tiny_png();
        buffer.extend_from_slice(&png);
        let verts = side * side;
        let view = |offset: usize, end: usize| json!({"buffer": 0, "byteOffset": offset, "byteLength": end - offset});
        let mut primitive =
            json!({"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0});
        if strips {
            primitive["mode"] = json!(5);
        }
        let mut material = json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}});
        if normal_mapped {
            material["normalTexture"] = json!({"index": 0});
        }
        if emissive {
            material["emissiveFactor"] = json!([1.0, 0.5, 0.25]);
        }
        let copies = copies.max(1);
        let nodes: Vec<Value> = (0..copies)
            .map(|i| json!({"mesh": 0, "translation": [(n + 1) * (i % 100), (n + 1) * (i / 100), 0]}))
            .collect();
        let doc = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": (0..copies).collect::<Vec<_>>()}],
            "nodes": nodes,
            "meshes": [{"primitives": [primitive]}],
            "materials": [material],
            "textures": [{"source": 0}],
            "images": [{"bufferView": 6, "mimeType": "image/png"}],
            "buffers": [{"byteLength": buffer.len()}],
            "bufferViews": [
                view(0, normals_at), view(normals_at, uvs_at), view(uvs_at, indices_at), view(indices_at, sparse_at),
                view(sparse_at, sparse_at + 4), view(sparse_at + 4, png_at), view(png_at, png_at + png.len())
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": verts, "type": "VEC3", "min": [0, 0, 0], "max": [n, n, 0.06]},
                {"bufferView": 1, "componentType": 5126, "count": verts, "type": "VEC3"},
                {"bufferView": 2, "componentType": 5126, "count": verts, "type": "VEC2"},
                {"bufferView": 3, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}
            ]
        });
        Parts { doc, buffer, indices_at, index_count: indices.len(), png_at }
    }

    /// The glTF file.
    fn file(self) -> Vec<u8> {
        let Parts { doc, buffer, .. } = self.parts();
        encode(doc, &buffer)
    }
}

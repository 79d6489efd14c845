//! Ray queries alone: Lucent's closest-hit and occlusion queries on the rays that
//! `docs/peers/rays.py gen DIR` writes (camera, bounce and shadow rays in the Cornell box),
//! timed on a pool of worker threads, so that traversal can be set against Embree's on the
//! same rays (`rays.py mitsuba DIR`, then `rays.py compare DIR`). Prints the median machine
//! time per ray (wall time x threads / rays) and writes the answers beside the rays.
//!
//!     cargo run --release --example rays -- DIR [--runs 5] [--threads 2] [SCENE.gltf]

use glam::Vec3;
use lucent::film::output::replace_file;
use lucent::open::OpenOptions;
use lucent::scene::{Scene, geometry::Ray};
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Rays per task handed to a worker.
const CHUNK: usize = 4096;

/// The rays of `DIR/NAME.centred.bin` (in the frame Lucent keeps a glTF scene in, centred on its
/// meshes' bounds): seven little-endian floats each (origin, direction, tmax).
fn read_rays(path: &Path) -> Result<Vec<Ray>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    if bytes.len() % 28 != 0 {
        return Err(format!("{}: not a whole number of 28-byte rays", path.display()));
    }
    let f = |r: &[u8], i: usize| f32::from_le_bytes(r[4 * i..4 * i + 4].try_into().expect("four bytes"));
    Ok(bytes
        .chunks_exact(28)
        .map(|r| Ray {
            o: Vec3::new(f(r, 0), f(r, 1), f(r, 2)),
            d: Vec3::new(f(r, 3), f(r, 4), f(r, 5)),
            tmax: f(r, 6),
        })
        .collect())
}

/// One query's answer as `rays.py compare` reads it: a distance (infinity for a miss), or a
/// byte saying whether the ray is blocked.
enum Answers {
    Distances(Vec<f32>),
    Blocked(Vec<u8>),
}

impl Answers {
    fn into_bytes(self) -> Vec<u8> {
        match self {
            Answers::Distances(t) => t.iter().flat_map(|t| t.to_le_bytes()).collect(),
            Answers::Blocked(b) => b,
        }
    }
}

/// The query the path tracer makes for rays of kind `name`: closest hits (camera rays cull
/// single-sided backs, as in `Scene::intersect`) or occlusion.
fn answer(scene: &Scene, name: &str, rays: &[Ray]) -> Answers {
    let camera = name == "camera";
    if name == "shadow" {
        Answers::Blocked(
            rays.par_chunks(CHUNK).flat_map_iter(|c| c.iter().map(|r| scene.occluded(r, true) as u8)).collect(),
        )
    } else {
        Answers::Distances(
            rays.par_chunks(CHUNK)
                .flat_map_iter(|c| c.iter().map(|r| scene.intersect(r, true, camera).map_or(f32::INFINITY, |h| h.t)))
                .collect(),
        )
    }
}

fn run() -> Result<(), String> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut option = |name: &str, default: usize| -> Result<usize, String> {
        match args.iter().position(|a| a == name) {
            Some(i) => {
                let v = args
                    .get(i + 1)
                    .ok_or(format!("{name} needs a number"))?
                    .parse()
                    .map_err(|e| format!("{name}: {e}"))?;
                args.drain(i..i + 2);
                Ok(v)
            }
            None => Ok(default),
        }
    };
    let (runs, threads) = (option("--runs", 5)?.max(1), option("--threads", 2)?.max(1));
    let dir = PathBuf::from(args.first().ok_or("usage: rays DIR [--runs N] [--threads N] [SCENE.gltf]")?);
    let scene = lucent::open(args.get(1).map(Path::new), &OpenOptions::default(), &mut |_| {})?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| e.to_string())?;
    for name in ["camera", "bounce", "shadow"] {
        let rays = read_rays(&dir.join(format!("{name}.centred.bin")))?;
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..=runs {
            let start = Instant::now();
            let answers = pool.install(|| answer(&scene, name, &rays));
            times.push(start.elapsed().as_secs_f64());
            last = Some(answers);
        }
        // The first run warms the caches and the pool, as Mitsuba's first compiles its kernel.
        times.remove(0);
        times.sort_by(f64::total_cmp);
        let ns = times[times.len() / 2] * threads as f64 / rays.len() as f64 * 1e9;
        let out = dir.join(format!("{name}.lucent"));
        let bytes = last.expect("at least one run").into_bytes();
        replace_file(&out, |tmp| std::fs::write(tmp, &bytes)).map_err(|e| e.to_string())?;
        writeln!(
            std::io::stdout(),
            "{name}: {ns:.1} ns machine time per ray (Lucent, {threads} threads, median of {runs})"
        )
        .map_err(|e| format!("standard output: {e}"))?;
    }
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

//! `lucent bench throughput`: a fixed suite of scenes rendered by `lucent render` child
//! processes, printing samples/s, rays/s, BVH build seconds and peak memory of each, and
//! with `--baseline` the same from another build, the two alternating run by run so that
//! their ratio holds on a machine whose speed drifts.

use super::args::BenchArgs;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// One scene of the suite: its name, its file under the assets folder (None: the built-in
/// Cornell box) and the render options it needs.
struct Case {
    name: &'static str,
    file: Option<&'static str>,
    options: &'static [&'static str],
}

/// The suite the speed issue names: both Cornell boxes, a million-triangle model, and two
/// textured models under the built-in sky.
const SUITE: [Case; 5] = [
    Case { name: "cornell-box", file: None, options: &[] },
    Case { name: "cornell-box-glass", file: Some("cornell-box-glass.gltf"), options: &[] },
    Case {
        name: "MetalRoughSpheresNoTextures",
        file: Some("MetalRoughSpheresNoTextures/glTF-Binary/MetalRoughSpheresNoTextures.glb"),
        options: &[],
    },
    Case {
        name: "ToyCar (camera 1, sky)",
        file: Some("ToyCar/glTF/ToyCar.gltf"),
        options: &["--camera", "1", "--env", "built-in"],
    },
    Case {
        name: "WaterBottle (sky)",
        file: Some("WaterBottle/glTF/WaterBottle.gltf"),
        options: &["--env", "built-in"],
    },
];

/// What one `lucent render` process reported and used.
#[derive(Clone, Copy, Debug)]
struct Run {
    samples_per_second: f64,
    rays_per_second: f64,
    /// BVH build seconds, if the build prints them.
    bvh_seconds: Option<f64>,
    /// Whole process, seconds.
    wall: f64,
    /// Peak resident memory of the process, MiB.
    peak_mib: f64,
}

/// Runs `lucent bench throughput`.
pub fn run(args: &BenchArgs) -> Result<(), String> {
    if !args.scenes.is_empty() {
        return Err("bench throughput renders its own suite: give no scenes (--assets DIR says where they are)".into());
    }
    let this = std::env::current_exe().map_err(|e| format!("cannot find this program: {e}"))?;
    let builds: Vec<PathBuf> = std::iter::once(this).chain(args.baseline.clone()).collect();
    for b in &builds[1..] {
        if !b.is_file() {
            return Err(format!("--baseline {}: no such program", b.display()));
        }
    }
    let assets = args.assets.clone().unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/assets"));
    let size = args.size.unwrap_or(256);
    let temp = std::env::temp_dir().join(format!("lucent-throughput-{}", std::process::id()));
    std::fs::create_dir_all(&temp).map_err(|e| format!("{}: {e}", temp.display()))?;
    let threads = args.threads.map_or_else(|| rayon::current_num_threads().to_string(), |t| t.to_string());
    println!(
        "{size}x{size}, max depth 7, {} spp per run, {} runs of each build alternating, {threads} threads; medians",
        args.spp, args.runs
    );
    let result = suite(args, &builds, &assets, &temp, size, &threads);
    let _ = std::fs::remove_dir_all(&temp);
    result
}

/// Renders every case with every build, `runs` times in turn, and prints a table.
fn suite(
    args: &BenchArgs,
    builds: &[PathBuf],
    assets: &Path,
    temp: &Path,
    size: u32,
    threads: &str,
) -> Result<(), String> {
    let mut header = "| scene | Msamples/s | Mrays/s | BVH build s | peak MiB | process s |".to_string();
    let mut rule = "|---|---:|---:|---:|---:|---:|".to_string();
    if builds.len() > 1 {
        header += " baseline Msamples/s | samples/s ratio | peak MiB ratio |";
        rule += "---:|---:|---:|";
    }
    println!("{header}\n{rule}");
    for case in &SUITE {
        let scene = case.file.map(|f| assets.join(f));
        if let Some(s) = &scene
            && !s.is_file()
        {
            return Err(format!(
                "{}: not found (give --assets, the folder of the repository's tests/assets)",
                s.display()
            ));
        }
        let mut runs: Vec<Vec<Run>> = vec![Vec::new(); builds.len()];
        for _ in 0..args.runs {
            for (build, out) in builds.iter().zip(&mut runs) {
                let mut cmd = Command::new(build);
                cmd.arg("render");
                cmd.args(scene.iter());
                cmd.args(["--spp", &args.spp.to_string(), "--width", &size.to_string(), "--height", &size.to_string()]);
                // A fixed workload, whatever the estimator's defaults: 7 bounces, roulette
                // from 3 (the default docs/performance.md's suite figures ran with), so that builds
                // of any age compare.
                cmd.args(["--max-depth", "7", "--rr-depth", "3", "--threads", threads]);
                cmd.args(case.options).arg("--out").arg(temp.join("image.exr"));
                out.push(measure(cmd).map_err(|e| format!("{} with {}: {e}", case.name, build.display()))?);
            }
        }
        let a = median_run(&runs[0]);
        let mut row = format!(
            "| {} | {:.3} | {:.2} | {} | {:.0} | {:.2} |",
            case.name,
            a.samples_per_second / 1e6,
            a.rays_per_second / 1e6,
            a.bvh_seconds.map_or("-".into(), |s| format!("{s:.3}")),
            a.peak_mib,
            a.wall
        );
        if let Some(base) = runs.get(1) {
            let b = median_run(base);
            let ratio = median(runs[0].iter().zip(base).map(|(a, b)| a.samples_per_second / b.samples_per_second));
            let mem = median(runs[0].iter().zip(base).map(|(a, b)| a.peak_mib / b.peak_mib));
            row += &format!(" {:.3} | {ratio:.3} | {mem:.3} |", b.samples_per_second / 1e6);
        }
        println!("{row}");
    }
    Ok(())
}

/// The median of each figure of `runs` taken separately.
fn median_run(runs: &[Run]) -> Run {
    Run {
        samples_per_second: median(runs.iter().map(|r| r.samples_per_second)),
        rays_per_second: median(runs.iter().map(|r| r.rays_per_second)),
        bvh_seconds: runs
            .iter()
            .all(|r| r.bvh_seconds.is_some())
            .then(|| median(runs.iter().filter_map(|r| r.bvh_seconds))),
        wall: median(runs.iter().map(|r| r.wall)),
        peak_mib: median(runs.iter().map(|r| r.peak_mib)),
    }
}

fn median(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(f64::total_cmp);
    if v.is_empty() { f64::NAN } else { v[v.len() / 2] }
}

/// Runs one render process and reads its figures from what it printed; its peak memory
/// comes from the kernel's accounting of the finished process.
fn measure(mut cmd: Command) -> Result<Run, String> {
    let start = Instant::now();
    let mut child =
        cmd.stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().map_err(|e| e.to_string())?;
    let mut stderr = child.stderr.take().ok_or("no stderr")?;
    let err_reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let mut stdout = String::new();
    child.stdout.take().ok_or("no stdout")?.read_to_string(&mut stdout).map_err(|e| e.to_string())?;
    let (status, peak_kib) = wait_with_peak_memory(child.id())?;
    let wall = start.elapsed().as_secs_f64();
    let stderr = err_reader.join().unwrap_or_default();
    if !status {
        let why = stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("failed");
        return Err(why.to_string());
    }
    let figure = |text: &str, unit: &str| -> Option<f64> {
        let at = text.find(unit)?;
        text[..at].trim_end().rsplit([' ', ',', ':']).next()?.parse().ok()
    };
    let (samples_per_second, rays_per_sample) = (|| {
        let (spp, rest) = stdout.split_once(" spp at ")?;
        let spp: f64 = spp.rsplit(' ').next()?.parse().ok()?;
        let (w, rest) = rest.split_once('x')?;
        let (h, rest) = rest.split_once(" in ")?;
        let seconds: f64 = rest.split(' ').next()?.parse().ok()?;
        let samples = spp * w.parse::<f64>().ok()? * h.parse::<f64>().ok()?;
        // Samples/s from the count and the time, which carry more digits than the printed
        // rate (unless the render took under a millisecond), and rays/s from rays per sample.
        let printed = figure(&stdout, "Msamples/s")? * 1e6;
        let per_second = if seconds > 0.0 { samples / seconds } else { printed };
        Some((per_second, figure(&stdout, "Mrays/s")? * 1e6 / printed.max(f64::MIN_POSITIVE)))
    })()
    .ok_or_else(|| format!("no figures in its output: {stdout}"))?;
    let bvh_seconds =
        stderr.lines().find_map(|l| l.split_once("built in ").and_then(|(_, r)| r.split(' ').next()?.parse().ok()));
    Ok(Run {
        samples_per_second,
        rays_per_second: samples_per_second * rays_per_sample,
        bvh_seconds,
        wall,
        peak_mib: peak_kib / 1024.0,
    })
}

/// Waits for process `pid` and returns whether it exited with status 0, and its peak
/// resident memory in KiB (`ru_maxrss` of that process alone, which `std::process`
/// does not expose).
fn wait_with_peak_memory(pid: u32) -> Result<(bool, f64), String> {
    let mut status = 0;
    // SAFETY: `rusage` is plain data that wait4 fills in; both pointers are to live locals,
    // and `pid` is our own child, which std has not waited for (so it is not reused).
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid as libc::pid_t, &mut status, 0, &mut usage) };
    if r < 0 {
        return Err(format!("wait4: {}", std::io::Error::last_os_error()));
    }
    Ok((libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0, usage.ru_maxrss as f64))
}

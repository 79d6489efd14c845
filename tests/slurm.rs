//! On a Slurm cluster (CI starts a single-node one with `.ci/slurm-cluster`), the job
//! scripts `lucent farm slurm` writes render 4 pieces and merge them into the image one
//! process renders, bit for bit, although one piece is killed mid-way (SIGKILL: its task
//! requeues itself) and another is requeued by the scheduler (`scontrol requeue`, as a
//! preemption does). Without a cluster the test says so and passes, unless
//! LUCENT_REQUIRE_SLURM is set (CI sets it, so there it must run).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn run(program: &str, args: &[&str]) -> (bool, String) {
    match Command::new(program).args(args).output() {
        Ok(out) => (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr),
        ),
        Err(e) => (false, format!("{program}: {e}")),
    }
}

/// The `Key=value` fields of `scontrol -o show job ID`, one map per record.
fn job_fields(id: &str) -> Vec<Vec<(String, String)>> {
    let (_, out) = run("scontrol", &["-o", "show", "job", id]);
    out.lines()
        .map(|l| {
            l.split_whitespace()
                .filter_map(|f| f.split_once('=').map(|(k, v)| (k.to_string(), v.to_string())))
                .collect()
        })
        .collect()
}

fn field(record: &[(String, String)], key: &str) -> String {
    record.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone()).unwrap_or_default()
}

/// Waits until `check` holds, polling; panics with `what` and the logs after `limit`.
fn wait_for(what: &str, limit: Duration, logs: &Path, mut check: impl FnMut() -> bool) {
    let start = Instant::now();
    while !check() {
        if start.elapsed() > limit {
            let (_, queue) = run("squeue", &[]);
            let logs: String = std::fs::read_dir(logs)
                .into_iter()
                .flatten()
                .flatten()
                .map(|e| format!("{}:\n{}", e.path().display(), std::fs::read_to_string(e.path()).unwrap_or_default()))
                .collect();
            panic!("timed out waiting for {what}\nsqueue:\n{queue}\n{logs}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The pid of a running `lucent render` writing `piece`.
fn render_process(piece: &str) -> Option<u32> {
    std::fs::read_dir("/proc").ok()?.flatten().find_map(|e| {
        let pid: u32 = e.file_name().to_str()?.parse().ok()?;
        let cmdline = std::fs::read(e.path().join("cmdline")).ok()?;
        let args: Vec<&[u8]> = cmdline.split(|&b| b == 0).collect();
        let is_render = args.first().is_some_and(|a| a.ends_with(b"lucent")) && args.iter().any(|a| *a == b"render");
        (is_render && args.iter().any(|a| a.ends_with(piece.as_bytes()))).then_some(pid)
    })
}

#[test]
fn farm_job_scripts_merge_to_the_single_process_image_despite_a_killed_and_a_requeued_piece() {
    if !run("sinfo", &["-h"]).0 {
        assert!(std::env::var_os("LUCENT_REQUIRE_SLURM").is_none(), "LUCENT_REQUIRE_SLURM is set but sinfo fails");
        eprintln!("no Slurm cluster answers (sinfo): the farm test needs one (.ci/slurm-cluster start)");
        return;
    }
    let dir = common::scratch("slurm");
    let p = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    let lucent = env!("CARGO_BIN_EXE_lucent");
    let farm = [
        "farm",
        "slurm",
        "--pieces",
        "4",
        "--dir",
        &p(""),
        "--out",
        &p("merged.exr"),
        "--width",
        "128",
        "--height",
        "96",
        "--spp",
        "1024",
    ];
    let (ok, out) = run(lucent, &farm);
    assert!(ok, "{out}");
    let (ok, out) = run("bash", &[&p("submit.sh")]);
    assert!(ok, "{out}");
    // "pieces: job array A; merge: job M"
    let ids: Vec<String> =
        out.split(|c: char| !c.is_ascii_digit()).filter(|s| !s.is_empty()).map(str::to_string).collect();
    let [array, merge] = &ids[..] else { panic!("submit.sh said: {out}") };
    let logs = PathBuf::from(p("logs"));

    // Piece 1: its render killed mid-way; the task requeues itself.
    let mut victim = None;
    wait_for("piece 1 to start", Duration::from_secs(300), &logs, || {
        victim = render_process("piece-0001.part");
        victim.is_some()
    });
    std::thread::sleep(Duration::from_millis(500));
    assert!(!dir.join("pieces/piece-0001.part").exists(), "piece 1 finished before it could be killed");
    assert!(run("kill", &["-9", &victim.unwrap().to_string()]).0);

    // Piece 2: requeued by the scheduler while it runs.
    let task2 = format!("{array}_2");
    wait_for("piece 2 to run", Duration::from_secs(300), &logs, || render_process("piece-0002.part").is_some());
    std::thread::sleep(Duration::from_millis(500));
    let (ok, out) = run("scontrol", &["requeue", &task2]);
    assert!(ok, "scontrol requeue {task2}: {out}");

    wait_for("the merge job", Duration::from_secs(600), &logs, || {
        let state = job_fields(merge).first().map(|r| field(r, "JobState")).unwrap_or_default();
        assert!(
            !["FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL", "OUT_OF_MEMORY"].contains(&state.as_str()),
            "merge job {merge}: {state}; {}",
            std::fs::read_to_string(logs.join("merge.log")).unwrap_or_default()
        );
        state == "COMPLETED"
    });
    for task in ["1", "2"] {
        let record = job_fields(&format!("{array}_{task}")).remove(0);
        assert_eq!(field(&record, "JobState"), "COMPLETED", "piece {task}");
        assert_eq!(field(&record, "Restarts"), "1", "piece {task} ran twice");
    }
    let log1 = std::fs::read_to_string(logs.join("piece-1.log")).unwrap();
    assert!(log1.contains("piece 1: killed (status 137), requeued"), "{log1}");

    let (ok, out) = run(lucent, &["render", "--view", &p("view.toml"), "--out", &p("single.exr")]);
    assert!(ok, "{out}");
    assert_eq!(
        std::fs::read(dir.join("single.exr")).unwrap(),
        std::fs::read(dir.join("merged.exr")).unwrap(),
        "the farm's merge differs from the single-process render"
    );
}

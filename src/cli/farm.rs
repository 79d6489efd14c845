//! `lucent farm slurm`: writes the job scripts that render a scene as pieces on a Slurm
//! cluster and merge them. A job array renders one piece per task (a sample range, or a
//! band of rows); a task killed by a signal (a lost node, the OOM killer, preemption)
//! requeues itself, and a piece already written is not rendered again; the merge job runs
//! `afterok` on the whole array. Every piece reads one view file, so all of them render
//! the same view with the same settings.

use super::args::{FarmSlurmArgs, Split};
use crate::film::TILE_SIZE;
use crate::film::merge::pieces_in;
use crate::film::output::check_writable;
use crate::film::window::Window;
use crate::open::OpenOptions;
use crate::render::{film_bytes, threshold_bytes};
use std::fmt::Write as _;
use std::path::Path;

/// One piece: its sample range and window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PieceSpec {
    /// First sample index.
    pub first: u32,
    /// Sample index after the last.
    pub end: u32,
    /// The frame's pixels.
    pub window: Window,
}

/// Cuts a `width` x `height`, `spp`-sample render into `n` pieces of nearly equal cost:
/// sample ranges of the whole frame, or bands of whole rows with every sample. With a
/// noise `threshold` only bands can be cut, on the tile grid, where pixels stop as in
/// the whole frame (`render::on_tile_grid`).
pub fn split(
    split: Split,
    n: u32,
    spp: u32,
    (width, height): (u32, u32),
    threshold: bool,
) -> Result<Vec<PieceSpec>, String> {
    if threshold && split == Split::Samples {
        return Err("a noise threshold stops pixels by their samples from the first on, so the render cannot be cut into sample ranges: use --split regions".into());
    }
    let rows = if threshold { TILE_SIZE } else { 1 };
    let (limit, what) = match split {
        Split::Samples => (spp, "samples per pixel".to_string()),
        Split::Regions if threshold => (height.div_ceil(rows), format!("bands of {rows} rows (the tile grid)")),
        Split::Regions => (height, "rows".to_string()),
    };
    if n == 0 || n > limit {
        return Err(format!("--pieces {n}: between 1 and the render's {limit} {what}"));
    }
    let cut = |i: u32| (limit as u64 * i as u64 / n as u64) as u32;
    let row = |i: u32| (cut(i) * rows).min(height);
    Ok((0..n)
        .map(|i| match split {
            Split::Samples => PieceSpec { first: cut(i), end: cut(i + 1), window: Window::full(width, height) },
            Split::Regions => {
                PieceSpec { first: 0, end: spp, window: Window { x0: 0, y0: row(i), x1: width, y1: row(i + 1) } }
            }
        })
        .collect())
}

/// A word for bash, single-quoted.
fn quote(text: &str) -> String {
    format!("'{}'", text.replace('\'', r"'\''"))
}

/// A path for bash, made absolute (the cluster's nodes start elsewhere).
fn absolute(path: &Path) -> Result<String, String> {
    let p = std::path::absolute(path).map_err(|e| format!("{}: {e}", path.display()))?;
    p.to_str().map(quote).ok_or_else(|| format!("{}: not a UTF-8 path", p.display()))
}

/// Checks a value written into an `#SBATCH` line, which Slurm reads without quoting.
fn sbatch_word(option: &str, value: &str) -> Result<(), String> {
    if value.is_empty() || value.chars().any(|c| c.is_whitespace() || c.is_control() || c == '\'' || c == '"') {
        return Err(format!("{option} {value:?}: #SBATCH lines take no spaces, quotes or control characters"));
    }
    Ok(())
}

/// Runs `lucent farm slurm`.
pub fn run(args: &FarmSlurmArgs) -> Result<(), String> {
    sbatch_word("--dir", &args.dir.to_string_lossy())?;
    for (option, value) in [("--mem", &args.mem), ("--partition", &args.partition), ("--time-limit", &args.time_limit)]
    {
        if let Some(v) = value {
            sbatch_word(option, v)?;
        }
    }
    let mut view = args.options.resolve(Some(64))?;
    let s = view.settings;
    let spp = s.target_spp.expect("a default target is given");
    if s.integrator.is_bidirectional() && args.split == Split::Regions {
        return Err(format!(
            "--integrator {} renders whole frames only (a region's light paths land anywhere in the frame): use --split samples",
            s.integrator.name()
        ));
    }
    let pieces = split(args.split, args.pieces, spp, (s.width, s.height), s.noise_threshold.is_some())?;
    if args.options.threads.is_some() {
        return Err("--threads: each piece uses the CPUs Slurm gives it (--cpus)".into());
    }
    let scene = super::render::open_scene(
        args.scene.as_deref(),
        &OpenOptions {
            environment: view.environment.clone(),
            keep_dark: args.options.keeps_dark(),
            variant: args.options.variant.clone(),
            instancing: args.options.instancing(),
            ..OpenOptions::default()
        },
    )?;
    // The pieces apply the view file's edits: a material it names must be in the scene.
    view.apply_edits(&mut scene.materials.clone(), &mut scene.lights.clone())?;
    view.camera = Some(match args.options.camera {
        Some(i) => scene.file_camera(i).map_err(|e| format!("--{e}"))?,
        None => view.camera.unwrap_or_else(|| scene.default_camera(s.width as f32 / s.height as f32)),
    });
    // The pieces render from the view file, so it names the sky a scene without light of
    // its own was given.
    if let Some(env) = &scene.environment {
        view.environment = env.settings.clone();
    }
    if let Some(map) = &view.environment.map
        && map.as_os_str() != "built-in"
    {
        view.environment.map = Some(std::path::absolute(map).map_err(|e| format!("{}: {e}", map.display()))?);
    }
    let dir = &args.dir;
    std::fs::create_dir_all(dir.join("pieces")).map_err(|e| format!("{}: {e}", dir.display()))?;
    std::fs::create_dir_all(dir.join("logs")).map_err(|e| format!("{}: {e}", dir.display()))?;
    check_writable(&args.out).map_err(|e| e.to_string())?;
    if !pieces_in(&dir.join("pieces"))?.is_empty() {
        return Err(format!("{} already holds pieces: give another --dir", dir.join("pieces").display()));
    }
    view.save(&dir.join("view.toml"))?;
    let lucent = match &args.lucent {
        Some(p) => p.clone(),
        None => std::env::current_exe().map_err(|e| format!("the lucent binary: {e}"))?,
    };
    let scripts = Scripts { args, pieces: &pieces, spp, lucent: absolute(&lucent)?, dir: absolute(dir)? };
    for (name, text) in
        [("render.sbatch", scripts.render()?), ("merge.sbatch", scripts.merge()?), ("submit.sh", scripts.submit())]
    {
        let path = dir.join(name);
        crate::film::output::replace_file(&path, |tmp| std::fs::write(tmp, &text)).map_err(|e| e.to_string())?;
    }
    let bytes = |w: &Window| {
        let extra = if s.noise_threshold.is_some() { threshold_bytes(w.width(), w.height()) } else { 0 };
        film_bytes(w.width(), w.height()) + extra
    };
    let largest = pieces.iter().map(|p| bytes(&p.window)).max().unwrap_or(0);
    println!(
        "{}: {} pieces of {} spp at {}x{} (each holds a film of at most {}, besides the scene); submit them with: bash {}",
        scene.name,
        pieces.len(),
        spp,
        s.width,
        s.height,
        crate::memory::format_bytes(largest),
        dir.join("submit.sh").display()
    );
    Ok(())
}

/// The three scripts' common parts.
struct Scripts<'a> {
    args: &'a FarmSlurmArgs,
    pieces: &'a [PieceSpec],
    spp: u32,
    lucent: String,
    dir: String,
}

impl Scripts<'_> {
    /// `#SBATCH` lines every job shares.
    fn common(&self, out: &mut String) {
        if let Some(p) = &self.args.partition {
            let _ = writeln!(out, "#SBATCH --partition={p}");
        }
        if let Some(t) = &self.args.time_limit {
            let _ = writeln!(out, "#SBATCH --time={t}");
        }
    }

    /// The job array: one task per piece.
    fn render(&self) -> Result<String, String> {
        let mut scene = match &self.args.scene {
            Some(p) => format!(" {}", absolute(p)?),
            None => String::new(),
        };
        if let Some(v) = &self.args.options.variant {
            scene.push_str(&format!(" --variant {}", quote(v)));
        }
        scene.push_str(&format!(" --instancing {}", self.args.options.instancing));
        let mut out = String::new();
        let _ = writeln!(out, "#!/bin/bash");
        let _ = writeln!(out, "# One piece of the render per task of the array (written by lucent farm slurm).");
        let _ = writeln!(out, "#SBATCH --job-name=lucent-pieces");
        let _ = writeln!(out, "#SBATCH --array=0-{}", self.pieces.len() - 1);
        let _ = writeln!(out, "#SBATCH --cpus-per-task={}", self.args.cpus);
        if let Some(m) = &self.args.mem {
            let _ = writeln!(out, "#SBATCH --mem={m}");
        }
        self.common(&mut out);
        let _ = writeln!(out, "#SBATCH --requeue");
        let _ = writeln!(out, "#SBATCH --open-mode=append");
        let _ = writeln!(out, "#SBATCH --output={}/logs/piece-%a.log", self.dir.trim_matches('\''));
        let _ = writeln!(out, "set -u");
        let samples: Vec<String> = self.pieces.iter().map(|p| format!("{}..{}", p.first, p.end)).collect();
        let regions: Vec<String> = self.pieces.iter().map(|p| p.window.to_string()).collect();
        let _ = writeln!(out, "samples=({})", samples.join(" "));
        let _ = writeln!(out, "regions=({})", regions.join(" "));
        let _ = writeln!(out, "i=$SLURM_ARRAY_TASK_ID");
        let _ = writeln!(out, "piece={}/pieces/piece-$(printf %04d \"$i\").part", self.dir);
        let _ = writeln!(out, "# A piece is renamed into place once whole: one that exists is done.");
        let _ = writeln!(out, "[ -f \"$piece\" ] && exit 0");
        let _ = writeln!(
            out,
            "{} render{scene} --view {}/view.toml --samples \"${{samples[$i]}}\" --region \"${{regions[$i]}}\" --threads \"${{SLURM_CPUS_PER_TASK:-1}}\" --out \"$piece\"",
            self.lucent, self.dir
        );
        let _ = writeln!(out, "status=$?");
        let _ = writeln!(out, "# Killed by a signal (a lost node, the OOM killer, preemption): run again, at most");
        let _ = writeln!(out, "# 3 times. An error of its own (a bad scene) is not retried.");
        let _ = writeln!(out, "if [ \"$status\" -gt 128 ] && [ \"${{SLURM_RESTART_COUNT:-0}}\" -lt 3 ]; then");
        let _ = writeln!(out, "    echo \"piece $i: killed (status $status), requeued\"");
        let _ = writeln!(out, "    scontrol requeue \"${{SLURM_ARRAY_JOB_ID}}_${{SLURM_ARRAY_TASK_ID}}\"");
        let _ = writeln!(out, "fi");
        let _ = writeln!(out, "exit \"$status\"");
        Ok(out)
    }

    /// The merge, run once every piece has succeeded.
    fn merge(&self) -> Result<String, String> {
        let mut out = String::new();
        let _ = writeln!(out, "#!/bin/bash");
        let _ = writeln!(out, "# Merges the pieces into the image (written by lucent farm slurm).");
        let _ = writeln!(out, "#SBATCH --job-name=lucent-merge");
        let _ = writeln!(out, "#SBATCH --cpus-per-task=1");
        self.common(&mut out);
        let _ = writeln!(out, "#SBATCH --output={}/logs/merge.log", self.dir.trim_matches('\''));
        let _ = writeln!(out, "set -eu");
        let _ = writeln!(
            out,
            "{} merge {}/pieces --spp {} --out {}",
            self.lucent,
            self.dir,
            self.spp,
            absolute(&self.args.out)?
        );
        Ok(out)
    }

    /// Submits the array, and the merge to run after it.
    fn submit(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "#!/bin/bash");
        let _ = writeln!(out, "# Submits the pieces and the merge (written by lucent farm slurm).");
        let _ = writeln!(out, "set -euo pipefail");
        let _ = writeln!(out, "cd {}", self.dir);
        let _ = writeln!(out, "pieces=$(sbatch --parsable render.sbatch)");
        let _ = writeln!(out, "pieces=${{pieces%%;*}}");
        let _ = writeln!(
            out,
            "merge=$(sbatch --parsable --dependency=afterok:\"$pieces\" --kill-on-invalid-dep=yes merge.sbatch)"
        );
        let _ = writeln!(out, "echo \"pieces: job array $pieces; merge: job ${{merge%%;*}}\"");
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_cover_the_render_once() {
        let by_samples = split(Split::Samples, 3, 10, (8, 6), false).unwrap();
        assert_eq!(by_samples.iter().map(|p| (p.first, p.end)).collect::<Vec<_>>(), [(0, 3), (3, 6), (6, 10)]);
        let bands = split(Split::Regions, 4, 10, (8, 6), false).unwrap();
        assert_eq!(
            bands.iter().map(|p| (p.window.y0, p.window.y1)).collect::<Vec<_>>(),
            [(0, 1), (1, 3), (3, 4), (4, 6)]
        );
        assert!(bands.iter().all(|p| (p.first, p.end, p.window.x0, p.window.x1) == (0, 10, 0, 8)));
        assert!(split(Split::Samples, 11, 10, (8, 6), false).is_err());
        assert!(split(Split::Regions, 0, 10, (8, 6), false).is_err());
        // With a noise threshold: bands on the tile grid, no sample ranges.
        let bands = split(Split::Regions, 3, 10, (8, 70), true).unwrap();
        let rows: Vec<(u32, u32)> = bands.iter().map(|p| (p.window.y0, p.window.y1)).collect();
        assert_eq!(rows, [(0, 16), (16, 48), (48, 70)]);
        assert!(bands.iter().all(|p| crate::render::on_tile_grid(&p.window, 8, 70)));
        assert!(split(Split::Regions, 6, 10, (8, 70), true).unwrap_err().contains("5 bands of 16 rows"));
        assert!(split(Split::Samples, 2, 10, (8, 70), true).unwrap_err().contains("--split regions"));
        assert_eq!(quote("it's"), r"'it'\''s'");
    }
}

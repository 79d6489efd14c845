//! The `lucent` command as a user runs it: outputs, and one-line errors with a non-zero
//! exit and no file left behind for bad input.

mod common;

use std::path::Path;
use std::process::{Command, Output};

fn lucent(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lucent")).args(args).output().expect("runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn fails_in_one_line(args: &[&str], needle: &str, out: &Path) {
    let o = lucent(args);
    assert!(!o.status.success(), "{args:?} succeeded");
    let err = stderr(&o);
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: one line, got {err:?}");
    assert!(err.contains(needle), "{args:?}: {err:?} lacks {needle:?}");
    assert!(!out.exists(), "{args:?} left {out:?} behind");
    if let Ok(entries) = std::fs::read_dir(out.parent().unwrap()) {
        let leftovers: Vec<_> = entries.collect();
        assert!(leftovers.is_empty(), "{args:?} left partial files: {leftovers:?}");
    }
}

#[test]
fn renders_png_and_exr_and_reports_figures() {
    let dir = common::scratch("cli-ok");
    for name in ["cornell.png", "cornell.exr"] {
        let out = dir.join(name);
        let o = lucent(&["render", "--spp", "4", "--width", "40", "--height", "30", "--out", out.to_str().unwrap()]);
        assert!(o.status.success(), "{}", stderr(&o));
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            stdout.contains("4 spp at 40x30") && stdout.contains("Mrays/s") && stdout.contains("0 NaN/Inf"),
            "{stdout}"
        );
        let img = image::open(&out).unwrap();
        assert_eq!((img.width(), img.height()), (40, 30));
    }
    let exr = image::open(dir.join("cornell.exr")).unwrap().into_rgb32f();
    let max = exr.as_raw().iter().fold(0.0f32, |a, &b| a.max(b));
    assert!(max > 1.0, "EXR keeps linear HDR radiance (the light is {max})");
}

#[test]
fn a_time_budget_renders_what_fits() {
    let dir = common::scratch("cli-time");
    let out = dir.join("t.exr");
    let o = lucent(&["render", "--time", "0.5", "--width", "16", "--height", "16", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.exists());
}

#[test]
fn bad_input_gives_one_line_errors_and_no_file() {
    let dir = common::scratch("cli-bad");
    let out = dir.join("x.png");
    let o = out.to_str().unwrap();
    fails_in_one_line(&["render", "/no/such/scene.glb", "--out", o], "no such file", &out);
    fails_in_one_line(&["render", "--lights", "bogus", "--out", o], "bogus", &out);
    fails_in_one_line(&["render", "--spp", "0", "--out", o], "--spp: 0 is not at least 1", &out);
    fails_in_one_line(&["render", "--spp", "-3", "--out", o], "--spp: -3 is not at least 1", &out);
    fails_in_one_line(&["render", "--width", "0", "--out", o], "--width: 0 is not in 1..=16384", &out);
    fails_in_one_line(&["render", "--strata", "65", "--out", o], "--strata: 65 is not in 1..=64", &out);
    fails_in_one_line(&["render", "--time", "-1", "--out", o], "--time", &out);
    fails_in_one_line(&["render", "--clamp", "-2", "--out", o], "--clamp: -2 is not a finite number", &out);
    fails_in_one_line(&["render", "--importance", "maybe", "--out", o], "--importance: 'maybe' is not on or off", &out);
    fails_in_one_line(&["view", "--screenshot", o], "--screenshot needs --spp", &out);
    let folder = common::scratch("cli-a-directory");
    let directory = folder.join("a.png");
    std::fs::create_dir(&directory).unwrap();
    let o = lucent(&["render", "--spp", "1", "--out", directory.to_str().unwrap()]);
    assert!(!o.status.success() && stderr(&o).contains("it is a directory"), "{}", stderr(&o));
    let o = out.to_str().unwrap();
    fails_in_one_line(&["render", "--without", "epsilons", "--out", o], "epsilons", &out);
    fails_in_one_line(&["render", "--env", "/no/such/sky.hdr", "--out", o], "sky.hdr", &out);
    fails_in_one_line(&["render", "--camera", "3", "--out", o], "cornell-box has 1 camera", &out);
    fails_in_one_line(&["render", "--background", "1,1", "--env-intensity", "2", "--out", o], "three values", &out);
    fails_in_one_line(&["render", "--background", "1,1,1", "--env-intensity", "-1", "--out", o], "intensity", &out);
    let drt = ["render", "--integrator", "distribution", "--branching", "64", "--max-depth", "4", "--out", o];
    fails_in_one_line(&drt, "--allow-expensive", &out);
    fails_in_one_line(&["render", "--out", dir.join("x.jpg").to_str().unwrap()], ".png or .exr", &dir.join("x.jpg"));
    let unwritable = dir.join("missing-dir/x.png");
    fails_in_one_line(&["render", "--out", unwritable.to_str().unwrap()], "cannot write", &unwritable);
    // A FIFO blocked the read forever and /dev/zero read until memory ran out.
    let fifos = common::scratch("cli-fifo");
    for name in ["view.toml", "piece.part"] {
        assert!(Command::new("mkfifo").arg(fifos.join(name)).status().unwrap().success());
    }
    let view = fifos.join("view.toml");
    fails_in_one_line(&["render", "--view", view.to_str().unwrap(), "--out", o], "view.toml: not a regular file", &out);
    fails_in_one_line(&["render", "--view", "/dev/zero", "--out", o], "/dev/zero: not a regular file", &out);
    let piece = fifos.join("piece.part");
    fails_in_one_line(&["merge", piece.to_str().unwrap(), "--out", o], "piece.part: not a regular file", &out);
    let scene = common::scratch("cli-garbage");
    let garbage = scene.join("broken.glb");
    std::fs::write(&garbage, b"glTF\x02\x00\x00\x00garbage").unwrap();
    fails_in_one_line(&["render", garbage.to_str().unwrap(), "--out", o], "broken.glb", &out);
}

#[test]
fn the_memory_budget_heeds_the_process_address_space_limit() {
    // Under a 2 GB RLIMIT_AS (the machine has more), an 8000x8000 film (8.3 GB) was checked
    // against half the machine's memory, allocated and aborted; it is refused in one line.
    let dir = common::scratch("cli-ulimit");
    let out = dir.join("x.exr");
    let o = Command::new("bash")
        .arg("-c")
        .arg(format!(
            "ulimit -v 2000000 && exec {} render --width 8000 --height 8000 --spp 1 --out {}",
            env!("CARGO_BIN_EXE_lucent"),
            out.display()
        ))
        .output()
        .expect("runs");
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("over the memory limit of 1."), "{err}");
    assert!(!out.exists());
}

#[test]
fn a_saved_view_renders_headless_and_options_override_it() {
    use lucent::config::ViewFile;
    use lucent::integrator::Settings;
    let dir = common::scratch("cli-view");
    let view = dir.join("v.toml");
    let settings = Settings { width: 24, height: 16, max_depth: 0, ..Settings::default() };
    ViewFile { settings, ..ViewFile::default() }.save(&view).unwrap();
    let render = |extra: &[&str], out: &Path| {
        let mut args = vec!["render", "--spp", "2", "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        let o = lucent(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        image::open(out).unwrap().into_rgb32f()
    };
    let from_view = render(&["--view", view.to_str().unwrap()], &dir.join("a.exr"));
    let from_flags = render(&["--width", "24", "--height", "16", "--max-depth", "0"], &dir.join("b.exr"));
    assert_eq!(from_view.dimensions(), (24, 16));
    assert!(from_view.as_raw() == from_flags.as_raw(), "the view file sets the same image as the flags");
    let overridden = render(&["--view", view.to_str().unwrap(), "--max-depth", "3"], &dir.join("c.exr"));
    assert!(overridden.as_raw() != from_view.as_raw(), "--max-depth overrides the file");
    // The environment is part of the view: the file and the flags light the box alike
    // (through its open front), and differently from no environment.
    let lit = dir.join("lit.toml");
    let environment = lucent::scene::environment::EnvSettings {
        background: glam::Vec3::new(0.2, 0.4, 0.8),
        intensity: 2.0,
        ..Default::default()
    };
    let settings = Settings { max_depth: 2, ..settings };
    ViewFile { settings, environment, ..ViewFile::default() }.save(&lit).unwrap();
    let env_view = render(&["--view", lit.to_str().unwrap()], &dir.join("e.exr"));
    let env_flags = render(
        &["--width", "24", "--height", "16", "--max-depth", "2", "--background", "0.2,0.4,0.8", "--env-intensity", "2"],
        &dir.join("f.exr"),
    );
    let unlit = render(&["--width", "24", "--height", "16", "--max-depth", "2"], &dir.join("g.exr"));
    assert!(env_view.as_raw() == env_flags.as_raw(), "the view file sets the same environment as the flags");
    assert!(env_view.as_raw() != unlit.as_raw(), "the background lights the box");
    std::fs::write(&view, "[settings]\nwidth = \"wide\"\n").unwrap();
    let clean_dir = common::scratch("cli-view-bad");
    let clean = clean_dir.join("d.png");
    fails_in_one_line(
        &["render", "--view", view.to_str().unwrap(), "--out", clean.to_str().unwrap()],
        "v.toml",
        &clean,
    );
}

#[test]
fn the_built_in_sky_is_chosen_by_name_on_the_command_line_and_in_a_view_file() {
    // The box's open front sees the sky: the map lights it, alike from the flag and the file.
    let dir = common::scratch("cli-built-in");
    let render = |extra: &[&str], out: &str| {
        let out = dir.join(out);
        let mut args =
            vec!["render", "--spp", "2", "--strata", "1", "--width", "24", "--height", "16", "--max-depth", "2"];
        args.extend_from_slice(extra);
        args.extend(["--out", out.to_str().unwrap()]);
        let o = lucent(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        image::open(out).unwrap().into_rgb32f()
    };
    let view = dir.join("sky.toml");
    std::fs::write(&view, "[environment]\nmap = \"built-in\"\n").unwrap();
    let from_flag = render(&["--env", "built-in"], "flag.exr");
    let from_view = render(&["--view", view.to_str().unwrap()], "view.exr");
    let unlit = render(&[], "unlit.exr");
    assert!(from_flag.as_raw() == from_view.as_raw(), "the flag and the view file choose the same sky");
    assert!(from_flag.as_raw() != unlit.as_raw(), "the built-in sky lights the box");
    let help = String::from_utf8_lossy(&lucent(&["render", "--help"]).stdout).into_owned();
    assert!(help.contains("built-in"), "--env's help names the built-in map: {help}");
}

#[test]
fn bench_robustness_measures_every_mechanism_against_all_on() {
    let o = lucent(&["bench", "robustness", "--runs", "1", "--spp", "1", "--size", "16"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    for label in ["all mechanisms", "without watertight", "without offsets", "without terminator", "without any"] {
        let line = stdout.lines().find(|l| l.contains(label)).unwrap_or_else(|| panic!("{label} missing: {stdout}"));
        let ratio: f64 = line.rsplit(' ').next().unwrap().parse().unwrap();
        assert!(ratio > 0.0 && ratio.is_finite(), "{line}");
    }
    let o = lucent(&["bench", "kernel", "scene.glb"]);
    assert!(!o.status.success() && stderr(&o).contains("built-in scene only"), "{}", stderr(&o));
}

#[test]
fn switching_the_terminator_offset_off_changes_a_smooth_scene_only() {
    // The Cornell box is flat: no lift, the same image. The coarse sphere changes.
    let dir = common::scratch("cli-without");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scenes/terminator.gltf");
    for (name, args) in [("cornell", vec![]), ("sphere", vec![scene])] {
        let mut images = Vec::new();
        for without in [None, Some("terminator")] {
            let out = dir.join(format!("{name}-{}.exr", without.is_some()));
            let mut a = vec!["render", "--spp", "2", "--width", "48", "--height", "32"];
            a.extend(&args);
            a.extend(without.map_or(vec![], |w| vec!["--without", w]));
            a.extend(["--out", out.to_str().unwrap()]);
            let o = lucent(&a);
            assert!(o.status.success(), "{}", stderr(&o));
            images.push(image::open(&out).unwrap().into_rgb32f().into_raw());
        }
        assert_eq!(images[0] == images[1], name == "cornell", "{name}");
    }
}

#[test]
fn distribution_ray_tracing_states_its_cost_before_it_starts() {
    let dir = common::scratch("cli-drt");
    let out = dir.join("drt.png");
    let args = ["--integrator", "distribution", "--branching", "2", "--max-depth", "2", "--spp", "3"];
    let o =
        lucent(&[&["render"][..], &args, &["--width", "8", "--height", "8", "--out", out.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    // 1 + 2 + 4 rays, plus a shadow ray at each of the 1 + 2 hits below the last depth.
    assert!(stderr(&o).contains("up to 1.000e1 rays per sample, 3.000e1 per pixel at 3 spp"), "{}", stderr(&o));
}

#[test]
fn the_readme_and_help_document_every_setting_of_the_tables() {
    use lucent::film::tonemap::DISPLAY;
    use lucent::integrator::Settings;
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    let help = String::from_utf8_lossy(&lucent(&["render", "--help"]).stdout).into_owned();
    let names = Settings::table().iter().map(|p| (p.name, p.help)).chain(DISPLAY.iter().map(|p| (p.name, p.help)));
    for (name, doc) in names {
        assert!(readme.contains(&format!("`--{name}")), "README's option table lacks --{name}");
        assert!(help.contains(&format!("--{name}")) && help.contains(doc), "--help lacks --{name}: {doc}");
    }
}

#[test]
fn bench_throughput_reports_every_scene_of_its_suite_against_a_baseline() {
    let exe = env!("CARGO_BIN_EXE_lucent");
    let o = lucent(&["bench", "throughput", "--spp", "1", "--size", "32", "--runs", "1", "--baseline", exe]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let rows: Vec<Vec<&str>> = stdout
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| scene"))
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    let names: Vec<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(
        names,
        [
            "cornell-box",
            "cornell-box-glass",
            "MetalRoughSpheresNoTextures",
            "ToyCar (camera 1, sky)",
            "WaterBottle (sky)"
        ]
    );
    for row in &rows {
        let figures: Vec<f64> = row[1..].iter().map(|f| f.parse().expect("a number")).collect();
        assert_eq!(figures.len(), 8, "{row:?}");
        let (samples, rays, bvh, peak) = (figures[0], figures[1], figures[2], figures[3]);
        assert!(samples > 0.0 && rays >= samples && bvh >= 0.0 && peak > 1.0, "{row:?}");
    }
    // The million-triangle spheres need more memory than the 32-triangle box.
    assert!(rows[2][4].parse::<f64>().unwrap() > rows[0][4].parse::<f64>().unwrap());
    let o = lucent(&["bench", "throughput", "--baseline", "/nonexistent/lucent"]);
    assert!(!o.status.success() && stderr(&o).contains("--baseline /nonexistent/lucent: no such program"));
}

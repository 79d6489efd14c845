//! A render split into pieces by sample range and by window (`lucent render --samples A..B
//! --region X0,Y0,X1,Y1 --out X.part`) merges (`lucent merge`) to the image the single
//! process makes, bit for bit; pieces of another render, overlapping or missing ranges and
//! windows and damaged piece files are refused in one line, and no output is written.

mod common;

use std::path::Path;
use std::process::Command;

fn lucent(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lucent")).args(args).output().expect("lucent runs");
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

fn render(out: &Path, extra: &[&str]) {
    let mut args = vec!["render", "--width", "24", "--height", "18", "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    let (ok, err) = lucent(&args);
    assert!(ok, "{err}");
}

fn refused(args: &[&str], needle: &str) {
    let (ok, err) = lucent(args);
    assert!(!ok, "accepted: {args:?}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert!(lines.len() == 1 && lines[0].contains(needle), "{args:?}: {err}");
}

#[test]
fn pieces_by_sample_range_merge_to_the_single_process_image_bit_for_bit() {
    let d = common::scratch("pieces-ranges");
    let p = |name: &str| d.join(name).to_str().unwrap().to_owned();
    render(&d.join("whole.exr"), &["--spp", "13"]);
    for (range, name) in [("0..4", "a.part"), ("4..9", "b.part"), ("9..13", "c.part")] {
        render(&d.join(name), &["--samples", range]);
    }
    let (ok, err) =
        lucent(&["merge", &p("c.part"), &p("a.part"), &p("b.part"), "--spp", "13", "--out", &p("merged.exr")]);
    assert!(ok, "{err}");
    assert_eq!(std::fs::read(d.join("whole.exr")).unwrap(), std::fs::read(d.join("merged.exr")).unwrap());

    render(&d.join("b-overlap.part"), &["--samples", "3..9"]);
    render(&d.join("c-other-seed.part"), &["--samples", "9..13", "--seed", "5"]);
    let bad = p("bad.exr");
    refused(&["merge", &p("a.part"), &p("c.part"), "--out", &bad], "samples 4..9 of pixels 0,0,24,18 are missing");
    refused(
        &["merge", &p("a.part"), &p("b.part"), "--spp", "13", "--out", &bad],
        "samples 9..13 of pixels 0,0,24,18 are missing",
    );
    refused(
        &["merge", &p("a.part"), &p("b-overlap.part"), "--out", &bad],
        "both hold samples 3..4 of pixels 0,0,24,18",
    );
    refused(&["merge", &p("a.part"), &p("b.part"), &p("c-other-seed.part"), "--out", &bad], "another render than");
    refused(
        &["merge", &p("a.part"), &p("c-other-seed.part"), "--out", &bad],
        "settings differ (seed = 0 against seed = 5)",
    );
    let bytes = std::fs::read(d.join("a.part")).unwrap();
    std::fs::write(d.join("short.part"), &bytes[..bytes.len() - 7]).unwrap();
    refused(&["merge", &p("short.part"), "--out", &bad], "bytes do not hold");
    // A header claiming a frame larger than any render around a one-pixel window, and
    // one whose pixel count times the bytes per pixel overflows u64 (it wrapped to a small
    // number and the allocation panicked).
    let text = String::from_utf8_lossy(&bytes);
    let first = text.lines().next().unwrap();
    let framed = |w: u32, h: u32| {
        let header = first.replace("\"width\":24,\"height\":18", &format!("\"width\":{w},\"height\":{h}"));
        [format!("{}\n", header.replace("\"x1\":24,\"y1\":18", "\"x1\":1,\"y1\":1")).as_bytes(), &[0u8; 80]].concat()
    };
    for (name, side) in [("huge.part", 100_000), ("wide.part", u32::MAX)] {
        std::fs::write(d.join(name), framed(side, side)).unwrap();
        refused(
            &["merge", &p(name), "--out", &bad],
            &format!("a {side}x{side} frame is larger than any render (16384 a side)"),
        );
    }
    // The largest frame a render has, merged under a 2 GB address-space limit: refused
    // against the limit instead of allocated.
    std::fs::write(d.join("largest.part"), framed(16384, 16384)).unwrap();
    let merge =
        format!("ulimit -v 2000000 && exec {} merge {} --out {bad}", env!("CARGO_BIN_EXE_lucent"), p("largest.part"));
    let out = Command::new("bash").arg("-c").arg(&merge).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.trim_end().lines().count() == 1, "{err}");
    assert!(err.contains("merging a 16384x16384 frame needs about 6.4 GB, over the memory limit of 1."), "{err}");
    // A sample range past u32.
    let past = first.replace("\"first\":0,", "\"first\":4294967294,");
    std::fs::write(d.join("past.part"), [format!("{past}\n").as_bytes(), &bytes[first.len() + 1..]].concat()).unwrap();
    refused(&["merge", &p("past.part"), "--out", &bad], "run past the last sample number");
    std::fs::write(d.join("junk.part"), b"not a piece\n").unwrap();
    refused(&["merge", &p("junk.part"), "--out", &bad], "bad header");
    refused(&["render", "--samples", "5..5", "--out", &p("x.part")], "A < B");
    assert!(!Path::new(&bad).exists(), "a refused merge writes nothing");
}

#[test]
fn bidirectional_pieces_by_sample_range_merge_to_the_single_process_image_bit_for_bit() {
    // A piece's pixels hold the light-traced splats of its own samples' light paths, wherever
    // they landed; a merge adds them exactly, as it adds the camera paths' sums. Under vertex
    // connection and merging a sample index is an iteration, with its own light subpaths
    // and radius, so a piece's iterations are the whole render's.
    let glass = common::asset("cornell-box-glass.gltf");
    for integrator in ["bdpt", "vcm"] {
        let d = common::scratch(&format!("pieces-{integrator}"));
        let p = |name: &str| d.join(name).to_str().unwrap().to_owned();
        let bidirectional = ["--integrator", integrator, glass.to_str().unwrap()];
        render(&d.join("whole.exr"), &[&bidirectional[..], &["--spp", "7"]].concat());
        for (range, name) in [("0..3", "a.part"), ("3..7", "b.part")] {
            render(&d.join(name), &[&bidirectional[..], &["--samples", range]].concat());
        }
        let (ok, err) = lucent(&["merge", &p("b.part"), &p("a.part"), "--out", &p("merged.exr")]);
        assert!(ok, "{err}");
        let (whole, merged) =
            (std::fs::read(d.join("whole.exr")).unwrap(), std::fs::read(d.join("merged.exr")).unwrap());
        assert!(whole == merged, "{integrator}: the merged pieces differ from the whole render");
        refused(
            &[&["render", "--region", "0,0,8,8", "--out", &p("r.part")][..], &bidirectional[..]].concat(),
            "renders whole frames only",
        );
    }
}

/// Reads an EXR's RGB pixels.
fn exr(path: &Path) -> image::Rgb32FImage {
    image::open(path).unwrap().into_rgb32f()
}

#[test]
fn pieces_by_window_and_sample_range_merge_to_the_single_process_image_bit_for_bit() {
    let d = common::scratch("pieces-windows");
    std::fs::create_dir_all(d.join("pieces")).unwrap();
    let p = |name: &str| d.join(name).to_str().unwrap().to_owned();
    render(&d.join("whole.exr"), &["--spp", "6"]);
    // The top band whole; below it, a left window in two sample ranges and a right window.
    for (region, samples, name) in [
        ("0,0,24,7", "0..6", "pieces/top.part"),
        ("0,7,10,18", "0..2", "pieces/left-a.part"),
        ("0,7,10,18", "2..6", "pieces/left-b.part"),
        ("10,7,24,18", "0..6", "pieces/right.part"),
        ("5,0,15,9", "0..6", "centre.part"),
    ] {
        render(&d.join(name), &["--region", region, "--samples", samples]);
    }
    let (ok, err) = lucent(&["merge", &p("pieces"), "--out", &p("merged.exr")]);
    assert!(ok, "{err}");
    assert_eq!(std::fs::read(d.join("whole.exr")).unwrap(), std::fs::read(d.join("merged.exr")).unwrap());

    // A window rendered to an image is that window of the frame.
    render(&d.join("crop.exr"), &["--spp", "6", "--region", "5,0,15,9"]);
    let (whole, crop) = (exr(&d.join("whole.exr")), exr(&d.join("crop.exr")));
    assert_eq!((crop.width(), crop.height()), (10, 9));
    for (x, y, px) in crop.enumerate_pixels() {
        assert_eq!(px, whole.get_pixel(x + 5, y), "pixel {x},{y} of the window");
    }

    let bad = p("bad.exr");
    let piece = |name: &str| p(&format!("pieces/{name}.part"));
    refused(
        &["merge", &piece("top"), &piece("left-a"), &piece("left-b"), "--out", &bad],
        "samples 0..6 of pixels 10,7,24,18 are missing",
    );
    refused(
        &["merge", &piece("top"), &piece("left-a"), &piece("right"), "--out", &bad],
        "samples 2..6 of pixels 0,7,10,18 are missing",
    );
    refused(&["merge", &p("pieces"), &p("centre.part"), "--out", &bad], "both hold samples 0..6 of pixels 5,0,10,7");
    let size = ["--width", "24", "--height", "18", "--spp", "1", "--out"];
    refused(&[&["render", "--region", "0,0,25,18"], &size[..], &[&p("x.part")]].concat(), "outside the 24x18 frame");
    refused(&[&["render", "--region", "4,4,4,8"], &size[..], &[&p("x.part")]].concat(), "empty");
    assert!(!Path::new(&bad).exists(), "a refused merge writes nothing");
}

#[test]
fn farm_job_scripts_name_every_piece_once_and_bad_requests_are_refused() {
    let d = common::scratch("pieces-farm");
    let (folder, out) = (d.to_str().unwrap().to_owned(), d.join("frame.exr").to_str().unwrap().to_owned());
    let farm = |extra: &[&str]| -> Vec<String> {
        let base = ["farm", "slurm", "--dir", &folder, "--out", &out, "--width", "24", "--height", "18", "--spp", "10"];
        base.iter().chain(extra).map(|s| s.to_string()).collect()
    };
    fn args(v: &[String]) -> Vec<&str> {
        v.iter().map(String::as_str).collect()
    }
    let (ok, err) = lucent(&args(&farm(&["--pieces", "3", "--split", "regions", "--cpus", "2"])));
    assert!(ok, "{err}");
    let script = std::fs::read_to_string(d.join("render.sbatch")).unwrap();
    for line in [
        "#SBATCH --array=0-2",
        "#SBATCH --cpus-per-task=2",
        "#SBATCH --requeue",
        "regions=(0,0,24,6 0,6,24,12 0,12,24,18)",
        "samples=(0..10 0..10 0..10)",
    ] {
        assert!(script.contains(line), "{line} in {script}");
    }
    assert!(std::fs::read_to_string(d.join("submit.sh")).unwrap().contains("--dependency=afterok:"));
    assert!(d.join("view.toml").exists());
    refused(&args(&farm(&["--pieces", "11"])), "--pieces 11: between 1 and the render's 10 samples per pixel");
    refused(&args(&farm(&["--pieces", "19", "--split", "regions"])), "between 1 and the render's 18 rows");
    refused(
        &args(&farm(&["--pieces", "2", "--split", "regions", "--integrator", "bdpt"])),
        "renders whole frames only",
    );
    refused(&args(&farm(&["--pieces", "2", "--mem", "4G\n#SBATCH --x"])), "#SBATCH lines take no spaces");
    std::fs::write(d.join("pieces/old.part"), b"a piece of an earlier render").unwrap();
    refused(&args(&farm(&["--pieces", "2"])), "already holds pieces: give another --dir");
}

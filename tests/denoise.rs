//! The denoiser and its AOVs. The AOVs need no Open Image Denoise: asking for them leaves
//! the radiance unchanged, a Lambertian wall's albedo is its base colour and its normal faces
//! the camera, and delta lobes pass them on to the next non-specular hit. Where the library
//! is not found, `--denoise` fails in one line before rendering. Where it is installed (CI
//! installs it and sets LUCENT_REQUIRE_OIDN; elsewhere these tests skip without it, saying
//! so), Open Image Denoise itself: at 16 spp it cuts the error of the displayed image
//! against a reference at least threefold, and a high-spp image it does not move away from
//! the reference; the command line and the viewer (tests/viewer.rs) write what it gives.

use glam::{UVec2, Vec2, Vec3};
use lucent::integrator::{Integrator, Settings};
use lucent::loader::builtin;
use lucent::render::{Job, RenderSession, Snapshot};
use lucent::scene::{Scene, camera::Camera, geometry::Ray};
use std::path::Path;
use std::process::Command;
use std::sync::Arc;

mod common;

/// Renders `scene` through its default camera to `settings.target_spp`, with or without AOVs.
fn render(scene: &Arc<Scene>, settings: Settings, aovs: bool) -> Arc<Snapshot> {
    let camera = scene.default_camera(settings.width as f32 / settings.height as f32);
    let job = Job { scene: Arc::clone(scene), camera, settings, window: None, aovs };
    RenderSession::new(job, None).expect("valid settings").wait_until_done()
}

fn cornell() -> Arc<Scene> {
    Arc::new(Scene::build(builtin::cornell_box()))
}

fn glass_box() -> Arc<Scene> {
    Arc::new(Scene::build(common::load("cornell-box-glass.gltf")))
}

fn settings(size: u32, spp: u32) -> Settings {
    Settings { width: size, height: size, target_spp: Some(spp), ..Settings::default() }
}

#[test]
fn asking_for_aovs_leaves_the_radiance_unchanged() {
    let fog = Scene::build(
        lucent::loader::gltf::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scenes/cornell-fog.gltf")))
            .unwrap(),
    );
    let drt = Settings { integrator: Integrator::Distribution, max_depth: 2, branching: 4, ..settings(24, 2) };
    let cases = [(glass_box(), settings(32, 8)), (Arc::new(fog), settings(16, 4)), (cornell(), drt)];
    for (scene, s) in cases {
        let (with, without) = (render(&scene, s, true), render(&scene, s, false));
        assert!(with.mean == without.mean, "{}: the radiance changed", scene.name);
        assert!(without.aovs.is_none(), "AOVs are kept only when asked for");
        let aovs = with.aovs.as_ref().expect("asked for");
        assert!(aovs.albedo.iter().any(|a| *a != Vec3::ZERO), "{}: no albedo recorded", scene.name);
    }
}

/// The surface a ray through film position `film` sees first: (material, normal facing the ray).
fn first_hit(scene: &Scene, camera: &Camera, size: u32, film: Vec2) -> Option<(u32, Vec3, Ray, Vec3)> {
    let ray = camera.rays(size, size).ray(film);
    let hit = scene.intersect(&ray, true, true)?;
    let surface = scene.surface(&hit);
    let d = ray.d.normalize();
    let n = if surface.ns.dot(d) < 0.0 { surface.ns } else { -surface.ns };
    Some((surface.material, n, ray, surface.p))
}

/// Pixels whose four corners and centre all see the same material (and with `flat` the same
/// normal): (pixel index, material, normal at the centre).
fn uniform_pixels(scene: &Scene, camera: &Camera, size: u32, flat: bool) -> Vec<(usize, u32, Vec3)> {
    let mut found = Vec::new();
    for i in 0..(size * size) as usize {
        let p = UVec2::new(i as u32 % size, i as u32 / size).as_vec2();
        let probes = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)]
            .map(|(x, y)| first_hit(scene, camera, size, p + Vec2::new(x, y)).map(|h| (h.0, h.1)));
        if let Some((m, n)) = probes[4]
            && probes.iter().all(|q| q.is_some_and(|(m2, n2)| m2 == m && (!flat || n2.abs_diff_eq(n, 1e-5))))
        {
            found.push((i, m, n));
        }
    }
    found
}

#[test]
fn a_lambertian_walls_albedo_is_its_base_colour_and_its_normal_faces_the_camera() {
    let scene = cornell();
    let size = 48;
    let snap = render(&scene, settings(size, 16), true);
    let aovs = snap.aovs.as_ref().unwrap();
    let camera = scene.default_camera(1.0);
    let pixels = uniform_pixels(&scene, &camera, size, true);
    let walls = ["red", "green", "white"].map(|name| scene.materials.iter().position(|m| m.name == name).unwrap());
    for (k, wall) in walls.iter().enumerate() {
        let on_wall: Vec<_> = pixels.iter().filter(|p| p.1 as usize == *wall).collect();
        assert!(on_wall.len() > 100, "{} pixels see only wall {k}", on_wall.len());
        let base = scene.materials[*wall].base_color;
        for &&(i, _, n) in &on_wall {
            // Every sample of the pixel records the same values, so their mean is exact.
            assert_eq!(aovs.albedo[i], base, "pixel {i}: the albedo is the wall's base colour");
            assert!((aovs.normal[i].length() - 1.0).abs() < 1e-6, "pixel {i}: unit normal");
            // Interpolated shading normals differ in their last bits from sample to sample.
            assert!(aovs.normal[i].abs_diff_eq(n, 1e-5), "pixel {i}: {} is not the wall's normal {n}", aovs.normal[i]);
            let view = first_hit(&scene, &camera, size, Vec2::new((i as u32 % size) as f32, (i as u32 / size) as f32))
                .unwrap()
                .2
                .d;
            assert!(aovs.normal[i].dot(view) < 0.0, "pixel {i}: it faces the camera");
        }
    }
}

#[test]
fn delta_lobes_pass_the_aovs_on_to_the_next_non_specular_hit() {
    let scene = glass_box();
    let size = 64;
    let snap = render(&scene, settings(size, 16), true);
    let aovs = snap.aovs.as_ref().unwrap();
    let camera = scene.default_camera(1.0);
    let material = |name: &str| scene.materials.iter().position(|m| m.name == name).unwrap() as u32;
    let (mirror, glass) = (material("mirror"), material("glass"));
    let pixels = uniform_pixels(&scene, &camera, size, false);
    // Mirror pixels: the recorded normal is that of the surface seen in the mirror (traced
    // here from the pixel's centre), not the sphere's own.
    let (mut mirrored, mut closer_to_reflected) = (0, 0);
    for &(i, _, n1) in pixels.iter().filter(|p| p.1 == mirror) {
        let centre = Vec2::new((i as u32 % size) as f32 + 0.5, (i as u32 / size) as f32 + 0.5);
        let (_, _, ray, p) = first_hit(&scene, &camera, size, centre).unwrap();
        let d = ray.d.normalize();
        let r = d - 2.0 * d.dot(n1) * n1;
        let reflected = Ray { o: p + 1e-3 * n1, d: r, tmax: f32::INFINITY };
        let Some(hit) = scene.intersect(&reflected, true, false) else { continue };
        let seen = scene.surface(&hit);
        let n2 = if seen.ns.dot(r) < 0.0 { seen.ns } else { -seen.ns };
        mirrored += 1;
        if aovs.normal[i].distance(n2) < aovs.normal[i].distance(n1) {
            closer_to_reflected += 1;
        }
    }
    assert!(mirrored > 20, "only {mirrored} mirror pixels reflect a surface");
    assert!(closer_to_reflected as f64 >= 0.9 * mirrored as f64, "{closer_to_reflected} of {mirrored}");
    // Glass pixels: what is seen through (or in) it, never the sphere's own normal.
    let glass_pixels: Vec<_> = pixels.iter().filter(|p| p.1 == glass).collect();
    assert!(glass_pixels.len() > 20);
    let own = glass_pixels.iter().filter(|&&&(i, _, n1)| aovs.normal[i].distance(n1) < 0.1).count();
    assert!(own * 10 <= glass_pixels.len(), "{own} of {} glass pixels record the sphere", glass_pixels.len());
}

#[test]
fn denoising_images_of_different_sizes_is_refused_in_one_line() {
    let err = lucent::film::denoise::denoise(&[Vec3::ONE; 5], None, 2, 2).unwrap_err();
    assert!(err.contains("2x2") && !err.contains('\n'), "{err}");
}

/// `lucent render ARGS --out DIR/NAME` and its exit status, standard error.
fn lucent(args: &[&str], out: &Path) -> (bool, String) {
    let run = Command::new(env!("CARGO_BIN_EXE_lucent")).args(args).arg("--out").arg(out).output().unwrap();
    (run.status.success(), String::from_utf8_lossy(&run.stderr).into_owned())
}

#[test]
fn aovs_on_the_command_line_are_written_beside_an_unchanged_image() {
    let dir = common::scratch("denoise-cli-aovs");
    let args = ["render", "--spp", "4", "--width", "32", "--height", "24"];
    let (ok, log) = lucent(&[&args[..], &["--aovs"]].concat(), &dir.join("a.exr"));
    assert!(ok, "{log}");
    assert!(lucent(&args, &dir.join("plain.exr")).0);
    let read = |name: &str| image::open(dir.join(name)).unwrap().into_rgb32f();
    assert!(read("a.exr").as_raw() == read("plain.exr").as_raw(), "--aovs changed the image");
    assert_eq!(read("a.albedo.exr").dimensions(), (32, 24));
    assert!(read("a.normal.exr").pixels().any(|p| p.0 != [0.0; 3]));
}

#[test]
fn without_the_library_denoise_fails_in_one_line_before_rendering() {
    let dir = common::scratch("denoise-not-found");
    let empty = dir.join("no-oidn");
    std::fs::create_dir_all(&empty).unwrap();
    let out = dir.join("x.png");
    let run = |args: &[&str]| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_lucent"));
        let run = command.args(args).env("OIDN_DIR", &empty).output().unwrap();
        (run.status.success(), String::from_utf8_lossy(&run.stderr).into_owned())
    };
    let (ok, log) = run(&["render", "--denoise", "--out", out.to_str().unwrap()]);
    assert!(!ok && log.trim().lines().count() == 1, "{log}");
    assert!(log.contains("Open Image Denoise did not load from OIDN_DIR=") && log.contains("no-oidn"), "{log}");
    assert!(!out.exists() && !dir.join("x.noisy.exr").exists(), "nothing written");
    let (ok, view) = run(&["view", "--denoise"]);
    assert!(!ok && view == log, "{view}");
}

mod oidn {
    //! Errors are RMSEs of the displayed image (the default display: linear, clamped,
    //! sRGB-encoded, as the PNG holds it) against a reference of 512 spp on another seed. In
    //! linear radiance the RMSE is dominated by the 1% of pixels that see the lamp (radiance
    //! 17), the one region the noisy image already has exact, which Open Image Denoise's
    //! HDR output moves by about 5%: measured at this size, denoising 16 spp takes the linear
    //! RMSE from 0.019 to 0.035, while away from the lamp it falls from 0.0150 to 0.0053 and
    //! on screen, where the lamp is white either way, from 0.0274 to 0.0073. The image is
    //! 192x192: a denoiser needs room around edges, and at 64x64 nearly every pixel is
    //! next to one (there it gains 2.3x on screen, at 128x128 2.9x, at 256x256 4.8x).
    use super::*;
    use lucent::film::denoise::denoise;
    use lucent::film::tonemap::Display;
    use std::path::PathBuf;
    use std::sync::OnceLock;

    const SIZE: u32 = 192;

    /// RMSE of two linear images as the default display shows them, in [0, 1].
    fn rmse(a: &[Vec3], b: &[Vec3]) -> f64 {
        let display = Display::default();
        let shown = |p: Vec3| display.to_srgb8(p).map(|c| c as f64 / 255.0);
        let sum: f64 = a.iter().zip(b).flat_map(|(x, y)| (0..3).map(|c| (shown(*x)[c] - shown(*y)[c]).powi(2))).sum();
        (sum / (3 * a.len()) as f64).sqrt()
    }

    /// The Cornell box at 512 spp on another seed, shared by the tests.
    fn reference() -> &'static [Vec3] {
        static REFERENCE: OnceLock<Vec<Vec3>> = OnceLock::new();
        REFERENCE.get_or_init(|| render(&cornell(), Settings { seed: 1, ..settings(SIZE, 512) }, false).mean.clone())
    }

    /// (RMSE of the noisy image, RMSE of the denoised one) at `spp` against the reference,
    /// printed for the README's figures (`-- --nocapture`).
    fn errors(spp: u32) -> (f64, f64) {
        let snap = render(&cornell(), settings(SIZE, spp), true);
        let denoised = denoise(&snap.mean, snap.aovs.as_ref(), SIZE, SIZE).unwrap();
        let (noisy, denoised) = (rmse(&snap.mean, reference()), rmse(&denoised, reference()));
        eprintln!("{spp} spp: RMSE {noisy:.5} noisy, {denoised:.5} denoised");
        (noisy, denoised)
    }

    /// The reference's own error adds in quadrature to both errors and so lowers their
    /// ratio: the bound holds of the true errors a fortiori. Fixed seeds make the outcome
    /// fixed for a given Open Image Denoise (measured: 3.7x, 0.0214 to 0.0058).
    #[test]
    fn denoising_16_spp_cuts_the_error_at_least_threefold() {
        if !common::oidn_installed("denoising_16_spp_cuts_the_error_at_least_threefold") {
            return;
        }
        let (noisy, denoised) = errors(16);
        assert!(denoised * 3.0 <= noisy, "RMSE {denoised:.5} denoised against {noisy:.5} noisy");
    }

    /// At 128 spp little noise is left for the filter to remove (measured: 0.0074 noisy,
    /// 0.0043 denoised, the reference's own error included): the filter must not add more
    /// error, by blurring edges or shifting colours, than it removes.
    #[test]
    fn denoising_a_high_spp_image_does_not_move_it_away_from_the_reference() {
        if !common::oidn_installed("denoising_a_high_spp_image_does_not_move_it_away_from_the_reference") {
            return;
        }
        let (noisy, denoised) = errors(128);
        assert!(denoised <= noisy, "RMSE {denoised:.5} denoised against {noisy:.5} noisy");
    }

    #[test]
    fn the_command_line_writes_the_denoised_image_and_keeps_the_noisy_one() {
        if !common::oidn_installed("the_command_line_writes_the_denoised_image_and_keeps_the_noisy_one") {
            return;
        }
        let dir = common::scratch("denoise-cli-denoise");
        let args = ["render", "--spp", "4", "--width", "32", "--height", "24"];
        let (ok, log) = lucent(&[&args[..], &["--denoise"]].concat(), &dir.join("d.exr"));
        assert!(ok && log.contains("denoised in"), "{log}");
        assert!(lucent(&args, &dir.join("plain.exr")).0);
        let read = |name: &str| image::open(dir.join(name)).unwrap().into_rgb32f();
        assert!(read("d.noisy.exr").as_raw() == read("plain.exr").as_raw(), "the noisy image is the plain render");
        assert!(read("d.exr").as_raw() != read("plain.exr").as_raw(), "--out is denoised");
    }

    /// Where the running process loaded Open Image Denoise's core library from.
    fn loaded_folder() -> PathBuf {
        let maps = std::fs::read_to_string("/proc/self/maps").unwrap();
        let line = maps.lines().find(|l| l.contains("libOpenImageDenoise_core.so")).expect("loaded");
        Path::new(line.split_whitespace().last().unwrap()).parent().unwrap().to_path_buf()
    }

    /// The four files of the library copied flat beside a copy of the binary, in a folder not
    /// named lib (pyoidn's own libraries find each other only through `$ORIGIN/../lib`), are
    /// found with no setting at all: the binary's folder is searched first, and TBB and the
    /// core library are loaded by full path before the API library.
    #[test]
    fn a_flat_copy_beside_the_binary_is_found_with_no_setting() {
        if !common::oidn_installed("a_flat_copy_beside_the_binary_is_found_with_no_setting") {
            return;
        }
        let from = loaded_folder();
        let dir = common::scratch("denoise-flat-copy");
        let flat = dir.join("bin");
        std::fs::create_dir_all(&flat).unwrap();
        let names: Vec<String> =
            std::fs::read_dir(&from).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        for prefix in ["libOpenImageDenoise_core.so.2", "libOpenImageDenoise_device_cpu.so.2"] {
            let name = names.iter().find(|n| n.starts_with(prefix)).expect(prefix);
            std::fs::copy(from.join(name), flat.join(name)).unwrap();
        }
        std::fs::copy(from.join("libOpenImageDenoise.so.2"), flat.join("libOpenImageDenoise.so.2")).unwrap();
        std::fs::copy(from.join("libtbb.so.12"), flat.join("libtbb.so.12")).unwrap();
        let binary = flat.join("lucent");
        std::fs::copy(env!("CARGO_BIN_EXE_lucent"), &binary).unwrap();
        let run = Command::new(&binary)
            .args(["render", "--denoise", "--spp", "2", "--width", "16", "--height", "16", "--out"])
            .arg(dir.join("d.exr"))
            .env_clear()
            .env("HOME", &*dir)
            .output()
            .unwrap();
        let log = String::from_utf8_lossy(&run.stderr);
        assert!(run.status.success() && log.contains("denoised in"), "{log}");
    }
}

//! Measured BRDFs: a MERL table generated from an analytic BRDF reads back as that BRDF,
//! a measured Lambertian matches the analytic furnace, and the sidecar file assigns tables
//! to glTF materials by name, with one-line errors for bad files.

mod common;

use glam::Vec3;
use lucent::bsdf::{Bsdf, measured::MerlTable};
use lucent::integrator::{LightSampling, Settings};
use lucent::loader::gltf;
use lucent::scene::{
    Scene, SceneDesc,
    camera::Camera,
    environment::{EnvSettings, Environment},
    material::{Material, Measured},
    shapes::uv_sphere,
};
use std::sync::Arc;

#[test]
fn a_table_of_an_analytic_brdf_reads_back_as_that_brdf() {
    let table = MerlTable::read(&common::merl_bytes(common::analytic_brdf)).unwrap();
    let (mut checked, mut worst) = (0, 0.0f64);
    // Every cell's centre, reached from directions with several half-vector azimuths: the
    // lookup must find the cell the value was written to (format, scales, indexing and the
    // half/difference rotation all round-trip). The first theta_half cell is left out: at
    // theta_h < 1e-4 the half vector's azimuth, and with it phi_diff, is lost to f32 rounding
    // of the directions (as the parameterisation's singularity at theta_h = 0 implies).
    for i in (1..90).step_by(3) {
        for j in (0..90).step_by(3) {
            for k in (0..180).step_by(7) {
                let (th, td, pd) = common::merl_cell_centre(i, j, k);
                for phi_h in [0.3, 2.0, -2.5] {
                    let (wo, wi) = common::from_half_diff(th, td, pd, phi_h);
                    if wo.z < 1e-3 || wi.z < 1e-3 {
                        continue;
                    }
                    let expected = common::analytic_brdf(th, td, pd);
                    let got = table.eval(wo, wi);
                    for c in 0..3 {
                        let rel = (got[c] as f64 - expected[c]).abs() / expected[c];
                        worst = worst.max(rel);
                    }
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 10_000, "{checked} pairs checked");
    assert!(worst < 1e-5, "worst relative error {worst:.2e} (f32 rounding only)");
    assert_eq!(table.eval(Vec3::Z, Vec3::new(0.0, 0.6, -0.8)), Vec3::ZERO, "no transmission");
}

#[test]
fn a_measured_lambertian_in_a_uniform_sky_matches_the_analytic_one() {
    // Table of 0.5 / pi: a flat-shaded convex sphere under a uniform sky reflects 0.5 x sky.
    let table = Arc::new(MerlTable::read(&common::merl_bytes(|_, _, _| [0.5 / std::f64::consts::PI; 3])).unwrap());
    let material = Material {
        measured: Some(Measured { path: "lambert.binary".into(), table }),
        ..Material::lambert("measured", Vec3::ONE)
    };
    let mut sphere = uv_sphere(Vec3::ZERO, 1.0, 16, 32, false, 0);
    sphere.normals = None;
    let desc =
        SceneDesc { name: "measured".into(), meshes: vec![sphere], materials: vec![material], ..SceneDesc::default() };
    let env = Environment::load(EnvSettings { background: Vec3::ONE, ..EnvSettings::default() }).unwrap();
    let scene = Arc::new(Scene::build(desc).with_environment(Some(env)));
    let camera = Camera::look_at(Vec3::new(0.3, 0.5, 3.0), Vec3::ZERO, 0.2);
    let z_max = common::sidak_z(1e-3, 3 * 3);
    for lights in [LightSampling::Off, LightSampling::Explicit, LightSampling::Mis] {
        let settings = Settings {
            width: 24,
            height: 24,
            max_depth: 2,
            light_sampling: lights,
            target_spp: Some(32),
            ..Settings::default()
        };
        let snap = common::render(&scene, camera, settings, None);
        assert_eq!(snap.rejected, 0);
        let (mean, se) = common::image_mean(&snap);
        for c in 0..3 {
            let (mean, se) = (mean[c], se[c]);
            assert!((mean - 0.5).abs() < z_max * se.max(1e-6), "{lights:?} channel {c}: {mean} (se {se:.1e})");
        }
    }
}

#[test]
fn the_sidecar_assigns_tables_by_name_and_reports_bad_files_in_one_line() {
    let dir = common::scratch("measured");
    std::fs::create_dir_all(dir.join("brdfs")).unwrap();
    let scene = dir.join("Box.glb");
    std::fs::copy(common::asset("Box/glTF-Binary/Box.glb"), &scene).unwrap();
    std::fs::write(dir.join("brdfs/analytic.binary"), common::merl_bytes(common::analytic_brdf)).unwrap();
    let sidecar = dir.join("Box.materials.toml");
    std::fs::write(&sidecar, "[measured]\nRed = \"brdfs/analytic.binary\"\nBlue = \"brdfs/analytic.binary\"\n")
        .unwrap();
    let desc = gltf::load(&scene).unwrap();
    let red = desc.materials.iter().find(|m| m.name == "Red").unwrap();
    assert!(red.measured.as_ref().is_some_and(|m| m.path.ends_with("analytic.binary")));
    assert!(desc.warnings.iter().any(|w| w.contains("\"Blue\"")), "{:?}", desc.warnings);
    let built = Scene::build(desc);
    let surface_bsdf = built.materials[0].bsdf(
        built.refs(),
        &dummy_surface(),
        (&mut lucent::math::frame::Frame::from_normal(Vec3::Z), || (glam::Vec4::ZERO, Vec3::Z)),
        (true, 1.0),
        None,
    );
    assert!(matches!(surface_bsdf, Bsdf::Measured(_)), "the measured table replaces the glTF BRDF");

    std::fs::write(dir.join("brdfs/truncated.binary"), &common::merl_bytes(common::analytic_brdf)[..1000]).unwrap();
    for (text, needle) in [
        ("[measured]\nRed = \"brdfs/missing.binary\"\n", "missing.binary"),
        ("[measured]\nRed = \"brdfs/truncated.binary\"\n", "expected"),
        ("[measurd]\n", "Box.materials.toml"),
    ] {
        std::fs::write(&sidecar, text).unwrap();
        let err = gltf::load(&scene).err().expect("a bad sidecar fails the load").to_string();
        assert!(err.contains(needle) && !err.contains('\n'), "{err}");
    }
}

fn dummy_surface() -> lucent::scene::Surface {
    lucent::scene::Surface {
        p: Vec3::ZERO,
        p_error: Vec3::ZERO,
        ng: Vec3::Z,
        ns: Vec3::Z,
        uv: [glam::Vec2::ZERO; 2],
        color: glam::Vec4::ONE,
        material: 0,
        tri: 0,
        b: [1.0, 0.0, 0.0],
    }
}

//! Materials in whole scenes: the Cornell glass scene (no NaN, a caustic under the glass
//! sphere, the walls mirrored in the metal sphere), Beer-Lambert attenuation against
//! thickness, alpha MASK and BLEND, single-sided culling, normal maps and clearcoat normal maps.

mod common;

use glam::Vec3;
use lucent::integrator::Settings;
use lucent::loader::gltf;
use lucent::scene::{
    MeshDesc, Scene, SceneDesc,
    camera::Camera,
    material::{AlphaMode, Material},
};
use std::sync::Arc;

fn glass_scene() -> Arc<Scene> {
    let desc = gltf::load(&common::asset("cornell-box-glass.gltf")).unwrap();
    Arc::new(Scene::build(desc))
}

/// A point given in the file's coordinates (the box spans [0, 0.556] x [0, 0.549] x [0, 0.559]
/// there; the loader centres the scene on its bounds).
fn at(scene: &Scene, file: Vec3) -> Vec3 {
    scene.bounds.0 + file
}

/// Luminance of the mean of an 8x8 image seen by a narrow camera from `eye` towards
/// `target`, and its standard error from the spread of the pixel means (every pixel sees the
/// same point, so they are independent estimates of one value).
fn radiance(scene: &Arc<Scene>, eye: Vec3, target: Vec3, spp: u32) -> (f64, f64, Vec3) {
    let camera = Camera::look_at(eye, target, 0.02);
    let settings = Settings { width: 8, height: 8, target_spp: Some(spp), max_depth: 8, ..Settings::default() };
    let snap = common::render(scene, camera, settings, None);
    assert_eq!(snap.rejected, 0, "NaN/Inf samples");
    let lum = |c: Vec3| (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z) as f64;
    let n = snap.mean.len() as f64;
    let mean = snap.mean.iter().map(|&c| lum(c)).sum::<f64>() / n;
    let var = snap.mean.iter().map(|&c| (lum(c) - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let colour = snap.mean.iter().copied().sum::<Vec3>() / n as f32;
    (mean, (var / n).sqrt(), colour)
}

/// Radiance leaving the floor upwards at file coordinates (x, z), seen from 1 mm above.
fn floor(scene: &Arc<Scene>, x: f32, z: f32) -> (f64, f64) {
    let p = at(scene, Vec3::new(x, 0.0, z));
    let (l, se, _) = radiance(scene, p + Vec3::new(0.0, 1e-3, 0.0), p + Vec3::new(0.0, 0.0, 1e-4), 1024);
    (l, se)
}

#[test]
fn cornell_glass_focuses_a_caustic_under_the_glass_sphere() {
    let scene = glass_scene();
    // The light is at the ceiling's centre; the glass sphere (r = 0.1) stands at (0.175, 0.19)
    // and the mirror sphere at (0.38, 0.37). A ball lens of index 1.5 focuses 1.5 r from its
    // centre, so the light through the glass lands as a spot around where the line from the
    // light through the centre meets the floor; under the opaque mirror sphere is shadow.
    let (glass, glass_se) = floor(&scene, 0.152, 0.170);
    let (shadow, shadow_se) = floor(&scene, 0.40, 0.39);
    let (open, open_se) = floor(&scene, 0.45, 0.10);
    let z = common::sidak_z(0.01, 2);
    assert!(glass - z * glass_se > 2.0 * (open + z * open_se), "caustic {glass} vs open floor {open}");
    assert!(shadow + z * shadow_se < 0.5 * (open - z * open_se), "shadow {shadow} vs open floor {open}");
}

#[test]
fn the_mirror_sphere_shows_the_red_and_green_walls() {
    let scene = glass_scene();
    // Looking at the mirror sphere's point facing a wall, along that point's normal: the
    // reflection goes straight back, past the camera, to the wall.
    let centre = Vec3::new(0.38, 0.101, 0.37);
    for (normal, red) in [(Vec3::X, true), (-Vec3::X, false)] {
        let p = at(&scene, centre + normal * 0.1);
        let (_, _, c) = radiance(&scene, p + normal * 0.03, p, 64);
        let (mine, other) = if red { (c.x, c.y) } else { (c.y, c.x) };
        assert!(mine > 2.0 * other, "the {} wall in the mirror: {c}", if red { "red" } else { "green" });
    }
}

/// A quad of half-size `h` in the plane z = `z`, facing +z (or -z).
fn quad(z: f32, h: f32, facing_plus_z: bool, material: u32) -> MeshDesc {
    let positions = vec![Vec3::new(-h, -h, z), Vec3::new(h, -h, z), Vec3::new(h, h, z), Vec3::new(-h, h, z)];
    let indices = if facing_plus_z { vec![0, 1, 2, 0, 2, 3] } else { vec![0, 2, 1, 0, 3, 2] };
    MeshDesc { name: "quad".into(), positions, indices, material, ..MeshDesc::default() }
}

/// A closed box [-1, 1]^2 x [z0, z1] with outward faces.
fn slab(z0: f32, z1: f32, material: u32) -> MeshDesc {
    let c = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { z0 } else { z1 },
        )
    };
    let faces: [[u32; 4]; 6] = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let indices = faces.iter().flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]]).collect();
    MeshDesc { name: "slab".into(), positions: (0..8).map(c).collect(), indices, material, ..MeshDesc::default() }
}

/// An emitter of radiance 1 at z = -2 facing +z, seen from z = 5 through `meshes`.
fn through(meshes: Vec<MeshDesc>, mut materials: Vec<Material>) -> (f64, f64) {
    let light = materials.len() as u32;
    materials.push(Material { emissive: Vec3::ONE, ..Material::lambert("light", Vec3::ZERO) });
    let mut all = meshes;
    all.push(quad(-2.0, 50.0, true, light));
    let scene = Arc::new(Scene::build(SceneDesc { meshes: all, materials, ..SceneDesc::default() }));
    let (l, se, _) = radiance(&scene, Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 256);
    (l, se)
}

#[test]
fn absorption_inside_a_volume_follows_beer_lambert() {
    // Index-matched glass (ior 1: no Fresnel, no bending) absorbing sigma = 1 per unit.
    let absorber = || vec![Material::glass("absorber", 1.0, Some(Vec3::ONE))];
    let (thin, _) = through(vec![slab(0.0, 0.5, 0)], absorber());
    let (thick, _) = through(vec![slab(0.0, 1.5, 0)], absorber());
    assert!((thin - (-0.5f64).exp()).abs() < 2e-3, "0.5 units: {thin}");
    assert!((thick - (-1.5f64).exp()).abs() < 2e-3, "1.5 units: {thick}");
    assert!((thick / thin - (-1.0f64).exp()).abs() < 5e-3, "ratio {}", thick / thin);
    // attenuationColor c after attenuationDistance d: sigma = -ln(c) / d, per channel.
    let desc = gltf::load(&common::asset("AttenuationTest/glTF-Binary/AttenuationTest.glb")).unwrap();
    let volumes: Vec<Vec3> = desc.materials.iter().filter_map(|m| m.volume.map(|v| v.sigma_t)).collect();
    assert!(!volumes.is_empty() && volumes.iter().all(|s| s.is_finite() && s.min_element() >= 0.0));
    assert!(volumes.iter().any(|s| s.max_element() > 0.0), "some volume absorbs: {volumes:?}");
}

#[test]
fn alpha_lets_light_through_and_single_sided_backs_are_culled() {
    let black = |alpha: f32, alpha_mode: AlphaMode, double_sided: bool| Material {
        alpha,
        alpha_mode,
        double_sided,
        ..Material::lambert("black", Vec3::ZERO)
    };
    let seen = |m: Material, facing_camera: bool| through(vec![quad(0.0, 10.0, facing_camera, 0)], vec![m]);
    let (blend, se) = seen(black(0.3, AlphaMode::Blend, true), true);
    let z = common::sidak_z(0.01, 1);
    assert!((blend - 0.7).abs() < z * se + 1e-3, "BLEND alpha 0.3 passes 0.7: {blend} +- {se}");
    assert_eq!(seen(black(0.4, AlphaMode::Mask(0.5), true), true).0, 1.0, "MASK below the cutoff passes");
    assert_eq!(seen(black(0.6, AlphaMode::Mask(0.5), true), true).0, 0.0, "MASK above the cutoff blocks");
    assert_eq!(seen(black(1.0, AlphaMode::Opaque, false), false).0, 1.0, "a single-sided back is culled");
    assert_eq!(seen(black(1.0, AlphaMode::Opaque, true), false).0, 0.0, "a double-sided back is not");
}

/// A BSDF of `material` at a surface point whose shading normal is `ns` and whose unmapped
/// normal is +z (tangent +x), read through a 1x1 16-bit texture of `texel` (linear codes).
fn bsdf_with_texel(material: &Material, ns: Vec3, texel: [u16; 4]) -> lucent::bsdf::Bsdf<'_> {
    use lucent::scene::texture::{Image, Texels, Texture, Wrap};
    let textures = vec![Texture { name: "t".into(), image: 0, wrap: [Wrap::Repeat; 2], nearest: true }];
    let images = vec![Image { width: 1, height: 1, texels: Texels::Words(vec![texel]) }];
    let features = lucent::scene::Features { textures: true, glossy: true, ..Default::default() };
    let refs = lucent::scene::material::SceneRefs { textures: &textures, images: &images, features };
    let surface = lucent::scene::Surface {
        p: Vec3::ZERO,
        p_error: Vec3::ZERO,
        ng: Vec3::Z,
        ns,
        uv: [glam::Vec2::splat(0.5); 2],
        color: glam::Vec4::ONE,
        material: 0,
        tri: 0,
        b: [1.0, 0.0, 0.0],
    };
    let mut frame = lucent::math::frame::Frame::from_normal(ns);
    let basis = || (glam::Vec4::new(1.0, 0.0, 0.0, 1.0), Vec3::Z);
    material.bsdf(refs, &surface, (&mut frame, basis), (true, 1.0), None)
}

/// The clearcoat's normal in the BSDF's local frame.
fn coat_normal(bsdf: &lucent::bsdf::Bsdf) -> Vec3 {
    match bsdf {
        lucent::bsdf::Bsdf::MetalRough(m) => m.clearcoat_normal,
        _ => panic!("not the glTF BSDF"),
    }
}

#[test]
fn clearcoat_normal_maps_tilt_the_coat_alone_and_a_flat_one_changes_nothing() {
    use lucent::bsdf::TransportMode;
    use lucent::scene::material::TexRef;
    let plain = Material {
        base_color: Vec3::new(0.8, 0.3, 0.1),
        metallic: 0.0,
        roughness: 0.6,
        clearcoat: 1.0,
        clearcoat_roughness: 0.3,
        ..Material::default()
    };
    let flat_map = Material { clearcoat_normal_tex: Some(TexRef::plain(0)), ..plain.clone() };
    // A flat texel (0.5, 0.5, 1): 32768 / 65535 is 0.5 + 7.6e-6, a tilt of 1.5e-5 rad.
    let flat = [32768, 32768, 65535, 65535];
    let (a, b) = (bsdf_with_texel(&plain, Vec3::Z, flat), bsdf_with_texel(&flat_map, Vec3::Z, flat));
    assert_eq!(coat_normal(&a), Vec3::Z);
    assert!((coat_normal(&b) - Vec3::Z).length() < 3e-5, "{}", coat_normal(&b));
    // f cos and pdf agree to 1e-3 (the lobe's slope at a 1.5e-5 rad tilt is far below it);
    // a tilted coat normal (below) differs by more than 10%.
    let tilted_map = Material { clearcoat_normal_scale: 0.5, ..flat_map.clone() };
    let tilted = bsdf_with_texel(&tilted_map, Vec3::Z, [52428, 32768, 58982, 65535]);
    let mut tilted_differs = 0;
    for (theta_o, theta_i, phi) in [(0.3f32, 0.5f32, 3.0f32), (0.9, 0.8, 2.5), (1.3, 1.2, 3.1), (0.6, 0.2, 1.0)] {
        let wo = Vec3::new(theta_o.sin(), 0.0, theta_o.cos());
        let wi = Vec3::new(theta_i.sin() * phi.cos(), theta_i.sin() * phi.sin(), theta_i.cos());
        let (fa, pa) = a.eval_pdf(wo, wi, TransportMode::Radiance);
        let (fb, pb) = b.eval_pdf(wo, wi, TransportMode::Radiance);
        let close = |x: f32, y: f32| (x - y).abs() <= 1e-3 * x.abs().max(y.abs());
        assert!(close(fa.max_element(), fb.max_element()) && close(pa, pb), "{fa:?} {pa} vs {fb:?} {pb}");
        let (ft, _) = tilted.eval_pdf(wo, wi, TransportMode::Radiance);
        tilted_differs += usize::from((ft.max_element() - fa.max_element()).abs() > 0.1 * fa.max_element());
        for u in [0.1f32, 0.5, 0.95] {
            let (sa, sb) = (
                a.sample(wo, u, glam::Vec2::new(0.3, 0.7), TransportMode::Radiance),
                b.sample(wo, u, glam::Vec2::new(0.3, 0.7), TransportMode::Radiance),
            );
            let (sa, sb) = (sa.unwrap(), sb.unwrap());
            assert!((sa.wi - sb.wi).length() < 1e-4 && close(sa.pdf, sb.pdf), "{sa:?} vs {sb:?}");
        }
    }
    assert!(tilted_differs > 0, "a tilted coat normal changes the BSDF");
    // The texel (0.8, 0.5, 0.9) is (0.6, 0, 0.8) in tangent space, X and Y scaled by 0.5.
    let want = Vec3::new(0.3, 0.0, 0.8).normalize();
    assert!((coat_normal(&tilted) - want).length() < 1e-4, "{} vs {want}", coat_normal(&tilted));
    // Under a normal-mapped base, a coat without its own map keeps the unmapped normal: +z
    // in the world, which the base's tilted frame sees tilted the other way.
    let mapped_base = Material { normal_tex: Some(TexRef::plain(0)), ..plain.clone() };
    let ns = Vec3::new(0.6, 0.0, 0.8);
    let under = bsdf_with_texel(&mapped_base, ns, flat);
    let frame = lucent::math::frame::Frame::from_normal(ns);
    assert!((coat_normal(&under) - frame.to_local(Vec3::Z)).length() < 1e-5, "{}", coat_normal(&under));
}

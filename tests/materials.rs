//! Materials in whole scenes: the Cornell glass scene (no NaN, a caustic under the glass
//! sphere, the walls mirrored in the metal sphere), Beer-Lambert attenuation against
//! thickness, alpha MASK and BLEND, single-sided culling, normal maps and clearcoat normal maps,
//! KHR_materials_specular's colour (factors above 1, textures) and minified textures.

mod common;

use glam::{DVec3, Vec2, Vec3};
use lucent::integrator::Settings;
use lucent::render::Snapshot;
use lucent::scene::environment::{EnvSettings, Environment};
use lucent::scene::{
    MeshDesc, Scene, SceneDesc,
    camera::Camera,
    material::{AlphaMode, Material, TexRef},
    texture::{Image, Texels, Texture, Wrap},
};
use std::sync::Arc;

fn glass_scene() -> Arc<Scene> {
    Arc::new(Scene::build(common::load("cornell-box-glass.gltf")))
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
    let desc = common::load("AttenuationTest/glTF-Binary/AttenuationTest.glb");
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

/// A scene lit by a uniform sky of radiance 1 and nothing else.
fn under_white_sky(desc: SceneDesc) -> Arc<Scene> {
    let sky = Environment::load(EnvSettings { background: Vec3::ONE, ..EnvSettings::default() }).unwrap();
    Arc::new(Scene::build(desc).with_environment(Some(sky)))
}

/// An 8x8 image from `camera` at `spp`, without NaN/Inf samples.
fn render_8x8(scene: &Arc<Scene>, camera: Camera, spp: u32) -> Arc<Snapshot> {
    let settings = Settings { width: 8, height: 8, target_spp: Some(spp), ..Settings::default() };
    let snap = common::render(scene, camera, settings, None);
    assert_eq!(snap.rejected, 0, "NaN/Inf samples");
    snap
}

#[test]
fn specular_colour_factors_above_one_raise_f0_as_khr_materials_specular_says() {
    // SpecularTest's last row: black smooth dielectrics (IOR 1.5, F0 0.04) whose
    // specularColorFactor is 0, 1.184, 5.441, 13.276 and 25. The extension clamps only the
    // product: F0 = min(0.04 x factor, 1). Seen head-on under a white sky, a sphere's front
    // reflects the sky behind the camera with F0 (Schlick's term is 1e-12 of it there).
    let desc = common::load("SpecularTest/glTF-Binary/SpecularTest.glb");
    let hdr: Vec<(u32, f32)> = (desc.materials.iter().enumerate())
        .filter(|(_, m)| m.name.starts_with("M7."))
        .map(|(i, m)| (i as u32, m.specular_color.x))
        .collect();
    assert_eq!(hdr.len(), 5, "the five HDR spheres");
    let bounds: Vec<(Vec3, Vec3)> = hdr
        .iter()
        .map(|&(material, _)| {
            let points = desc.meshes.iter().filter(|m| m.material == material).flat_map(|m| m.positions.iter());
            points.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)))
        })
        .collect();
    let scene = under_white_sky(desc);
    for (&(_, factor), &(lo, hi)) in hdr.iter().zip(&bounds) {
        let (centre, radius) = ((lo + hi) * 0.5, (hi - lo).x * 0.5);
        let camera = Camera::look_at(centre + Vec3::Z * 4.0 * radius, centre, 0.01);
        let (mean, se) = common::image_mean(&render_8x8(&scene, camera, 4));
        let want = (0.04 * factor as f64).min(1.0);
        assert!(se.max_element() < 1e-6, "a delta reflection of a uniform sky is noiseless: {se}");
        assert!((mean.x - want).abs() < 1e-3 * want.max(0.04), "factor {factor}: F0 {:.4}, want {want:.4}", mean.x);
    }
}

/// The unit square at z = 0 facing +z, with texture coordinates over it.
fn square(material: u32) -> MeshDesc {
    MeshDesc {
        name: "square".into(),
        positions: vec![
            Vec3::new(-0.5, -0.5, 0.0),
            Vec3::new(0.5, -0.5, 0.0),
            Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(-0.5, 0.5, 0.0),
        ],
        uvs: Some(vec![Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)]),
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
        ..MeshDesc::default()
    }
}

/// The square alone under a white sky, with `material` and the RGBA8 image `texels` (`side`
/// texels square, bilinear, repeating) as texture 0.
fn textured_square(material: Material, side: u32, texels: Vec<[u8; 4]>) -> Arc<Scene> {
    under_white_sky(SceneDesc {
        name: "square".into(),
        meshes: vec![square(0)],
        materials: vec![material],
        textures: vec![Texture { name: "t".into(), image: 0, wrap: [Wrap::Repeat; 2], nearest: false }],
        images: vec![Image { width: side, height: side, texels: Texels::Bytes(texels) }],
        ..SceneDesc::default()
    })
}

/// The sRGB decoding of an 8-bit code (IEC 61966-2-1).
fn srgb(code: u8) -> f64 {
    let c = code as f64 / 255.0;
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

#[test]
fn a_specular_colour_texture_tints_f0_as_the_same_factor_does() {
    // A black smooth dielectric square seen head-on under a white sky reflects F0 =
    // min(0.04 x specularColorFactor x specularColorTexture, 1): the texture's sRGB colour,
    // decoded, acts exactly as a factor of that value, above 1 too once multiplied.
    let code = [200u8, 150, 30, 255];
    let texel = DVec3::new(srgb(code[0]), srgb(code[1]), srgb(code[2]));
    let black = Material { base_color: Vec3::ZERO, metallic: 0.0, roughness: 0.0, ..Material::default() };
    let camera = Camera::look_at(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, 0.05);
    for factor in [1.0f32, 12.0] {
        let textured = Material {
            specular_color: Vec3::splat(factor),
            specular_color_tex: Some(TexRef::plain(0)),
            ..black.clone()
        };
        let plain = Material { specular_color: (texel * factor as f64).as_vec3(), ..black.clone() };
        let (with_texture, _) = common::image_mean(&render_8x8(&textured_square(textured, 1, vec![code]), camera, 4));
        let (with_factor, _) = common::image_mean(&render_8x8(&textured_square(plain, 1, vec![code]), camera, 4));
        let want = (texel * 0.04 * factor as f64).min(DVec3::ONE);
        for c in 0..3 {
            assert!(
                (with_texture[c] - want[c]).abs() < 1e-5,
                "factor {factor}, channel {c}: textured {with_texture}, want {want}"
            );
            assert!(
                (with_factor[c] - want[c]).abs() < 1e-5,
                "factor {factor}, channel {c}: plain {with_factor}, want {want}"
            );
        }
    }
}

#[test]
fn a_minified_black_and_white_texture_averages_to_its_linear_mean() {
    // A 256 x 256 checkerboard of black and white texels (sRGB codes 0 and 255) on a Lambertian
    // square seen by 8 x 8 pixels: each pixel covers 32 x 32 texels, and under a white sky
    // the radiance is the albedo, so the picture must average the texels' linear values,
    // 1/2 (averaging the codes and then decoding would give 0.214).
    let side = 256;
    let texels =
        (0..side * side).map(|i| if (i % side + i / side) % 2 == 0 { [0, 0, 0, 255] } else { [255; 4] }).collect();
    let material = Material { base_color_tex: Some(TexRef::plain(0)), ..Material::lambert("checker", Vec3::ONE) };
    let scene = textured_square(material, side, texels);
    // The frame lies inside the square.
    let camera = Camera::look_at(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, 0.4);
    let z_max = common::sidak_z(1e-3, 3);
    common::assert_mean(&render_8x8(&scene, camera, 64), 0.5, z_max, "checker");
}

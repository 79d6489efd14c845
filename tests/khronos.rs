//! Khronos test models rendered and checked against what their READMEs say a correct
//! renderer shows: texture orientation (TextureCoordinateTest), alpha modes
//! (AlphaBlendModeTest), normal maps with supplied and generated tangents
//! (NormalTangentMirrorTest, NormalTangentTest) and thin-walled transmission
//! (TransmissionTest). Each check is paired with a deliberately wrong variant that it
//! must reject, so it cannot pass vacuously.

mod common;

use glam::{Vec2, Vec3};
use lucent::integrator::Settings;
use lucent::render::Snapshot;
use lucent::scene::{
    Scene,
    camera::Camera,
    environment::{EnvSettings, Environment},
    geometry::Ray,
    material::AlphaMode,
};
use std::sync::Arc;

/// The Khronos test model `name` (its binary glTF) under a white sky.
fn model(name: &str) -> Scene {
    let desc = common::load(format!("{name}/glTF-Binary/{name}.glb"));
    let sky = Environment::load(EnvSettings { background: Vec3::ONE, ..EnvSettings::default() }).unwrap();
    Scene::build(desc).with_environment(Some(sky))
}

/// A camera on the +z axis through the centre of the scene's bounds, looking along -z
/// (glTF's front view), with the bounds filling most of an image of `aspect`.
fn front(scene: &Scene, aspect: f32) -> Camera {
    let (lo, hi) = scene.bounds;
    let centre = 0.5 * (lo + hi);
    let tan = (0.5f32 * 0.5).tan();
    let distance = (0.5 * (hi.y - lo.y) / tan).max(0.5 * (hi.x - lo.x) / (tan * aspect));
    Camera::look_at(centre + Vec3::new(0.0, 0.0, hi.z - centre.z + 1.05 * distance), centre, 0.5)
}

/// The material seen through each pixel's centre (None: background).
fn material_ids(scene: &Scene, camera: Camera, width: u32, height: u32) -> Vec<Option<u32>> {
    let rays = camera.rays(width, height);
    (0..width * height)
        .map(|i| {
            let film = Vec2::new((i % width) as f32 + 0.5, (i / width) as f32 + 0.5);
            scene.intersect(&rays.ray(film), true, true).map(|h| scene.geometry.attrs(h.tri).material)
        })
        .collect()
}

fn render(scene: &Arc<Scene>, camera: Camera, width: u32, height: u32, spp: u32) -> Arc<Snapshot> {
    let settings = Settings { width, height, target_spp: Some(spp), max_depth: 6, ..Settings::default() };
    let snap = common::render(scene, camera, settings, None);
    assert_eq!(snap.rejected, 0, "NaN/Inf samples");
    snap
}

fn material(scene: &Scene, name: &str) -> u32 {
    scene.materials.iter().position(|m| m.name == name).unwrap_or_else(|| panic!("no material {name}")) as u32
}

#[test]
fn texture_coordinates_put_each_labelled_corner_where_it_belongs() {
    // The README: TopLeft_TEXCOORD_0 spans u, v in [0, 0.4], the texture's top-left corner,
    // which is yellow; top right orange, bottom left blue, bottom right green. A flipped V
    // would give the top objects the bottom colours.
    let scene = Arc::new(model("TextureCoordinateTest"));
    let (w, h) = (96, 96);
    let camera = front(&scene, 1.0);
    let snap = render(&scene, camera, w, h, 8);
    let ids = material_ids(&scene, camera, w, h);
    type Hue = fn(Vec3) -> bool;
    let cases: [(&str, bool, bool, Hue); 4] = [
        ("TopLeftMat", true, true, |c| c.x > 2.0 * c.z && c.y > 2.0 * c.z && c.y > 0.6 * c.x),
        ("TopRightMat", true, false, |c| c.x > 2.0 * c.y && c.x > 4.0 * c.z),
        ("BottomLeftMat", false, true, |c| c.z > 2.0 * c.x && c.z > 1.2 * c.y),
        ("BottomRightMat", false, false, |c| c.y > 2.0 * c.x && c.y > 2.0 * c.z),
    ];
    for (name, top, left, hue) in cases {
        let m = material(&scene, name);
        let pixels: Vec<usize> = (0..ids.len()).filter(|&i| ids[i] == Some(m)).collect();
        assert!(pixels.len() > 100, "{name}: {} pixels", pixels.len());
        let centroid = pixels.iter().map(|&i| Vec2::new((i as u32 % w) as f32, (i as u32 / w) as f32)).sum::<Vec2>()
            / pixels.len() as f32;
        assert_eq!((centroid.y < h as f32 / 2.0, centroid.x < w as f32 / 2.0), (top, left), "{name} at {centroid}");
        let colour = pixels.iter().map(|&i| snap.mean[i]).sum::<Vec3>() / pixels.len() as f32;
        assert!(hue(colour), "{name}: mean colour {colour}");
    }
}

/// Pixels of a strong red: the red X marks that appear where an alpha mode is handled wrongly.
fn red_pixels(snap: &Snapshot) -> usize {
    snap.mean.iter().filter(|c| c.x > 0.15 && c.x > 3.0 * c.y && c.x > 3.0 * c.z).count()
}

#[test]
fn alpha_modes_hide_every_red_cross() {
    // The README: green checks and hidden red X's "show check marks only when the requested
    // mode is correctly applied". A renderer that ignores BLEND or MASK shows red X's.
    let scene = Arc::new(model("AlphaBlendModeTest"));
    let (w, h) = (720, 240);
    let camera = front(&scene, 3.0);
    let right = render(&scene, camera, w, h, 8);
    let red = red_pixels(&right);
    let mut wrong = scene.materials.clone();
    for m in &mut wrong {
        m.alpha_mode = AlphaMode::Opaque;
    }
    let wrong = Arc::new(scene.with_edits(wrong, scene.lights.clone()));
    let wrong_red = red_pixels(&render(&wrong, camera, w, h, 8));
    // The X under "Blend" covers about 30 pixels at this size.
    assert!(wrong_red >= 15, "the control (alpha ignored) shows red X's: {wrong_red} red pixels");
    assert!(red * 10 <= wrong_red, "{red} red pixels when rendered right, {wrong_red} with alpha ignored");
}

/// For every normal-mapped or bumped cell of the test's grid, seen front-on: the fraction
/// of its points whose shading normal tilts away from the cell's centre, as on the dome
/// the cells depict. Cells are found by clustering the points whose normal is tilted.
fn dome_agreement(scene: &Scene) -> Vec<(Vec2, f32)> {
    let (lo, hi) = scene.bounds;
    let n = 400;
    let mut tilted = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let x = lo.x + (hi.x - lo.x) * (i as f32 + 0.5) / n as f32;
            let y = lo.y + (hi.y - lo.y) * (j as f32 + 0.5) / n as f32;
            let ray = Ray { o: Vec3::new(x, y, hi.z + 1.0), d: Vec3::NEG_Z, tmax: f32::INFINITY };
            let Some(hit) = scene.intersect(&ray, true, true) else { continue };
            let s = scene.surface(&hit);
            let tilt = Vec2::new(s.ns.x, s.ns.y);
            if s.ng.z > 0.99 && tilt.length() > 0.1 || s.ng.z > 0.0 && s.ng.z < 0.99 {
                tilted.push((Vec2::new(x, y), Vec2::new(s.ns.x, s.ns.y)));
            }
        }
    }
    // Cells sit on a regular grid: split x and y where the tilted points leave a gap.
    let clusters = |coord: fn(&Vec2) -> f32| {
        let mut v: Vec<f32> = tilted.iter().map(|(p, _)| coord(p)).collect();
        v.sort_by(f32::total_cmp);
        let gap = 3.0 * (hi.x - lo.x) / n as f32;
        let mut edges = vec![v[0]];
        for pair in v.windows(2) {
            if pair[1] - pair[0] > gap {
                edges.push(0.5 * (pair[0] + pair[1]));
            }
        }
        edges
    };
    let (xs, ys) = (clusters(|p| p.x), clusters(|p| p.y));
    let cell = |p: Vec2| (xs.partition_point(|&e| e <= p.x), ys.partition_point(|&e| e <= p.y));
    let mut cells: std::collections::BTreeMap<(usize, usize), Vec<(Vec2, Vec2)>> = Default::default();
    for &(p, t) in &tilted {
        cells.entry(cell(p)).or_default().push((p, t));
    }
    cells
        .values()
        .filter(|points| points.len() > 50)
        .map(|points| {
            let centre = points.iter().map(|(p, _)| *p).sum::<Vec2>() / points.len() as f32;
            let outward = points.iter().filter(|(p, t)| t.dot(*p - centre) > 0.0).count();
            (centre, outward as f32 / points.len() as f32)
        })
        .collect()
}

#[test]
fn normal_maps_tilt_like_the_geometry_they_imitate() {
    // The README: every test cell, real geometry or normal-mapped (with V and U mirrored
    // texture coordinates), should look alike: a dome. Its shading normals must all point
    // away from the cell's centre. With the normal map's green channel flipped (the
    // README's "Flipped Y" failure) the mapped cells must fail this.
    for name in ["NormalTangentMirrorTest", "NormalTangentTest"] {
        let scene = model(name);
        let cells = dome_agreement(&scene);
        assert!(cells.len() >= 30, "{name}: found {} cells", cells.len());
        for (centre, agreement) in &cells {
            assert!(*agreement > 0.9, "{name}: cell at {centre} has {agreement:.2} of its normals pointing outwards");
        }
        let mut flipped = scene.materials.clone();
        for m in &mut flipped {
            m.normal_scale = -m.normal_scale;
        }
        let flipped = scene.with_edits(flipped, scene.lights.clone());
        let bad = dome_agreement(&flipped).iter().filter(|(_, a)| *a < 0.6).count();
        assert!(bad * 2 >= cells.len(), "{name}: inverted normal maps leave only {bad} wrong cells");
    }
}

/// Pearson correlation between the luminances of two images over the pixels that see
/// `material` (through their centre and at their four neighbours, so no pixel straddles an
/// edge of it).
fn correlation(a: &Snapshot, b: &Snapshot, ids: &[Option<u32>], width: usize, material: u32) -> f64 {
    let lum = |c: Vec3| (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z) as f64;
    let inside = |i: usize| ids.get(i) == Some(&Some(material));
    let pixels: Vec<usize> = (width..ids.len() - width)
        .filter(|&i| inside(i) && inside(i - 1) && inside(i + 1) && inside(i - width) && inside(i + width))
        .collect();
    assert!(pixels.len() > 100, "{} pixels", pixels.len());
    let n = pixels.len() as f64;
    let (ma, mb) = (
        pixels.iter().map(|&i| lum(a.mean[i])).sum::<f64>() / n,
        pixels.iter().map(|&i| lum(b.mean[i])).sum::<f64>() / n,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for &i in &pixels {
        let (da, db) = (lum(a.mean[i]) - ma, lum(b.mean[i]) - mb);
        sab += da * db;
        saa += da * da;
        sbb += db * db;
    }
    sab / (saa * sbb).sqrt()
}

#[test]
fn transmission_shows_the_backdrop_through_smooth_spheres_and_blurs_it_through_rough_ones() {
    // What a thin-walled sphere transmits is the checkered cloth straight behind it: the
    // sphere's pixels correlate with an image of the cloth alone (the spheres made
    // invisible), less so through the rough sphere, and not at all without transmission.
    let scene = Arc::new(model("TransmissionTest"));
    let (w, h) = (160, 120);
    let camera = scene.default_camera(w as f32 / h as f32);
    let ids = material_ids(&scene, camera, w, h);
    let (smooth, rough) = (material(&scene, "YellowTrans"), material(&scene, "YellowTransRough"));
    let edited = |f: &dyn Fn(&mut lucent::scene::material::Material)| {
        let mut materials = scene.materials.clone();
        f(&mut materials[smooth as usize]);
        f(&mut materials[rough as usize]);
        Arc::new(scene.with_edits(materials, scene.lights.clone()))
    };
    let spp = 32;
    let seen = render(&scene, camera, w, h, spp);
    let behind = render(
        &edited(&|m| {
            m.alpha = 0.0;
            m.alpha_mode = AlphaMode::Mask(0.5);
        }),
        camera,
        w,
        h,
        spp,
    );
    let opaque = render(&edited(&|m| m.transmission = 0.0), camera, w, h, spp);
    let w = w as usize;
    let (c_smooth, c_rough) =
        (correlation(&seen, &behind, &ids, w, smooth), correlation(&seen, &behind, &ids, w, rough));
    let c_opaque = correlation(&opaque, &behind, &ids, w, smooth);
    assert!(c_smooth > 0.5, "smooth sphere against the cloth behind it: correlation {c_smooth:.2}");
    assert!(c_smooth > c_rough + 0.1, "smooth {c_smooth:.2} vs rough {c_rough:.2}");
    assert!(c_opaque < 0.25, "without transmission: correlation {c_opaque:.2}");
}

/// ln(B / R) of the mean colour of the pixels whose centre sees `material`: how blue the
/// light through a cube of the blue glass is.
fn blueness(snap: &Snapshot, ids: &[Option<u32>], material: u32) -> f64 {
    let pixels: Vec<usize> = (0..ids.len()).filter(|&i| ids[i] == Some(material)).collect();
    assert!(pixels.len() > 20, "{} pixels", pixels.len());
    let c = pixels.iter().map(|&i| snap.mean[i]).sum::<Vec3>();
    (c.z as f64 / c.x as f64).ln()
}

#[test]
fn attenuation_deepens_with_thickness_alike_in_every_row() {
    // The README: each column must show one shade. The "Thickness Factor" row varies the
    // cube's size at attenuation distance 1, the "Attenuation" row varies the distance at
    // size 1, so column x has x units of attenuation in both: the two must be equally blue,
    // and bluer the larger x. Without the volume (thin walls) nothing deepens.
    let scene = Arc::new(model("AttenuationTest"));
    let (w, h) = (400, 400);
    let camera = front(&scene, 1.0);
    let ids = material_ids(&scene, camera, w, h);
    let columns = ["0.25", "0.50", "1.0", "1.5", "2.0"];
    let row = |snap: &Snapshot| -> Vec<(f64, f64)> {
        columns
            .iter()
            .map(|x| {
                let size =
                    if *x == "1.0" { "R2_and_R4_ThicknessFac_1.0".into() } else { format!("R2_ThicknessFac_{x}") };
                let by_size = blueness(snap, &ids, material(&scene, &size));
                (by_size, blueness(snap, &ids, material(&scene, &format!("R5_Attenuation_{x}"))))
            })
            .collect()
    };
    let right = row(&render(&scene, camera, w, h, 32));
    for (x, (by_size, by_distance)) in columns.iter().zip(&right) {
        let ratio = by_distance / by_size;
        assert!(
            (0.75..1.33).contains(&ratio),
            "column {x}: ln(B/R) {by_size:.2} by size, {by_distance:.2} by distance"
        );
    }
    // Beyond one unit the red that crosses the glass (0.1^x) is below what its faces
    // reflect, so the measure saturates; up to one unit it must grow.
    for pair in right[..3].windows(2) {
        assert!(pair[1].0 > pair[0].0 && pair[1].1 > pair[0].1, "thicker is bluer: {right:?}");
    }
    let mut thin = scene.materials.clone();
    for m in &mut thin {
        m.volume = None;
    }
    let thin = row(&render(&Arc::new(scene.with_edits(thin, scene.lights.clone())), camera, w, h, 32));
    let deepest = thin.iter().map(|p| p.0.max(p.1)).fold(f64::MIN, f64::max);
    assert!(deepest < 0.5 * right[2].0, "thin walls tint as much as one unit of glass: {thin:?}");
}

//! Delta lobes: below `SMOOTH_ALPHA` a mirror and a glass interface are exact deltas. Their
//! `eval` and `pdf` are zero in every direction; sampling returns the mirror direction with
//! probability F and the refracted one with 1 - F (pbrt-v4's EffectivelySmooth); light
//! sampling never starts at a vertex that has only delta lobes.

use glam::{UVec2, Vec2, Vec3};
use lucent::bsdf::microfacet::fresnel_dielectric;
use lucent::bsdf::{Bsdf, LobeFlags, MetalRough, TransportMode};
use lucent::integrator::{LightSampling, Settings, View, sample_pixel};
use lucent::math::warp;
use lucent::scene::{MeshDesc, Scene, SceneDesc, camera::Camera, material::Material, shapes::uv_sphere};
use lucent::spectrum::Spectrum;

const RADIANCE: TransportMode = TransportMode::Radiance;

fn from_angle(theta: f32) -> Vec3 {
    Vec3::new(theta.sin(), 0.0, theta.cos())
}

fn glass(eta: f32, thin: bool) -> Bsdf<'static> {
    Bsdf::MetalRough(MetalRough { alpha: 0.0, transmission: 1.0, eta, thin, ..MetalRough::default() })
}

#[test]
fn a_smooth_mirror_is_a_delta_lobe() {
    let base = Vec3::new(0.9, 0.6, 0.3);
    let mirror = Bsdf::MetalRough(MetalRough {
        base: Spectrum::from_rgb(base),
        metallic: 1.0,
        alpha: 0.0,
        ..MetalRough::default()
    });
    assert!(!mirror.flags().has_non_specular(), "only a delta: no light sampling there");
    for theta in [0.0f32, 0.6, 1.4] {
        let wo = from_angle(theta);
        let reflected = Vec3::new(-wo.x, -wo.y, wo.z);
        for wi in (0..256)
            .map(|i| warp::uniform_sphere(Vec2::new((i % 16) as f32 / 16.0, (i / 16) as f32 / 16.0)))
            .chain([reflected])
        {
            assert_eq!(mirror.eval_pdf(wo, wi, RADIANCE), (Spectrum::ZERO, 0.0), "eval and pdf vanish at {wi}");
        }
        assert_eq!(mirror.specular_probability(wo), 1.0);
        for u_lobe in [0.0f32, 0.5, 0.999] {
            let s = mirror.sample(wo, u_lobe, Vec2::new(0.3, 0.7), RADIANCE).expect("a mirror always reflects");
            assert!((s.wi - reflected).length() < 1e-6 && s.pdf == 1.0 && s.eta == 1.0);
            assert_eq!(s.flags, LobeFlags::REFLECTION | LobeFlags::SPECULAR);
            let schlick = base + (Vec3::ONE - base) * (1.0 - theta.cos()).powi(5);
            assert!((s.weight.to_rgb() - schlick).abs().max_element() < 1e-6, "weight {:?} vs F {schlick}", s.weight);
        }
    }
}

#[test]
fn smooth_glass_reflects_with_probability_f_and_refracts_otherwise() {
    let eta = 1.5;
    let bsdf = glass(eta, false);
    for theta in [0.1f32, 0.7, 1.3] {
        let wo = from_angle(theta);
        let f = fresnel_dielectric(wo.z, eta);
        assert!((bsdf.specular_probability(wo) - 1.0).abs() < 1e-6);
        assert!(bsdf.pdf(wo, Vec3::new(-wo.x, 0.0, -(1.0 - wo.x * wo.x / (eta * eta)).sqrt())) == 0.0);
        let n = 1000;
        let mut reflected = 0;
        for k in 0..n {
            let u_lobe = (k as f32 + 0.5) / n as f32;
            let s = bsdf.sample(wo, u_lobe, Vec2::new(0.5, 0.5), RADIANCE).unwrap();
            assert!(s.is_specular());
            if s.wi.z > 0.0 {
                reflected += 1;
                assert!(u_lobe < f + 1e-6, "reflection only below F");
                assert!((s.wi - Vec3::new(-wo.x, 0.0, wo.z)).length() < 1e-6 && (s.pdf - f).abs() < 1e-6);
                assert!((s.weight.to_rgb() - Vec3::ONE).abs().max_element() < 1e-5, "{:?}", s.weight);
            } else {
                // Snell: sin theta_t = sin theta_o / eta, in the plane of incidence, opposite side.
                assert!((-s.wi.x - wo.x / eta).abs() < 1e-6 && s.wi.y.abs() < 1e-6, "{}", s.wi);
                assert!((s.pdf - (1.0 - f)).abs() < 1e-6 && s.eta == eta && s.is_transmission());
                let w = s.weight.to_rgb();
                assert!(
                    (w - Vec3::splat(1.0 / (eta * eta))).abs().max_element() < 1e-5,
                    "radiance carries 1/eta^2: {w}"
                );
                let imp = bsdf.sample(wo, u_lobe, Vec2::new(0.5, 0.5), TransportMode::Importance).unwrap();
                assert!((imp.weight.to_rgb() - Vec3::ONE).abs().max_element() < 1e-5, "importance does not");
            }
        }
        assert!((reflected as f32 / n as f32 - f).abs() <= 1.0 / n as f32, "{reflected} of {n} reflected, F = {f}");
    }
    // From inside beyond the critical angle: total internal reflection, always.
    let inside = glass(1.0 / eta, false);
    let wo = from_angle(1.0);
    let s = inside.sample(wo, 0.99, Vec2::ZERO, RADIANCE).unwrap();
    assert!(s.wi.z > 0.0 && (s.pdf - 1.0).abs() < 1e-6);
    // A thin wall lets light straight through, unbent and unscaled.
    let thin = glass(eta, true);
    let s = thin.sample(wo, 0.99, Vec2::ZERO, RADIANCE).unwrap();
    assert!((s.wi + wo).length() < 1e-6 && s.eta == 1.0 && (s.weight.to_rgb() - Vec3::ONE).abs().max_element() < 1e-5);
}

/// A closed mirror enclosure that emits, around a smooth glass sphere: every vertex has only
/// delta lobes. `rough` makes the walls rough instead.
fn all_delta_scene(roughness: f32) -> Scene {
    let wall = Material {
        name: "mirror".into(),
        metallic: 1.0,
        roughness,
        emissive: Vec3::splat(0.25),
        ..Material::default()
    };
    let flat = |mut m: MeshDesc| {
        m.normals = None;
        m
    };
    Scene::build(SceneDesc {
        name: "mirrors".into(),
        meshes: vec![
            flat(uv_sphere(Vec3::ZERO, 2.0, 12, 24, true, 0)),
            flat(uv_sphere(Vec3::new(0.0, 0.0, -1.0), 0.5, 12, 24, false, 1)),
        ],
        materials: vec![wall, Material::glass("glass", 1.5, Some(Vec3::ZERO))],
        ..SceneDesc::default()
    })
}

#[test]
fn no_shadow_ray_leaves_a_delta_vertex() {
    let camera = Camera::look_at(Vec3::new(0.0, 0.3, 1.0), Vec3::new(0.0, 0.0, -1.0), 1.0);
    let count = |scene: &Scene, light_sampling| {
        let view = View::new(scene, &camera, 16, 16);
        let s = Settings { light_sampling, max_depth: 6, ..Settings::default() };
        let (mut shadow, mut all, mut light) = (0u64, 0u64, 0.0f64);
        for i in 0..16 * 16 * 4u32 {
            let out = sample_pixel(
                scene,
                &s,
                &view,
                UVec2::new(i % 16, (i / 16) % 16),
                (i / 256) as u64,
                false,
                &mut |_, _| {},
            );
            shadow += out.shadow_rays as u64;
            all += out.rays as u64;
            light += out.radiance.to_rgb().x as f64;
        }
        (shadow, all, light)
    };
    let smooth = all_delta_scene(0.0);
    assert!(!smooth.light_sampler.is_empty(), "the walls are lights");
    for mode in [LightSampling::Explicit, LightSampling::Mis] {
        let (shadow, all, light) = count(&smooth, mode);
        assert_eq!(shadow, 0, "{mode:?}: shadow rays from delta vertices");
        assert!(all > 3 * 1024, "{mode:?}: paths bounce ({all} rays)");
        assert!(light > 0.0, "{mode:?}: light found after delta bounces counts");
    }
    let (shadow, _, _) = count(&all_delta_scene(0.5), LightSampling::Mis);
    assert!(shadow > 1024, "rough walls sample lights ({shadow} shadow rays)");
}

#[test]
fn transmits_agrees_with_the_transmission_flag() {
    for metallic in [0.0, 0.5, 1.0] {
        for transmission in [0.0, 0.5, 1.0] {
            for diffuse_transmission in [0.0, 0.5, 1.0] {
                for (alpha, thin) in [(0.0, false), (0.0, true), (0.3, false), (0.3, true)] {
                    let bsdf = Bsdf::MetalRough(MetalRough {
                        metallic,
                        transmission,
                        diffuse_transmission,
                        alpha,
                        thin,
                        ..MetalRough::default()
                    });
                    assert_eq!(
                        bsdf.transmits(),
                        bsdf.flags().contains(LobeFlags::TRANSMISSION),
                        "metallic {metallic}, transmission {transmission}, diffuse transmission \
                         {diffuse_transmission}, alpha {alpha}, thin {thin}"
                    );
                }
            }
        }
    }
}

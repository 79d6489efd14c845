//! Property tests (proptest) over the sampling and BSDF routines: for random directions,
//! parameters and uniforms, sampled directions are unit length, pdfs are finite and
//! non-negative, weights are finite whenever the pdf is positive, and every reflective
//! BSDF is reciprocal.

use glam::{Vec2, Vec3};
use lucent::bsdf::{Bsdf, Lambert, MetalRough, Strategy as Sampling};
use lucent::math::warp;
use proptest::prelude::*;

fn direction() -> impl Strategy<Value = Vec3> {
    (0.0f32..1.0, 0.0f32..1.0).prop_map(|(a, b)| warp::uniform_hemisphere(Vec2::new(a, b)))
}

fn bsdf() -> impl Strategy<Value = Bsdf> {
    prop_oneof![
        (0.0f32..=1.0).prop_map(|a| Bsdf::Lambert(Lambert { albedo: Vec3::splat(a) })),
        (0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0, 1.0f32..10.0).prop_map(
            |(base, metallic, roughness, specular, ior)| {
                let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
                Bsdf::MetalRough(MetalRough {
                    base: Vec3::new(base, 0.5 * base, 1.0 - base),
                    metallic,
                    alpha: (roughness * roughness).max(lucent::scene::material::MIN_ALPHA),
                    dielectric_f0: Vec3::splat(f0),
                    specular,
                })
            }
        ),
    ]
}

fn strategy() -> impl Strategy<Value = Sampling> {
    prop_oneof![Just(Sampling::Importance), Just(Sampling::Uniform)]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4096, ..ProptestConfig::default() })]

    #[test]
    fn samples_are_unit_with_finite_pdfs_and_weights(
        b in bsdf(), wo in direction(), s in strategy(), u_lobe in 0.0f32..1.0, u in (0.0f32..1.0, 0.0f32..1.0)
    ) {
        if let Some(sample) = b.sample(wo, u_lobe, Vec2::new(u.0, u.1), s) {
            prop_assert!((sample.wi.length() - 1.0).abs() < 1e-4, "wi {:?}", sample.wi);
            prop_assert!(sample.pdf.is_finite() && sample.pdf > 0.0);
            prop_assert!(sample.weight.is_finite() && sample.weight.min_element() >= 0.0, "weight {:?}", sample.weight);
            let pdf = b.pdf(wo, sample.wi, s);
            prop_assert!(pdf.is_finite() && pdf >= 0.0);
        }
    }

    #[test]
    fn evaluation_is_finite_non_negative_and_reciprocal(b in bsdf(), wo in direction(), wi in direction()) {
        let f = b.eval_cos(wo, wi);
        prop_assert!(f.is_finite() && f.min_element() >= 0.0, "f {:?}", f);
        for s in [Sampling::Importance, Sampling::Uniform] {
            let pdf = b.pdf(wo, wi, s);
            prop_assert!(pdf.is_finite() && pdf >= 0.0);
        }
        let fab = b.eval_cos(wo, wi) / wi.z.max(1e-6);
        let fba = b.eval_cos(wi, wo) / wo.z.max(1e-6);
        let scale = fab.max_element().max(fba.max_element()).max(1.0);
        prop_assert!((fab - fba).abs().max_element() <= 1e-3 * scale, "{:?} vs {:?}", fab, fba);
    }
}

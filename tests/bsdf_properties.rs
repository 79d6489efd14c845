//! Property tests (proptest) over the sampling and BSDF routines: for random directions,
//! parameters and uniforms, sampled directions are unit length, pdfs are finite and
//! non-negative, weights are finite whenever the pdf is positive, and every BSDF is
//! reciprocal: f(wo, wi) = f(wi, wo) for reflection, and f(wo, wi) / n_o^2 = f(wi, wo) / n_i^2
//! for transmission, light flowing from wi to wo (Veach 1997, eq. 5.14: radiance scales with
//! n^2); and the importance-transport BSDF is the adjoint of the radiance one,
//! f_importance(wo, wi) = f_radiance(wi, wo) (Veach 1997, section 5.2: no 1/eta^2 for importance).
//! Parameters include roughness 0, so delta lobes are drawn too.

use glam::{Vec2, Vec3};
use lucent::bsdf::{Bsdf, Lambert, MetalRough, TransportMode};
use lucent::integrator::Sampling;
use lucent::math::warp;
use lucent::spectrum::Spectrum;
use proptest::prelude::*;

fn direction() -> impl Strategy<Value = Vec3> {
    (0.0f32..1.0, 0.0f32..1.0).prop_map(|(a, b)| warp::uniform_hemisphere(Vec2::new(a, b)))
}

fn sphere_direction() -> impl Strategy<Value = Vec3> {
    (0.0f32..1.0, 0.0f32..1.0).prop_map(|(a, b)| warp::uniform_sphere(Vec2::new(a, b)))
}

/// The glTF BSDF with every lobe's parameters drawn at random; `eta` is n_other / n_wo.
fn metal_rough() -> impl Strategy<Value = MetalRough> {
    let core = (0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0, 1.0f32..10.0, any::<bool>());
    let layers = (0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0, 0.2f32..5.0);
    (core, layers).prop_map(
        |((base, metallic, roughness, specular, ior, thin), (transmission, coat, coat_r, sheen, sheen_r, eta))| {
            let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
            let alpha = |r: f32| r * r;
            MetalRough {
                base: Spectrum::from_rgb(Vec3::new(base, 0.5 * base, 1.0 - base)),
                metallic,
                alpha: alpha(roughness),
                dielectric_f0: Spectrum::splat(f0),
                specular,
                transmission,
                eta: if thin { ior } else { eta },
                thin,
                clearcoat: coat,
                clearcoat_alpha: alpha(coat_r),
                sheen: Spectrum::from_rgb(Vec3::new(sheen, 0.3, 1.0 - sheen)),
                sheen_alpha: (sheen_r * sheen_r).max(lucent::bsdf::sheen::MIN_SHEEN_ALPHA),
                ..MetalRough::default()
            }
        },
    )
}

fn bsdf() -> impl Strategy<Value = Bsdf<'static>> {
    prop_oneof![
        (0.0f32..=1.0).prop_map(|a| Bsdf::Lambert(Lambert { albedo: Spectrum::splat(a) })),
        metal_rough().prop_map(Bsdf::MetalRough),
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
        if let Some(sample) = s.sample(&b, wo, u_lobe, Vec2::new(u.0, u.1)) {
            prop_assert!((sample.wi.length() - 1.0).abs() < 1e-4, "wi {:?}", sample.wi);
            prop_assert!(sample.pdf.is_finite() && sample.pdf > 0.0);
            prop_assert!(sample.weight.is_finite() && sample.weight.min_element() >= 0.0, "weight {:?}", sample.weight);
            prop_assert_eq!(sample.is_specular(), u_lobe < b.specular_probability(wo), "deltas come first in u_lobe");
            if sample.is_specular() {
                prop_assert!(sample.pdf <= 1.0 + 1e-6, "a delta's pdf is a probability");
            } else {
                let pdf = s.eval_pdf(&b, wo, sample.wi).1;
                prop_assert!((pdf - sample.pdf).abs() <= 1e-4 * pdf.max(1.0), "pdf {} vs {}", pdf, sample.pdf);
            }
        }
    }

    #[test]
    fn evaluation_is_finite_non_negative_and_reciprocal(b in bsdf(), wo in direction(), wi in sphere_direction()) {
        let (f, pdf) = b.eval_pdf(wo, wi, TransportMode::Radiance);
        prop_assert!(f.is_finite() && f.min_element() >= 0.0, "f {:?}", f);
        prop_assert_eq!(f, b.eval(wo, wi, TransportMode::Radiance));
        prop_assert_eq!(pdf, b.pdf(wo, wi));
        for s in [Sampling::Importance, Sampling::Uniform] {
            let pdf = s.eval_pdf(&b, wo, wi).1;
            prop_assert!(pdf.is_finite() && pdf >= 0.0);
        }
        if wi.z.abs() < 1e-3 || wo.z < 1e-3 {
            return Ok(());
        }
        // Seen from wi, the frame is flipped to wi's side and the index ratio inverted.
        let (reversed, eta2) = match b {
            Bsdf::MetalRough(m) if wi.z < 0.0 && !m.thin => (Bsdf::MetalRough(MetalRough { eta: 1.0 / m.eta, ..m }), m.eta * m.eta),
            _ => (b, 1.0),
        };
        let flip = |w: Vec3| if wi.z < 0.0 { -w } else { w };
        let f = |b: &Bsdf, wo: Vec3, wi: Vec3, mode| b.eval(wo, wi, mode).to_rgb() / wi.z.abs();
        let fab = f(&b, wo, wi, TransportMode::Radiance);
        let fba = f(&reversed, flip(wi), flip(wo), TransportMode::Radiance);
        // With n_i / n_o = eta: f(wo, wi) eta^2 = f(wi, wo).
        let scale = (fab.max_element() * eta2).max(fba.max_element()).max(1.0);
        prop_assert!((fab * eta2 - fba).abs().max_element() <= 1e-3 * scale, "{:?} x {} vs {:?}", fab, eta2, fba);
        // The adjoint: importance flowing wo -> wi sees the radiance BSDF of wi -> wo.
        let importance = f(&b, wo, wi, TransportMode::Importance);
        prop_assert!((importance - fba).abs().max_element() <= 1e-3 * scale, "{:?} vs {:?}", importance, fba);
    }
}

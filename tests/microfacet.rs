//! The GGX distribution on its own, isotropic and anisotropic (KHR_materials_anisotropy's
//! alpha_x = mix(alpha, 1, s^2), alpha_y = alpha): D is a distribution of normals (its
//! projected area integrates to 1), and the weak white furnace of Heitz 2014 ("Understanding
//! the Masking-Shadowing Function in Microfacet-Based BRDFs", section 3.4): with F = 1 and
//! G1 in place of G2, the lobe G1(wo) D(h) / (4 cos theta_o) integrates to 1 over wi.
//!
//! Both integrals are midpoint rules on a (theta, phi) grid, evaluated at N and 2N nodes per
//! axis; the midpoint rule's error falls as 1/N^2, so the difference of the two bounds the
//! error of the finer one (Richardson: error(2N) ~ (I(2N) - I(N)) / 3; where the integrand
//! jumps, as at the furnace's h.z = 0 edge, the rule converges as 1/N and the difference
//! equals the error). Each test asserts |I(2N) - 1| <= 4 |I(2N) - I(N)| + 5e-4, the last
//! term for the integrand's f32 evaluation, whose bias does not shrink with N (measured:
//! at most 1.5e-4, for alpha 0.5 at theta_o 1.02).

use glam::Vec3;
use lucent::bsdf::microfacet::{Ggx, reflect};
use std::f64::consts::PI;

/// The alphas tested: isotropic, and anisotropic for strengths 0.3, 0.7 and 1 over
/// roughness 0.3 and 0.6 (alpha 0.09, 0.36), also turned by 90 degrees.
fn distributions() -> Vec<Ggx> {
    let mut out = vec![Ggx::isotropic(0.09), Ggx::isotropic(0.5)];
    for alpha in [0.09f32, 0.36] {
        for s in [0.3f32, 0.7, 1.0] {
            let alpha_x = alpha + (1.0 - alpha) * s * s;
            out.push(Ggx { alpha_x, alpha_y: alpha });
        }
    }
    out.push(Ggx { alpha_x: 0.1, alpha_y: 0.8 });
    out
}

/// Midpoint rule of `f(theta, phi) sin theta` over theta in [0, theta_max], phi in [0, 2 pi).
fn integrate(n: usize, theta_max: f64, f: impl Fn(Vec3) -> f64) -> f64 {
    let (dt, dp) = (theta_max / n as f64, 2.0 * PI / (2 * n) as f64);
    let mut sum = 0.0;
    for i in 0..n {
        let theta = (i as f64 + 0.5) * dt;
        let mut ring = 0.0;
        for j in 0..2 * n {
            let phi = (j as f64 + 0.5) * dp;
            let w = Vec3::new((theta.sin() * phi.cos()) as f32, (theta.sin() * phi.sin()) as f32, theta.cos() as f32);
            ring += f(w);
        }
        sum += ring * theta.sin();
    }
    sum * dt * dp
}

fn assert_converges_to_one(label: &str, coarse: f64, fine: f64) {
    let tolerance = 4.0 * (fine - coarse).abs() + 5e-4;
    assert!((fine - 1.0).abs() <= tolerance, "{label}: {fine} (coarse {coarse}), tolerance {tolerance:.1e}");
}

#[test]
fn d_integrates_to_one_over_projected_area() {
    for g in distributions() {
        let integral = |n| integrate(n, 0.5 * PI, |h| g.d(h) as f64 * h.z as f64);
        assert_converges_to_one(&format!("{g:?}"), integral(600), integral(1200));
    }
}

#[test]
fn weak_white_furnace_holds() {
    for g in distributions() {
        let directions = [Vec3::Z, Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.3, 0.8, 0.52), Vec3::new(-0.2, 0.97, 0.14)]
            .map(Vec3::normalize);
        for wo in directions {
            // Over the whole sphere of wi: masking removes what leaves below the horizon.
            let integral = |n| {
                integrate(n, PI, |wi| {
                    let h = (wo + wi).normalize_or_zero();
                    if h.z <= 0.0 {
                        return 0.0;
                    }
                    debug_assert!((reflect(wo, h) - wi).length() < 1e-3);
                    (g.g1(wo) * g.d(h) / (4.0 * wo.z)) as f64
                })
            };
            assert_converges_to_one(&format!("{g:?}, wo {wo}"), integral(700), integral(1400));
        }
    }
}

//! Chi-square goodness-of-fit tests of the direction sampling routines against their pdfs
//! (after Mitsuba 3's chi2 tests and pbrt-v4's bsdfs_test): sampled directions are binned
//! on a (theta, phi) grid, expected counts come from integrating the pdf numerically over
//! each bin, bins expecting fewer than 5 samples are pooled, and rejected samples are a bin
//! of their own (expected: the pdf's missing mass). Family-wise significance 1% (Sidak).

use glam::{UVec2, Vec3};
use lucent::bsdf::{Bsdf, Lambert, MetalRough, Strategy};
use lucent::math::sampler::Sampler;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::PI;

const THETA_BINS: usize = 32;
const PHI_BINS: usize = 64;
const SUB: usize = 8;
const SAMPLES: usize = 400_000;

fn direction(theta: f64, phi: f64) -> Vec3 {
    Vec3::new((theta.sin() * phi.cos()) as f32, (theta.sin() * phi.sin()) as f32, theta.cos() as f32)
}

fn from_angles(theta: f32) -> Vec3 {
    Vec3::new(theta.sin(), 0.0, theta.cos())
}

/// Chi-square p-value of `Bsdf::sample` under `strategy` against `Bsdf::pdf` under
/// `pdf_strategy` (the same one, unless testing the test) for outgoing `wo`.
fn p_value(bsdf: &Bsdf, wo: Vec3, strategy: Strategy, pdf_strategy: Strategy, seed: u64) -> f64 {
    let (dt, dp) = (0.5 * PI / THETA_BINS as f64, 2.0 * PI / PHI_BINS as f64);
    let bins = THETA_BINS * PHI_BINS;
    let mut observed = vec![0.0f64; bins + 1];
    let mut sampler = Sampler::new(UVec2::new(7, 11), 0, seed);
    for _ in 0..SAMPLES {
        let (u_lobe, u) = (sampler.next_1d(), sampler.next_2d());
        match bsdf.sample(wo, u_lobe, u, strategy) {
            Some(s) => {
                assert!(s.wi.z > 0.0 && (s.wi.length() - 1.0).abs() < 1e-4, "bad direction {:?}", s.wi);
                let theta = (s.wi.z as f64).clamp(-1.0, 1.0).acos();
                let phi = (s.wi.y as f64).atan2(s.wi.x as f64).rem_euclid(2.0 * PI);
                let (i, j) = (((theta / dt) as usize).min(THETA_BINS - 1), ((phi / dp) as usize).min(PHI_BINS - 1));
                observed[i * PHI_BINS + j] += 1.0;
            }
            None => observed[bins] += 1.0,
        }
    }
    let mut expected = vec![0.0f64; bins + 1];
    for i in 0..THETA_BINS {
        for j in 0..PHI_BINS {
            let mut integral = 0.0;
            for a in 0..SUB {
                for b in 0..SUB {
                    let theta = (i as f64 + (a as f64 + 0.5) / SUB as f64) * dt;
                    let phi = (j as f64 + (b as f64 + 0.5) / SUB as f64) * dp;
                    integral += bsdf.pdf(wo, direction(theta, phi), pdf_strategy) as f64 * theta.sin();
                }
            }
            expected[i * PHI_BINS + j] = integral * dt * dp / (SUB * SUB) as f64 * SAMPLES as f64;
        }
    }
    let total: f64 = expected[..bins].iter().sum();
    expected[bins] = (SAMPLES as f64 - total).max(0.0);
    // Pool bins expecting fewer than 5 samples.
    let (mut stat, mut dof, mut pooled_o, mut pooled_e) = (0.0, 0usize, 0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        if *e < 5.0 {
            pooled_o += o;
            pooled_e += e;
        } else {
            stat += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pooled_e > 0.0 {
        stat += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
        dof += 1;
    } else {
        assert_eq!(pooled_o, 0.0, "samples where the pdf is zero");
    }
    1.0 - ChiSquared::new((dof - 1) as f64).unwrap().cdf(stat)
}

fn metal_rough(base: Vec3, metallic: f32, roughness: f32) -> Bsdf {
    with_specular(base, metallic, roughness, 1.0)
}

/// The glTF BRDF with KHR_materials_specular weight `specular` and ior 1.5.
fn with_specular(base: Vec3, metallic: f32, roughness: f32, specular: f32) -> Bsdf {
    Bsdf::MetalRough(MetalRough {
        base,
        metallic,
        alpha: (roughness * roughness).max(lucent::scene::material::MIN_ALPHA),
        dielectric_f0: Vec3::splat(0.04),
        specular,
    })
}

#[test]
fn sampling_routines_match_their_pdfs() {
    let lambert = Bsdf::Lambert(Lambert { albedo: Vec3::splat(0.7) });
    let mut cases: Vec<(String, Bsdf, Vec3, Strategy)> = vec![
        ("cosine hemisphere".into(), lambert, from_angles(0.5), Strategy::Importance),
        ("uniform hemisphere".into(), lambert, from_angles(0.5), Strategy::Uniform),
        ("uniform, glossy".into(), metal_rough(Vec3::splat(0.8), 1.0, 0.3), from_angles(0.7), Strategy::Uniform),
    ];
    for roughness in [0.3f32, 0.6, 1.0] {
        for theta_o in [0.2f32, 0.9, 1.4] {
            let label = format!("GGX VNDF reflection, roughness {roughness}, theta_o {theta_o}");
            cases.push((
                label,
                metal_rough(Vec3::splat(0.9), 1.0, roughness),
                from_angles(theta_o),
                Strategy::Importance,
            ));
        }
    }
    for roughness in [0.4f32, 0.9] {
        for theta_o in [0.3f32, 1.2] {
            let label = format!("glTF mixture, roughness {roughness}, theta_o {theta_o}");
            let bsdf = metal_rough(Vec3::new(0.6, 0.4, 0.2), 0.3, roughness);
            cases.push((label, bsdf, from_angles(theta_o), Strategy::Importance));
        }
    }
    let alpha = 1.0 - (1.0 - 0.01f64).powf(1.0 / cases.len() as f64);
    let failures: Vec<String> = cases
        .iter()
        .enumerate()
        .filter_map(|(i, (label, bsdf, wo, strategy))| {
            let p = p_value(bsdf, *wo, *strategy, *strategy, i as u64);
            (p < alpha).then(|| format!("{label}: p = {p:.2e} < {alpha:.2e}"))
        })
        .collect();
    assert!(failures.is_empty(), "chi-square rejections:\n{}", failures.join("\n"));
}

#[test]
fn a_wrong_pdf_is_rejected() {
    // The test's power: cosine-distributed samples judged against the uniform pdf.
    let lambert = Bsdf::Lambert(Lambert { albedo: Vec3::ONE });
    assert!(p_value(&lambert, Vec3::Z, Strategy::Importance, Strategy::Uniform, 1) < 1e-6);
}

/// Energy conservation of white metals, white dielectrics (the diffuse base under the
/// specular layer, weighted by the energy the layer leaves), their mix, and the base alone,
/// from normal to grazing incidence; and reciprocity.
#[test]
fn brdfs_conserve_energy_and_are_reciprocal() {
    let mut sampler = Sampler::new(UVec2::new(1, 2), 0, 9);
    for roughness in [0.0f32, 0.05, 0.3, 0.7, 1.0] {
        for bsdf in [
            metal_rough(Vec3::ONE, 1.0, roughness),
            with_specular(Vec3::ONE, 0.0, roughness, 0.0),
            metal_rough(Vec3::ONE, 0.0, roughness),
            metal_rough(Vec3::ONE, 0.5, roughness),
        ] {
            for theta_o in [0.1f32, 0.8, 1.3, 1.5, 1.55] {
                let wo = from_angles(theta_o);
                let n = 20_000;
                let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    let w = bsdf
                        .sample(wo, sampler.next_1d(), sampler.next_2d(), Strategy::Importance)
                        .map_or(0.0, |s| s.weight.max_element() as f64);
                    sum += w;
                    sum_sq += w * w;
                }
                let mean = sum / n as f64;
                let se = ((sum_sq / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                assert!(mean <= 1.0 + 4.0 * se + 1e-6, "albedo {mean} > 1 ({bsdf:?}, theta_o {theta_o})");
            }
            for _ in 0..200 {
                let a = lucent::math::warp::uniform_hemisphere(sampler.next_2d());
                let b = lucent::math::warp::uniform_hemisphere(sampler.next_2d());
                let fab = bsdf.eval_cos(a, b) / b.z;
                let fba = bsdf.eval_cos(b, a) / a.z;
                assert!((fab - fba).abs().max_element() <= 1e-4 * fab.max_element().max(1.0), "{fab} vs {fba}");
            }
        }
    }
}

//! Distribution ray tracing (textbook sections 10.2 to 10.6): at every hit, `branching`
//! directions over the hemisphere, each traced recursively to `max_depth`, so a sample
//! costs up to branching^depth rays. Directions come from stratified Monte Carlo (BSDF or
//! uniform sampling per stratum, unbiased) or from the textbook's theta/phi grid (eqs. 8
//! to 10, deterministic and biased). Light sampling at each hit works as in the path
//! tracer, with the direction scheme's density in the MIS weights. Surfaces with a null lobe
//! are crossed without a bounce, as in the path tracer. Participating media are the path
//! tracer's (a scene with a scattering medium refuses this estimator). The denoiser's AOVs
//! follow the first branch of each delta vertex to the first non-specular one (`aov`).

use super::Context;
use super::aov::AovTrace;
use super::direct::sample_direct;
use super::emission::escaped;
use super::kernel::PathOutput;
use super::media::{Media, transmittance};
use super::mis::Scattered;
use super::scatter::Sampling;
use super::settings::{Directions, LightSampling};
use super::vertex::{Bounces, Step, arrive};
use crate::bsdf::{Bsdf, LobeFlags, TransportMode};
use crate::math::sampler::Sampler;
use crate::scene::geometry::Ray;
use crate::spectrum::{Spectrum, Wavelengths};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, TAU};

/// Radiance along a camera ray starting in `media` by distribution ray tracing, the rays
/// it traced, and with `aovs` the denoiser's albedo and normal.
pub fn radiance(cx: Context, ray: Ray, media: Media, sampler: &mut Sampler, aovs: bool) -> PathOutput {
    let mut out = PathOutput::default();
    let mut aov = AovTrace::new(aovs);
    let bounces = Bounces { depth: 0, travelled: 0.0, last: None };
    let radiance = trace(cx, (ray, media), bounces, sampler, &mut out, &mut aov);
    PathOutput { radiance, aov: aov.finish(), ..out }
}

/// Theta and phi cell counts of the grid for `n` directions: n = m x k with m about
/// sqrt(n / 4), since phi spans four times theta's range.
pub fn grid_shape(n: u32) -> (u32, u32) {
    let target = ((n as f32 / 4.0).sqrt().round() as u32).max(1);
    let m = (1..=target).rev().find(|m| n.is_multiple_of(*m)).unwrap_or(1);
    (m, n / m)
}

/// Strata per axis for `n` stratified directions: the divisor pair closest to square.
fn strata_shape(n: u32) -> (u32, u32) {
    let root = (n as f32).sqrt() as u32;
    let a = (1..=root.max(1)).rev().find(|a| n.is_multiple_of(*a)).unwrap_or(1);
    (n / a, a)
}

/// Radiance arriving along `ray`, in `media`, at the path's `bounces`, counting rays into
/// `out` and following `aov`.
fn trace(
    cx: Context,
    (ray, media): (Ray, Media),
    bounces: Bounces,
    sampler: &mut Sampler,
    out: &mut PathOutput,
    aov: &mut AovTrace,
) -> Spectrum {
    let Context { scene, settings } = cx;
    let Bounces { depth, travelled, last } = bounces;
    out.rays += 1;
    let Some(hit) = scene.intersect(&ray, settings.watertight, depth == 0) else {
        return escaped(cx, ray.d, last, &media, &Wavelengths::Rgb);
    };
    let absorbed = if scene.features.volumes {
        transmittance(media.sigma_t(&scene.materials), hit.t * ray.d.length())
    } else {
        Spectrum::ONE
    };
    let mut slot = None;
    let mut radiance = Spectrum::ZERO;
    let found = |le| radiance = le;
    let step = arrive(cx, (&ray, &hit), media, bounces, (&mut Wavelengths::Rgb, aov), &mut slot, found);
    let vertex = match (step, &slot) {
        (Step::Scatter, Some(vertex)) => vertex,
        (Step::Pass { weight, ray, media }, _) => {
            let arriving =
                trace(cx, (ray, media), Bounces { travelled: travelled + hit.t, ..bounces }, sampler, out, aov);
            return (radiance + weight * arriving) * absorbed;
        }
        _ => return radiance * absorbed,
    };
    if settings.light_sampling != LightSampling::Off && !scene.light_sampler.is_empty() {
        let direct = sample_direct(cx, vertex, sampler, &Wavelengths::Rgb);
        radiance += direct.radiance;
        out.rays += direct.shadow_ray as u32;
        out.shadow_rays += direct.shadow_ray as u32;
    }
    let n = settings.branching;
    // A direction sampled as `scattered`, or passed straight through a null lobe (None).
    let mut follow =
        |wi_local: Vec3, weight: Spectrum, scattered: Option<Scattered>, sampler: &mut Sampler, aov: &mut AovTrace| {
            let Some((d, o, crosses)) = vertex.leave(wi_local) else { return Spectrum::ZERO };
            let next = Ray { o, d, tmax: f32::INFINITY };
            let media = vertex.media_after(scene, crosses);
            let bounces = match scattered {
                Some(s) => Bounces { depth: depth + 1, travelled: 0.0, last: Some(s) },
                None => Bounces { travelled: travelled + hit.t, ..bounces },
            };
            weight * trace(cx, (next, media), bounces, sampler, out, aov)
        };
    let sampling = Sampling::new(settings.importance_sampling);
    match settings.directions {
        Directions::Stratified => {
            let (sx, sy) = strata_shape(n);
            for s in 0..n {
                let cell = Vec2::new((s % sx) as f32, (s / sx) as f32);
                let u_lobe = sampler.next_1d();
                let u = (cell + sampler.next_2d()) / Vec2::new(sx as f32, sy as f32);
                let u = u.min(Vec2::splat(1.0 - f32::EPSILON));
                if let Some(bs) = sampling.sample(&vertex.bsdf, vertex.wo, u_lobe, u) {
                    let null = bs.flags.contains(LobeFlags::NULL);
                    let scattered = (!null).then_some(Scattered { pdf: bs.pdf, specular: bs.is_specular() });
                    // The AOVs follow the first direction of a delta vertex only.
                    let mut branch = if s == 0 { *aov } else { AovTrace::off() };
                    branch.delta(bs.weight, bs.eta);
                    radiance += follow(bs.wi, bs.weight / n as f32, scattered, sampler, &mut branch);
                    if s == 0 {
                        *aov = branch;
                    }
                }
            }
        }
        // The grid sees no delta lobe: the AOVs are recorded here or nowhere.
        Directions::Grid => {
            radiance += grid(&vertex.bsdf, vertex.wo, n, sampler, &mut |wi, w, s, sampler| {
                follow(wi, w, s, sampler, &mut AovTrace::off())
            })
        }
    }
    radiance * absorbed
}

/// The textbook's eq. 10 at cell midpoints: sum of f cos L sin(theta) dtheta dphi. Each
/// direction's weight w is reported to MIS as the density 1 / (n w) that a Monte Carlo
/// estimate with the same weight would have. The grid sees only the non-delta lobes.
fn grid(
    bsdf: &Bsdf,
    wo: Vec3,
    n: u32,
    sampler: &mut Sampler,
    follow: &mut impl FnMut(Vec3, Spectrum, Option<Scattered>, &mut Sampler) -> Spectrum,
) -> Spectrum {
    let (m, k) = grid_shape(n);
    let (d_theta, d_phi) = (FRAC_PI_2 / m as f32, TAU / k as f32);
    let mut sum = Spectrum::ZERO;
    for i in 0..m {
        let theta = (i as f32 + 0.5) * d_theta;
        let w = theta.sin() * d_theta * d_phi;
        for j in 0..k {
            let phi = (j as f32 + 0.5) * d_phi;
            let wi = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            let f = bsdf.eval(wo, wi, TransportMode::Radiance);
            if !f.is_black() {
                let scattered = Scattered { pdf: 1.0 / (n as f32 * w), specular: false };
                sum += follow(wi, f * w, Some(scattered), sampler);
            }
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_and_strata_shapes_cover_the_branching_exactly() {
        for n in [1, 2, 4, 8, 9, 16, 32, 64, 100] {
            let (m, k) = grid_shape(n);
            assert_eq!(m * k, n);
            assert!(k >= m, "{n}: phi has the larger range");
            let (a, b) = strata_shape(n);
            assert_eq!(a * b, n);
        }
        assert_eq!(grid_shape(16), (2, 8));
        assert_eq!(grid_shape(64), (4, 16));
    }

    #[test]
    fn the_grid_integrates_a_lambertian_cosine_as_the_midpoint_rule_predicts() {
        // sum over M theta cells of sin(2 theta_i) dtheta = x / sin(x), x = pi / (2M): the
        // grid's bias for a white Lambertian surface under uniform light, exactly.
        let lambert = Bsdf::Lambert(crate::bsdf::Lambert { albedo: Spectrum::ONE });
        let mut sampler = Sampler::new(glam::UVec2::ZERO, 0, 0);
        for n in [4u32, 16, 64, 256] {
            let total = grid(&lambert, Vec3::Z, n, &mut sampler, &mut |_, w, _, _| w).to_rgb();
            let x = FRAC_PI_2 / grid_shape(n).0 as f32;
            assert!((total.x - x / x.sin()).abs() < 1e-5, "{n}: {} vs {}", total.x, x / x.sin());
        }
    }
}

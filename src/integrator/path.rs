//! The path tracer (textbook section 10.7): one direction per bounce, chosen by importance
//! sampling (10.8) or uniformly, with explicit light sampling (10.9) or MIS, and Russian
//! roulette on the square root of the throughput times eta^2 (pbrt-v4's etaScale, so that
//! radiance scaled by refraction into glass does not end paths early).
//!
//! With `MEDIA` it is the volumetric path tracer (pbrt-v4's VolPathIntegrator): inside a
//! scattering volume a free flight is sampled on every segment (`media::flight`); where light
//! scatters, a light is sampled with the phase function and MIS, and the phase function
//! gives the next direction. Scattering events in media are counted apart from surface
//! bounces, toward `max_volume_depth` (Cycles' volume bounces): a subsurface random walk
//! takes hundreds of them, a surface path a few bounces. Off, they count toward `max_depth`
//! (pbrt-v4's convention). Both kinds count toward the start of Russian roulette.
//!
//! The loop's phases: a medium along the segment, escape to the environment, the surface
//! (`vertex::arrive`: the light it emits, then a vertex, passing straight through, or the
//! end), light sampling, BSDF sampling and roulette.
//!
//! Surfaces with a null lobe (index-matched interfaces, smooth thin walls passed straight
//! through) are crossed without a bounce: the last real vertex stays the reference of the MIS
//! weights, and the distance from it keeps adding up.
//!
//! Asked for them, the path also reports the denoiser's AOVs: the albedo and normal of its
//! first non-specular vertex (`aov`).

use super::Context;
use super::aov::AovTrace;
use super::direct::{DirectLight, sample_light, sample_medium};
use super::emission::escaped;
use super::kernel::PathOutput;
use super::media::{Media, flight, transmittance};
use super::mis::Scattered;
use super::nan::{NanCause, check};
use super::scatter::Sampling;
use super::settings::{LightSampling, Settings};
use super::vertex::{Bounces, Step, arrive};
use crate::bsdf::LobeFlags;
use crate::math::sampler::Sampler;
use crate::medium::Flight;
use crate::scene::geometry::Ray;
use crate::spectrum::{Spectrum, Wavelengths};

/// Most surfaces a path crosses without a bounce (guards against coincident null surfaces).
const MAX_CROSSINGS: u32 = 256;

/// Radiance along a camera ray starting in `media`, by path tracing, the rays it traced,
/// and with `aovs` the denoiser's albedo and normal (pbrt-v4's `PathIntegrator::Li`, with
/// `MEDIA` its `VolPathIntegrator::Li`).
pub fn radiance<const MEDIA: bool>(
    cx: Context,
    mut ray: Ray,
    mut media: Media,
    sampler: &mut Sampler,
    wl: &mut Wavelengths,
    aovs: bool,
) -> PathOutput {
    let Context { scene, settings } = cx;
    let mut out = PathOutput::default();
    let mut aov = AovTrace::new(aovs);
    let mut throughput = Spectrum::ONE;
    // The product of eta^2 over the refractions (pbrt-v4's etaScale), for roulette.
    let mut eta_scale = 1.0f32;
    let mut bounces = Bounces { depth: 0, travelled: 0.0, last: None };
    // Surfaces crossed without a bounce; scattering events in media.
    let mut crossings = 0u32;
    let mut volume_events = 0u32;
    let sampling = Sampling::new(settings.importance_sampling);
    let sample_lights = settings.light_sampling != LightSampling::Off && !scene.light_sampler.is_empty();
    loop {
        out.rays += 1;
        let hit = scene.intersect(&ray, settings.watertight, bounces.last.is_none());

        // A scattering medium: where it scatters the path first, if before the surface.
        if MEDIA && let Some(volume) = media.volume(&scene.materials).filter(|v| v.scatters()) {
            let length = ray.d.length();
            let t_max = hit.map_or(f32::INFINITY, |h| h.t * length);
            match flight(scene, &volume, (&ray, t_max), throughput, sampler, wl) {
                Flight::Pass { weight } => throughput *= weight,
                Flight::Scatter { t, weight } => {
                    throughput *= weight;
                    aov.medium(volume.albedo, -ray.d / length);
                    let apart = settings.max_volume_depth;
                    if apart.map_or(bounces.depth, |_| volume_events) == apart.unwrap_or(settings.max_depth) {
                        break;
                    }
                    let (wo, p, phase) = (-ray.d / length, ray.o + ray.d * (t / length), volume.phase());
                    if sample_lights {
                        add_direct(&mut out, throughput, sample_medium(cx, (p, wo), phase, media, sampler, wl));
                    }
                    let next = phase.sample(wo, sampler.next_2d());
                    let last = Some(Scattered { pdf: next.pdf, specular: false });
                    bounces = Bounces { travelled: 0.0, last, ..bounces };
                    match apart {
                        Some(_) => volume_events += 1,
                        None => bounces.depth += 1,
                    }
                    ray = Ray { o: p, d: next.wi, tmax: f32::INFINITY };
                    if !roulette(settings, bounces.depth + volume_events, &mut throughput, eta_scale, sampler) {
                        break;
                    }
                    continue;
                }
            }
        } else if let Some(hit) = hit
            && scene.features.volumes
        {
            throughput *= transmittance(wl.reflectance(media.sigma_t(&scene.materials)), hit.t * ray.d.length());
        }

        // Escaped: light from the environment.
        let Some(hit) = hit else {
            out.radiance += throughput * escaped(cx, ray.d, bounces.last, &media, wl);
            break;
        };

        // The surface: the light it emits, then a vertex, passing straight through, or the end.
        let mut slot = None;
        let found = |le| out.radiance += throughput * le;
        let step = arrive(cx, (&ray, &hit), media, bounces, (wl, &mut aov), &mut slot, found);
        let vertex = match (step, &slot) {
            (Step::Scatter, Some(vertex)) => vertex,
            (Step::Pass { weight, ray: beyond, media: around }, _) => {
                crossings += 1;
                if crossings > MAX_CROSSINGS {
                    break;
                }
                throughput *= wl.reflectance(weight);
                bounces.travelled += hit.t;
                (ray, media) = (beyond, around);
                continue;
            }
            _ => break,
        };

        // Light sampling: one shadow ray towards a light chosen by power, traced after the
        // BSDF's direction is drawn and computed, so that the two overlap (the numbers are
        // drawn in the same order either way, unless the shadow ray's volumes draw too).
        let light = if sample_lights { sample_light(cx, vertex, sampler) } else { None };
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let sampled = sampling.sample(&vertex.bsdf, vertex.wo, u_lobe, u);
        if let Some(light) = light {
            add_direct(&mut out, throughput, light.trace(cx, sampler, wl));
        }

        // BSDF sampling: the next segment, and Russian roulette.
        let Some(bs) = sampled else { break };
        check(NanCause::BsdfSample, bs.weight);
        let Some((d, origin, crosses)) = vertex.leave(bs.wi) else { break };
        throughput *= wl.reflectance(bs.weight);
        aov.delta(bs.weight, bs.eta);
        media = vertex.media_after(scene, crosses);
        ray = Ray { o: origin, d, tmax: f32::INFINITY };
        if bs.flags.contains(LobeFlags::NULL) {
            // Crossed without a bounce: the last vertex stays the reference of MIS.
            crossings += 1;
            if crossings > MAX_CROSSINGS {
                break;
            }
            bounces.travelled += hit.t;
            continue;
        }
        if bs.is_transmission() {
            eta_scale *= bs.eta * bs.eta;
        }
        let last = Some(Scattered { pdf: bs.pdf, specular: bs.is_specular() });
        bounces = Bounces { depth: bounces.depth + 1, travelled: 0.0, last };
        if !roulette(settings, bounces.depth + volume_events, &mut throughput, eta_scale, sampler) {
            break;
        }
    }
    out.aov = aov.finish();
    out
}

/// Adds a light sample's contribution, through the path's `throughput`.
#[inline(always)]
fn add_direct(out: &mut PathOutput, throughput: Spectrum, direct: DirectLight) {
    check(NanCause::LightSample, direct.radiance);
    out.radiance += throughput * direct.radiance;
    out.rays += direct.shadow_ray as u32;
    out.shadow_rays += direct.shadow_ray as u32;
}

/// Highest survival probability of Russian roulette. Below 1, so that a path whose
/// throughput stays 1 (total internal reflection in a clear sphere) still ends; close to 1,
/// so that the hundreds of events of a random walk in a dense medium that barely absorbs
/// are not cut short (with 0.95, a subsurface furnace kept 5% of its paths after 60 events,
/// each weighted 20-fold, and its estimate was heavy-tailed).
const MAX_SURVIVAL: f32 = 0.995;

/// Russian roulette from `rr_depth` bounces on: the path survives with the square root of
/// its throughput times eta^2, capped below 1; false if it ends. The square root (Cycles'
/// rule) ends dim paths later than the throughput itself (pbrt-v4's and Mitsuba's), for
/// less error at equal time (docs/performance.md).
fn roulette(settings: &Settings, depth: u32, throughput: &mut Spectrum, eta_scale: f32, sampler: &mut Sampler) -> bool {
    let u_rr = sampler.next_1d();
    if depth >= settings.rr_depth {
        let survive = (*throughput * eta_scale).max_element().sqrt().min(MAX_SURVIVAL);
        if u_rr >= survive {
            return false;
        }
        *throughput /= survive;
    }
    true
}

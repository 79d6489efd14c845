//! The path tracer (textbook section 10.7): one direction per bounce, chosen by importance
//! sampling (10.8) or uniformly, with explicit light sampling (10.9) or MIS, and Russian
//! roulette on the square root of the throughput times eta^2 (pbrt-v4's etaScale, so that
//! radiance scaled by refraction into glass does not end paths early).
//!
//! With `MEDIA` it is the volumetric path tracer (pbrt-v4's VolPathIntegrator for
//! homogeneous media): inside a scattering volume a free-flight distance is sampled on every
//! segment (`medium::sample_flight`); where light scatters, a light is sampled with the phase
//! function and MIS, and the phase function gives the next direction. A scattering event
//! counts as a bounce toward `max_depth` and meets Russian roulette like a surface vertex.
//!
//! Surfaces with a null lobe (index-matched interfaces, smooth thin walls passed straight
//! through) are crossed without a bounce: the last real vertex stays the reference of the MIS
//! weights, and the distance from it keeps adding up.
//!
//! Asked for them, the path also reports the denoiser's AOVs: the albedo and normal of its
//! first non-specular vertex (`aov`).

use super::aov::AovTrace;
use super::direct::{sample_light, sample_medium};
use super::emission::{emitted, escaped};
use super::kernel::PathOutput;
use super::media::{Media, transmittance};
use super::mis::Scattered;
use super::nan::{NanCause, check};
use super::scatter::Sampling;
use super::settings::{LightSampling, Settings};
use super::vertex::Vertex;
use crate::bsdf::LobeFlags;
use crate::math::sampler::Sampler;
use crate::medium::{Flight, sample_flight};
use crate::scene::{Scene, geometry::Ray};
use crate::spectrum::{Spectrum, Wavelengths};

/// Most surfaces a path crosses without a bounce (guards against coincident null surfaces).
const MAX_CROSSINGS: u32 = 256;

/// Radiance along a camera ray starting in `media`, by path tracing, the rays it traced,
/// and with `aovs` the denoiser's albedo and normal.
pub fn radiance<const MEDIA: bool>(
    scene: &Scene,
    settings: &Settings,
    mut ray: Ray,
    mut media: Media,
    sampler: &mut Sampler,
    wl: &mut Wavelengths,
    aovs: bool,
) -> PathOutput {
    let mut out = PathOutput::default();
    let mut aov = AovTrace::new(aovs);
    let mut throughput = Spectrum::ONE;
    let mut eta_scale = 1.0f32;
    let mut last: Option<Scattered> = None;
    // Distance from the last scattering vertex to the current ray's origin.
    let mut travelled = 0.0f32;
    let (mut depth, mut crossings) = (0u32, 0u32);
    let sampling = Sampling::new(settings.importance_sampling);
    let sample_lights = settings.light_sampling != LightSampling::Off && !scene.light_sampler.is_empty();
    loop {
        out.rays += 1;
        let hit = scene.intersect(&ray, settings.watertight, depth == 0);

        // A scattering medium along the segment: sample where light scatters first.
        if MEDIA && let Some(volume) = media.volume(&scene.materials).filter(|v| v.scatters()) {
            let length = ray.d.length();
            let t_max = hit.map_or(f32::INFINITY, |h| h.t * length);
            let scattered = match volume.grid {
                Some(g) => {
                    // Delta tracking: a real collision scatters with the albedo as weight.
                    let mut u = || sampler.next_1d();
                    let sigma = volume.sigma_t.max_element();
                    scene.grids[g as usize]
                        .delta_track(sigma, ray.o, ray.d / length, t_max, &mut u)
                        .map(|t| (t, wl.reflectance(Spectrum::from_rgb(volume.albedo))))
                }
                None => {
                    let u = (sampler.next_1d(), sampler.next_1d());
                    match sample_flight(
                        wl.reflectance(volume.sigma_t()),
                        wl.reflectance(volume.sigma_s()),
                        t_max,
                        throughput,
                        u,
                    ) {
                        Flight::Scatter { t, weight } => Some((t, weight)),
                        Flight::Pass { weight } => {
                            throughput *= weight;
                            None
                        }
                    }
                }
            };
            if let Some((t, weight)) = scattered {
                throughput *= weight;
                aov.medium(volume.albedo, -ray.d / length);
                if depth == settings.max_depth {
                    break;
                }
                let wo = -ray.d / length;
                let p = ray.o + ray.d * (t / length);
                let phase = volume.phase();
                if sample_lights {
                    let direct = sample_medium(scene, settings, (p, wo), phase, media, sampler, wl);
                    check(NanCause::LightSample, direct.radiance);
                    out.radiance += throughput * direct.radiance;
                    out.rays += direct.shadow_ray as u32;
                    out.shadow_rays += direct.shadow_ray as u32;
                }
                let next = phase.sample(wo, sampler.next_2d());
                last = Some(Scattered { pdf: next.pdf, specular: false });
                travelled = 0.0;
                ray = Ray { o: p, d: next.wi, tmax: f32::INFINITY };
                depth += 1;
                if !roulette(settings, depth, &mut throughput, eta_scale, sampler) {
                    break;
                }
                continue;
            }
        } else if let Some(hit) = hit
            && scene.features.volumes
        {
            throughput *= transmittance(wl.reflectance(media.sigma_t(&scene.materials)), hit.t * ray.d.length());
        }
        let Some(hit) = hit else {
            out.radiance += throughput * escaped(scene, settings, ray.d, last, &media, wl);
            break;
        };
        let surface = scene.surface(&hit);

        // Emission found by the path itself.
        if surface.ng.dot(ray.d) < 0.0 {
            out.radiance += throughput * emitted(scene, settings, &surface, -ray.d, travelled + hit.t, last, wl);
        }
        if depth == settings.max_depth && !scene.features.see_through && media.is_empty() {
            if aov.pending() {
                // Its own wavelengths: the path's must not change for the AOVs' sake.
                aov.surface(&Vertex::new(scene, settings, surface, ray.d, media, &mut Wavelengths::Rgb));
            }
            break;
        }
        let vertex = Vertex::new(scene, settings, surface, ray.d, media, wl);
        aov.surface(&vertex);
        if depth == settings.max_depth {
            // No bounce is left, but light passing straight through still goes on.
            let Some(passed) = vertex.bsdf.null_transmission(vertex.wo) else { break };
            crossings += 1;
            if passed.is_black() || crossings > MAX_CROSSINGS {
                break;
            }
            throughput *= wl.reflectance(passed);
            aov.delta(passed, 1.0);
            travelled += hit.t;
            media = vertex.media_after(scene, true);
            ray = Ray { o: vertex.behind, d: ray.d, tmax: f32::INFINITY };
            continue;
        }

        // Light sampling: one shadow ray towards a light chosen by power, traced after the
        // BSDF's direction is drawn and computed, so that the two overlap (the numbers are
        // drawn in the same order either way, unless the shadow ray's volumes draw too).
        let light = if sample_lights { sample_light(scene, settings, &vertex, sampler) } else { None };

        // BSDF sampling: the direction of the next segment.
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let sampled = sampling.sample(&vertex.bsdf, vertex.wo, u_lobe, u);
        if let Some(light) = light {
            let direct = light.trace(scene, settings, sampler, wl);
            check(NanCause::LightSample, direct.radiance);
            out.radiance += throughput * direct.radiance;
            out.rays += direct.shadow_ray as u32;
            out.shadow_rays += direct.shadow_ray as u32;
        }
        let Some(bs) = sampled else { break };
        check(NanCause::BsdfSample, bs.weight);
        let Some((d, origin, crosses)) = vertex.leave(bs.wi) else { break };
        throughput *= wl.reflectance(bs.weight);
        aov.delta(bs.weight, bs.eta);
        media = vertex.media_after(scene, crosses);
        ray = Ray { o: origin, d, tmax: f32::INFINITY };
        if bs.flags.contains(LobeFlags::NULL) {
            crossings += 1;
            if crossings > MAX_CROSSINGS {
                break;
            }
            travelled += hit.t;
            continue;
        }
        if bs.is_transmission() {
            eta_scale *= bs.eta * bs.eta;
        }
        last = Some(Scattered { pdf: bs.pdf, specular: bs.is_specular() });
        travelled = 0.0;
        depth += 1;
        if !roulette(settings, depth, &mut throughput, eta_scale, sampler) {
            break;
        }
    }
    out.aov = aov.finish();
    out
}

/// Highest survival probability of Russian roulette. Below 1, so that a path whose
/// throughput stays 1 (total internal reflection in a clear sphere) still ends; close to 1,
/// so that the hundreds of events of a random walk in a dense medium that barely absorbs
/// are not cut short (with 0.95, a subsurface furnace kept 5% of its paths after 60 events,
/// each weighted 20-fold, and its estimate was heavy-tailed).
const MAX_SURVIVAL: f32 = 0.995;

/// Russian roulette from `rr_depth` bounces on: the path survives with the square root of
/// its throughput times eta^2, capped below 1; false if it ends. The square root (Cycles'
/// rule) ends dim paths later than the throughput itself (pbrt-v4's and Mitsuba's): on the
/// Cornell boxes at 64 spp it traced 8% more rays per sample for 16% (box) and 14% (glass)
/// less squared error (README, "Speed").
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

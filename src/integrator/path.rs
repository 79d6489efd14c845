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
use super::vertex::{Bounces, Step, Vertex, arrive};
use crate::bsdf::{BsdfSample, LobeFlags};
use crate::math::sampler::Sampler;
use crate::medium::{Flight, Volume};
use crate::scene::geometry::Ray;
use crate::spectrum::{Spectrum, Wavelengths};

/// Most surfaces a path crosses without a bounce (guards against coincident null surfaces).
const MAX_CROSSINGS: u32 = 256;

/// Radiance along a camera ray starting in `media`, by path tracing, the rays it traced,
/// and with `aovs` the denoiser's albedo and normal (pbrt-v4's `PathIntegrator::Li`, with
/// `MEDIA` its `VolPathIntegrator::Li`).
pub fn radiance<const MEDIA: bool>(
    cx: Context,
    ray: Ray,
    media: Media,
    sampler: &mut Sampler,
    wl: &mut Wavelengths,
    aovs: bool,
) -> PathOutput {
    let Context { scene, settings } = cx;
    let mut path = Path::new(ray, media, aovs);
    let sampling = Sampling::new(settings.importance_sampling);
    let sample_lights = settings.light_sampling != LightSampling::Off && !scene.light_sampler.is_empty();
    loop {
        path.out.rays += 1;
        let hit = scene.intersect(&path.ray, settings.watertight, path.bounces.depth == 0);

        // A scattering medium along the segment: where light scatters first, if before the surface.
        if MEDIA && let Some(volume) = path.media.volume(&scene.materials).filter(|v| v.scatters()) {
            let t_max = hit.map_or(f32::INFINITY, |h| h.t * path.ray.d.length());
            match flight(scene, &volume, (&path.ray, t_max), path.throughput, sampler, wl) {
                Flight::Scatter { t, weight } => {
                    if !path.scatter_in_medium(cx, (&volume, t, weight), sample_lights, sampler, wl) {
                        break;
                    }
                    continue;
                }
                Flight::Pass { weight } => path.throughput *= weight,
            }
        } else if let Some(hit) = hit
            && scene.features.volumes
        {
            let sigma_t = wl.reflectance(path.media.sigma_t(&scene.materials));
            path.throughput *= transmittance(sigma_t, hit.t * path.ray.d.length());
        }

        // Escaped: light from the environment.
        let Some(hit) = hit else {
            path.out.radiance += path.throughput * escaped(cx, path.ray.d, path.bounces.last, &path.media, wl);
            break;
        };

        // The surface: the light it emits, then a vertex, passing straight through, or the end.
        let (emission, step) = arrive(cx, (&path.ray, &hit), path.media, path.bounces, wl, &mut path.aov);
        if let Some(le) = emission {
            path.out.radiance += path.throughput * le;
        }
        let vertex = match step {
            Step::Scatter(vertex) => vertex,
            Step::Pass { weight, ray, media } => {
                if !path.pass(weight, (ray, media), hit.t, wl) {
                    break;
                }
                continue;
            }
            Step::End => break,
        };

        // Light sampling: one shadow ray towards a light chosen by power, traced after the
        // BSDF's direction is drawn and computed, so that the two overlap (the numbers are
        // drawn in the same order either way, unless the shadow ray's volumes draw too).
        let light = if sample_lights { sample_light(cx, &vertex, sampler) } else { None };
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let sampled = sampling.sample(&vertex.bsdf, vertex.wo, u_lobe, u);
        if let Some(light) = light {
            path.add_direct(light.trace(cx, sampler, wl));
        }

        // BSDF sampling: the next segment, and Russian roulette.
        let Some(bs) = sampled else { break };
        if !path.bounce(cx, &vertex, bs, hit.t, sampler, wl) {
            break;
        }
    }
    path.out.aov = path.aov.finish();
    path.out
}

/// A path's state between its segments.
struct Path {
    /// What it has gathered so far.
    out: PathOutput,
    /// The denoiser's AOVs.
    aov: AovTrace,
    /// Its throughput.
    throughput: Spectrum,
    /// The product of eta^2 over its refractions (pbrt-v4's etaScale), for roulette.
    eta_scale: f32,
    /// Its bounces, and how the current ray was sampled.
    bounces: Bounces,
    /// Surfaces crossed without a bounce.
    crossings: u32,
    /// The current ray.
    ray: Ray,
    /// The volumes the current ray is in.
    media: Media,
}

impl Path {
    fn new(ray: Ray, media: Media, aovs: bool) -> Self {
        Self {
            out: PathOutput::default(),
            aov: AovTrace::new(aovs),
            throughput: Spectrum::ONE,
            eta_scale: 1.0,
            bounces: Bounces { depth: 0, travelled: 0.0, last: None },
            crossings: 0,
            ray,
            media,
        }
    }

    /// Adds a light sample's contribution.
    #[inline(always)]
    fn add_direct(&mut self, direct: DirectLight) {
        check(NanCause::LightSample, direct.radiance);
        self.out.radiance += self.throughput * direct.radiance;
        self.out.rays += direct.shadow_ray as u32;
        self.out.shadow_rays += direct.shadow_ray as u32;
    }

    /// Light passes straight through a surface with `weight`, on along `ray` in `media`, the
    /// current ray having reached it after `t`; false if the path has crossed too many.
    #[inline(always)]
    fn pass(&mut self, weight: Spectrum, (ray, media): (Ray, Media), t: f32, wl: &Wavelengths) -> bool {
        self.crossings += 1;
        if self.crossings > MAX_CROSSINGS {
            return false;
        }
        self.throughput *= wl.reflectance(weight);
        self.bounces.travelled += t;
        self.media = media;
        self.ray = ray;
        true
    }

    /// The volume scatters the path `t` along its ray with `weight`: light sampling with
    /// the phase function, then the phase function's direction; false if the path ends.
    #[inline(always)]
    fn scatter_in_medium(
        &mut self,
        cx: Context,
        (volume, t, weight): (&Volume, f32, Spectrum),
        sample_lights: bool,
        sampler: &mut Sampler,
        wl: &Wavelengths,
    ) -> bool {
        let length = self.ray.d.length();
        self.throughput *= weight;
        self.aov.medium(volume.albedo, -self.ray.d / length);
        if self.bounces.depth == cx.settings.max_depth {
            return false;
        }
        let wo = -self.ray.d / length;
        let p = self.ray.o + self.ray.d * (t / length);
        let phase = volume.phase();
        if sample_lights {
            self.add_direct(sample_medium(cx, (p, wo), phase, self.media, sampler, wl));
        }
        let next = phase.sample(wo, sampler.next_2d());
        self.bounces.last = Some(Scattered { pdf: next.pdf, specular: false });
        self.bounces.travelled = 0.0;
        self.ray = Ray { o: p, d: next.wi, tmax: f32::INFINITY };
        self.bounces.depth += 1;
        roulette(cx.settings, self.bounces.depth, &mut self.throughput, self.eta_scale, sampler)
    }

    /// The path leaves `vertex`, which its ray reached after `t`, along the BSDF sample
    /// `bs`; false if it ends (a direction the surface blocks, too many crossings, roulette).
    #[inline(always)]
    fn bounce(
        &mut self,
        cx: Context,
        vertex: &Vertex,
        bs: BsdfSample,
        t: f32,
        sampler: &mut Sampler,
        wl: &Wavelengths,
    ) -> bool {
        check(NanCause::BsdfSample, bs.weight);
        let Some((d, origin, crosses)) = vertex.leave(bs.wi) else { return false };
        self.throughput *= wl.reflectance(bs.weight);
        self.aov.delta(bs.weight, bs.eta);
        self.media = vertex.media_after(cx.scene, crosses);
        self.ray = Ray { o: origin, d, tmax: f32::INFINITY };
        if bs.flags.contains(LobeFlags::NULL) {
            // Crossed without a bounce: the last vertex stays the reference of MIS.
            self.crossings += 1;
            self.bounces.travelled += t;
            return self.crossings <= MAX_CROSSINGS;
        }
        if bs.is_transmission() {
            self.eta_scale *= bs.eta * bs.eta;
        }
        self.bounces.last = Some(Scattered { pdf: bs.pdf, specular: bs.is_specular() });
        self.bounces.travelled = 0.0;
        self.bounces.depth += 1;
        roulette(cx.settings, self.bounces.depth, &mut self.throughput, self.eta_scale, sampler)
    }
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

//! The path tracer (textbook section 10.7): one direction per bounce, chosen by importance
//! sampling (10.8) or uniformly, with explicit light sampling (10.9) or MIS, and Russian
//! roulette on the throughput times eta^2 (pbrt-v4's etaScale), so that radiance scaled by
//! refraction into glass does not end paths early.

use super::direct::sample_direct;
use super::emission::{emitted, escaped};
use super::kernel::PathOutput;
use super::media::{Media, transmittance};
use super::mis::Scattered;
use super::nan::{NanCause, check};
use super::scatter::Sampling;
use super::settings::{LightSampling, Settings};
use super::vertex::Vertex;
use crate::math::sampler::Sampler;
use crate::scene::{Scene, geometry::Ray};
use crate::spectrum::Spectrum;

/// Radiance along a camera ray by path tracing, and the rays it traced.
pub fn radiance(scene: &Scene, settings: &Settings, mut ray: Ray, sampler: &mut Sampler) -> PathOutput {
    let mut out = PathOutput::default();
    let mut throughput = Spectrum::ONE;
    let mut eta_scale = 1.0f32;
    let mut last: Option<Scattered> = None;
    let mut depth = 0u32;
    let mut media = Media::default();
    let sampling = Sampling::new(settings.importance_sampling);
    let sample_lights = settings.light_sampling != LightSampling::Off && !scene.light_sampler.is_empty();
    loop {
        out.rays += 1;
        let Some(hit) = scene.intersect(&ray, settings.watertight, depth == 0) else {
            out.radiance += throughput * escaped(scene, settings, ray.d, last, &media);
            break;
        };
        if scene.features.volumes {
            throughput *= transmittance(media.sigma_a(&scene.materials), hit.t * ray.d.length());
        }
        let surface = scene.surface(&hit);

        // Emission found by the path itself.
        if surface.ng.dot(ray.d) < 0.0 {
            out.radiance += throughput * emitted(scene, settings, &surface, -ray.d, hit.t, last);
        }
        if depth == settings.max_depth {
            break;
        }
        let vertex = Vertex::new(scene, settings, surface, ray.d, media);

        // Light sampling: one shadow ray towards a light chosen by power.
        if sample_lights {
            let direct = sample_direct(scene, settings, &vertex, sampler);
            check(NanCause::LightSample, direct.radiance);
            out.radiance += throughput * direct.radiance;
            out.rays += direct.shadow_ray as u32;
            out.shadow_rays += direct.shadow_ray as u32;
        }

        // BSDF sampling: the direction of the next segment.
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = sampling.sample(&vertex.bsdf, vertex.wo, u_lobe, u) else { break };
        check(NanCause::BsdfSample, bs.weight);
        let Some((d, origin, crosses)) = vertex.leave(bs.wi) else { break };
        throughput *= bs.weight;
        if bs.is_transmission() {
            eta_scale *= bs.eta * bs.eta;
        }
        last = Some(Scattered { pdf: bs.pdf, specular: bs.is_specular() });
        media = vertex.media_after(scene, crosses);
        ray = Ray { o: origin, d, tmax: f32::INFINITY };
        depth += 1;

        // Termination: Russian roulette on the throughput, survival capped below 1.
        let u_rr = sampler.next_1d();
        if depth >= settings.rr_depth {
            let survive = (throughput * eta_scale).max_element().min(0.95);
            if u_rr >= survive {
                break;
            }
            throughput /= survive;
        }
    }
    out
}

//! Next-event estimation (the textbook's explicit light sampling, section 10.9): at a vertex
//! with a non-delta lobe, one light is sampled (`Scene::sample_li`), the shadow ray towards
//! it is traced here, with the transmittance of the volume it runs through, and the
//! estimate is weighted against BSDF sampling by MIS. A vertex with only delta lobes
//! samples no light: no light direction could be reflected by it.

use super::media::transmittance;
use super::mis::power_heuristic;
use super::scatter::Sampling;
use super::settings::{LightSampling, Settings};
use super::vertex::Vertex;
use crate::math::{float::offset_ray_origin, sampler::Sampler};
use crate::scene::{Scene, geometry::Ray, light::LightTarget};
use crate::spectrum::Spectrum;
use glam::Vec3;

/// What one light sample contributed, and whether it traced a shadow ray.
#[derive(Clone, Copy, Debug)]
pub struct DirectLight {
    /// Direct radiance towards the vertex's wo (before the path's throughput).
    pub radiance: Spectrum,
    /// A shadow ray was traced.
    pub shadow_ray: bool,
}

impl DirectLight {
    const NONE: Self = Self { radiance: Spectrum::ZERO, shadow_ray: false };
}

/// The shadow ray from `vertex` along world direction `wi` towards `target`, and the
/// transmittance of the volume it runs through; None if `wi` leaves on a side the BSDF does
/// not reach.
fn shadow_ray(
    scene: &Scene,
    settings: &Settings,
    vertex: &Vertex,
    wi: Vec3,
    target: LightTarget,
) -> Option<(Ray, Spectrum)> {
    let (_, origin, crosses) = vertex.leave(vertex.frame.to_local(wi))?;
    let (d, tmax) = match target {
        LightTarget::Surface { p, error, n } => {
            let end = if settings.offset_origins { offset_ray_origin(p, error, n, -wi) } else { p };
            (end - origin, 1.0)
        }
        LightTarget::Point(p) => (p - origin, 1.0),
        LightTarget::Infinite => (wi, f32::INFINITY),
    };
    let tr = if scene.features.volumes {
        let sigma = vertex.media_after(scene, crosses).sigma_a(&scene.materials);
        transmittance(sigma, d.length() * tmax)
    } else {
        Spectrum::ONE
    };
    Some((Ray { o: origin, d, tmax }, tr))
}

/// Direct light at `vertex` from one light chosen in proportion to power. Area lights are
/// sampled by area and converted to solid angle, `Le f cos_s cos_l / (d^2 p_area p_select)`,
/// with no clamp.
pub fn sample_direct(scene: &Scene, settings: &Settings, vertex: &Vertex, sampler: &mut Sampler) -> DirectLight {
    let u_select = sampler.next_2d();
    let u = sampler.next_2d();
    if !vertex.bsdf.flags().has_non_specular() {
        return DirectLight::NONE;
    }
    let Some(light) = scene.sample_li(vertex.surface.p, u_select, u) else { return DirectLight::NONE };
    let sampling = Sampling::new(settings.importance_sampling);
    let (f, bsdf_pdf) = sampling.eval_pdf(&vertex.bsdf, vertex.wo, vertex.frame.to_local(light.wi));
    if f.is_black() {
        return DirectLight::NONE;
    }
    let Some((ray, tr)) = shadow_ray(scene, settings, vertex, light.wi, light.target) else {
        return DirectLight::NONE;
    };
    if scene.occluded(&ray, settings.watertight) {
        return DirectLight { radiance: Spectrum::ZERO, shadow_ray: true };
    }
    let radiance = if light.is_delta {
        light.radiance * f * tr / light.pdf
    } else {
        let weight = match settings.light_sampling {
            LightSampling::Mis => power_heuristic(light.pdf, bsdf_pdf),
            _ => 1.0,
        };
        light.radiance * f * tr * (weight / light.pdf)
    };
    DirectLight { radiance, shadow_ray: true }
}

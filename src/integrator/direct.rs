//! Next-event estimation (the textbook's explicit light sampling, section 10.9): at a vertex
//! with a non-delta lobe, or at a point where a medium scatters, one light is sampled
//! (`Scene::sample_li`), the shadow ray towards it is traced here, and the estimate is
//! weighted against BSDF or phase sampling by MIS. A vertex with only delta lobes samples
//! no light: no light direction could be reflected by it.
//!
//! Shadow rays carry the transmittance of the volumes they run through and cross surfaces
//! that let light straight through (the null lobe of an index-matched interface or a smooth
//! thin wall), picking up what those pass; any other surface blocks them.

use super::Context;
use super::media::{Media, transmittance};
use super::mis::power_heuristic;
use super::scatter::Sampling;
use super::settings::{LightSampling, Settings};
use super::vertex::Vertex;
use crate::math::{float::offset_ray_origin, sampler::Sampler};
use crate::medium::phase::HenyeyGreenstein;
use crate::scene::{
    Scene,
    geometry::Ray,
    light::{LightSample, LightTarget},
};
use crate::spectrum::{Spectrum, Wavelengths};
use glam::Vec3;

/// Most see-through surfaces one shadow ray crosses before it counts as blocked.
const MAX_CROSSINGS: u32 = 64;

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

/// The end of a shadow ray from `origin` towards `target` along `wi`: its direction scaled
/// so that the target is at t = 1, or `wi` with t unbounded.
fn towards(settings: &Settings, origin: Vec3, wi: Vec3, target: LightTarget) -> (Vec3, f32) {
    match target {
        LightTarget::Surface { p, error, n } => {
            let end = if settings.offset_origins { offset_ray_origin(p, error, n, -wi) } else { p };
            (end - origin, 1.0)
        }
        LightTarget::Point(p) => (p - origin, 1.0),
        LightTarget::Infinite => (wi, f32::INFINITY),
    }
}

/// Transmittance of the volume innermost in `media` along the ray from `o` along `d` up to
/// parameter `t`: Beer-Lambert for a homogeneous medium, ratio tracking through a grid.
/// Forced inline, with `shadow`: left to itself the compiler calls both out of line.
#[inline(always)]
fn segment(
    scene: &Scene,
    media: &Media,
    (o, d, t): (Vec3, Vec3, f32),
    sampler: &mut Sampler,
    wl: &Wavelengths,
) -> Spectrum {
    if !scene.features.volumes {
        return Spectrum::ONE;
    }
    let length = d.length();
    match media.volume(&scene.materials) {
        Some(v) => match v.grid {
            Some(g) => {
                let mut u = || sampler.next_1d();
                let sigma = v.sigma_t.max_element();
                Spectrum::splat(scene.grids[g as usize].ratio_track(sigma, o, d / length, t * length, &mut u))
            }
            None => transmittance(wl.reflectance(v.sigma_t()), t * length),
        },
        None => Spectrum::ONE,
    }
}

/// Transmittance of the shadow ray from `origin` towards `target` along `wi`, starting in
/// `media`: zero if an opaque or refracting surface blocks it.
#[inline(always)]
pub(super) fn shadow(
    cx: Context,
    (origin, wi, target): (Vec3, Vec3, LightTarget),
    media: Media,
    sampler: &mut Sampler,
    wl: &Wavelengths,
) -> Spectrum {
    let Context { scene, settings } = cx;
    let (d, tmax) = towards(settings, origin, wi, target);
    let ray = Ray { o: origin, d, tmax };
    if scene.features.see_through || !media.is_empty() {
        return shadow_through(cx, (ray, wi, target), media, sampler, wl);
    }
    if scene.occluded(&ray, settings.watertight) {
        Spectrum::ZERO
    } else {
        segment(scene, &media, (origin, d, tmax), sampler, wl)
    }
}

/// `shadow` in a scene with see-through surfaces, or from inside a volume: crosses each
/// see-through surface the ray meets, up to `MAX_CROSSINGS`.
#[inline(never)]
fn shadow_through(
    cx: Context,
    (mut ray, wi, target): (Ray, Vec3, LightTarget),
    mut media: Media,
    sampler: &mut Sampler,
    wl: &Wavelengths,
) -> Spectrum {
    let Context { scene, settings } = cx;
    let mut tr = Spectrum::ONE;
    for _ in 0..MAX_CROSSINGS {
        let Some(hit) = scene.intersect(&ray, settings.watertight, false) else {
            return tr * segment(scene, &media, (ray.o, ray.d, ray.tmax), sampler, wl);
        };
        // The material first: a blocker's surface (its normal map, say) is not needed.
        if !scene.material_at(hit.tri).is_transmissive() {
            return Spectrum::ZERO;
        }
        let surface = scene.surface(&hit);
        tr *= segment(scene, &media, (ray.o, ray.d, hit.t), sampler, wl);
        let vertex = Vertex::new(cx, surface, ray.d, media, &mut wl.clone());
        let Some(passed) = vertex.bsdf.null_transmission(vertex.wo) else { return Spectrum::ZERO };
        tr *= wl.reflectance(passed);
        if tr.is_black() {
            return tr;
        }
        media = vertex.media_after(scene, true);
        let (d, tmax) = towards(settings, vertex.behind, wi, target);
        ray = Ray { o: vertex.behind, d, tmax };
    }
    Spectrum::ZERO
}

/// The light sample's contribution for a scattering function value `f` (f |cos| at a
/// surface, the phase function in a medium) of density `pdf` for the direction, and the
/// shadow ray's transmittance `tr`.
fn weighted(
    settings: &Settings,
    light: &LightSample,
    (f, pdf): (Spectrum, f32),
    tr: Spectrum,
    wl: &Wavelengths,
) -> Spectrum {
    let (radiance, f) = (wl.illuminant(light.radiance), wl.reflectance(f));
    if light.is_delta {
        return radiance * f * tr / light.pdf;
    }
    let weight = match settings.light_sampling {
        LightSampling::Mis => power_heuristic(light.pdf, pdf),
        _ => 1.0,
    };
    radiance * f * tr * (weight / light.pdf)
}

/// Direct light at the surface `vertex` from one light chosen in proportion to power. Area
/// lights are sampled by area and converted to solid angle, `Le f cos_s cos_l / (d^2 p_area
/// p_select)`, with no clamp.
pub fn sample_direct(cx: Context, vertex: &Vertex, sampler: &mut Sampler, wl: &Wavelengths) -> DirectLight {
    match sample_light(cx, vertex, sampler) {
        Some(light) => light.trace(cx, sampler, wl),
        None => DirectLight::NONE,
    }
}

/// `sample_direct` up to its shadow ray: the light sample (two draws, always made) and the
/// BSDF's value and density for it; None where it carries nothing. The path tracer draws
/// and computes its next direction before it traces the shadow ray, so that the processor
/// works on both at once.
#[inline(always)]
pub fn sample_light(cx: Context, vertex: &Vertex, sampler: &mut Sampler) -> Option<PendingLight> {
    let Context { scene, settings } = cx;
    let u_select = sampler.next_2d();
    let u = sampler.next_2d();
    if !vertex.bsdf.flags().has_non_specular() {
        return None;
    }
    let light = scene.sample_li(vertex.surface.p, u_select, u)?;
    let sampling = Sampling::new(settings.importance_sampling);
    let (f, bsdf_pdf) = sampling.eval_pdf(&vertex.bsdf, vertex.wo, vertex.frame.to_local(light.wi));
    if f.is_black() {
        return None;
    }
    let (_, origin, crosses) = vertex.leave(vertex.frame.to_local(light.wi))?;
    Some(PendingLight { light, f, bsdf_pdf, origin, media: vertex.media_after(scene, crosses) })
}

/// A light sample at a surface whose shadow ray is still to be traced.
pub struct PendingLight {
    light: LightSample,
    /// The BSDF's value (times the cosine) and density for the light's direction.
    f: Spectrum,
    bsdf_pdf: f32,
    /// Where the shadow ray leaves from, and the volumes it starts in.
    origin: Vec3,
    media: Media,
}

impl PendingLight {
    /// Traces the shadow ray and weights the sample.
    pub fn trace(self, cx: Context, sampler: &mut Sampler, wl: &Wavelengths) -> DirectLight {
        let Self { light, f, bsdf_pdf, origin, media } = self;
        let tr = shadow(cx, (origin, light.wi, light.target), media, sampler, wl);
        if tr.is_black() {
            return DirectLight { radiance: Spectrum::ZERO, shadow_ray: true };
        }
        DirectLight { radiance: weighted(cx.settings, &light, (f, bsdf_pdf), tr, wl), shadow_ray: true }
    }
}

/// Direct light at a point `p` where a medium of phase function `phase` scatters light
/// towards `wo`, the path being in `media` there.
pub fn sample_medium(
    cx: Context,
    (p, wo): (Vec3, Vec3),
    phase: HenyeyGreenstein,
    media: Media,
    sampler: &mut Sampler,
    wl: &Wavelengths,
) -> DirectLight {
    let u_select = sampler.next_2d();
    let u = sampler.next_2d();
    let Some(light) = cx.scene.sample_li(p, u_select, u) else { return DirectLight::NONE };
    let f = phase.eval(wo, light.wi);
    let tr = shadow(cx, (p, light.wi, light.target), media, sampler, wl);
    if tr.is_black() {
        return DirectLight { radiance: Spectrum::ZERO, shadow_ray: true };
    }
    DirectLight { radiance: weighted(cx.settings, &light, (Spectrum::splat(f), f), tr, wl), shadow_ray: true }
}

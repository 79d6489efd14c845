//! A surface scattering vertex: where a ray met a surface, the shading frame turned to the
//! side it arrived from, the BSDF there, where rays leave from, and the volumes the path is
//! in; and the step every estimator takes where its ray meets a surface (`arrive`): the
//! light found there, then a vertex to scatter at, light passing straight through once no
//! bounce is left, or the end. Shared by the path tracer and the distribution ray tracer.

use super::Context;
use super::aov::AovTrace;
use super::emission::emitted;
use super::media::Media;
use super::mis::Scattered;
use crate::bsdf::Bsdf;
use crate::math::frame::Frame;
use crate::scene::{
    Scene, Surface,
    geometry::{Hit, Ray},
    shading::bend_normal,
};
use crate::spectrum::{Spectrum, Wavelengths};
use glam::Vec3;

/// Shading frame at `surface` for a ray arriving from `wo`, turned to the side it arrived
/// from (`front`; every surface is shaded two-sided). A shading normal on the other side of
/// the surface falls back to the geometric one, and one that would reflect the view below
/// the surface is bent (`bend_normal`).
fn shading_frame(surface: &Surface, front: bool, wo: Vec3) -> Frame {
    let ng = if front { surface.ng } else { -surface.ng };
    let ns = if front { surface.ns } else { -surface.ns };
    // The facet's own normal reflects nothing below the surface: nothing to bend.
    Frame::from_normal(if ns == ng { ns } else { bend_normal(ng, wo, if ns.dot(ng) > 0.0 { ns } else { ng }) })
}

/// A scattering event on a surface.
#[derive(Clone, Copy)]
pub struct Vertex<'a> {
    /// The surface point.
    pub surface: Surface,
    /// The path arrived on the front (glTF winding) side.
    pub front: bool,
    /// Shading frame, normal on the arriving side.
    pub frame: Frame,
    /// Direction back along the arriving ray, in the shading frame.
    pub wo: Vec3,
    /// The BSDF at the point.
    pub bsdf: Bsdf<'a>,
    /// Origin of rays leaving on the arriving side (see `Scene::reflection_origin`).
    pub origin: Vec3,
    /// Origin of rays crossing the surface.
    pub behind: Vec3,
    /// Volumes the path is in when it arrives.
    pub media: Media,
}

impl<'a> Vertex<'a> {
    /// The vertex where a ray travelling along `d` meets `surface`.
    pub fn new(cx: Context<'a>, surface: Surface, d: Vec3, media: Media, wl: &mut Wavelengths) -> Self {
        let Context { scene, settings } = cx;
        let wo_world = -d;
        let front = surface.ng.dot(wo_world) > 0.0;
        let mut frame = shading_frame(&surface, front, wo_world);
        let material = &scene.materials[surface.material as usize];
        let outside_ior =
            if scene.features.volumes { media.outside_ior(&scene.materials, surface.material, front) } else { 1.0 };
        // A dispersive interface bends each wavelength its own way, and a thin film reflects
        // each its own share: the hero's is used and the other wavelengths end (pbrt-v4's
        // TerminateSecondary).
        let wavelength =
            wl.hero().filter(|_| (scene.features.dispersion && material.is_dispersive()) || material.is_iridescent());
        let bsdf = material.bsdf(
            scene.refs(),
            &surface,
            (&mut frame, || scene.tangent_space(&surface)),
            (front, outside_ior),
            wavelength,
        );
        if wavelength.is_some() {
            wl.terminate_secondary();
        }
        let origin = scene.reflection_origin(&surface, front, settings.terminator, settings.offset_origins);
        let behind = if bsdf.transmits() {
            scene.reflection_origin(&surface, !front, false, settings.offset_origins)
        } else {
            origin
        };
        Self { wo: frame.to_local(wo_world), surface, front, frame, bsdf, origin, behind, media }
    }

    /// The ray leaving along shading-frame direction `wi`: world direction, origin, and
    /// whether it crosses the surface. None for a transmitted direction that the shading
    /// normal put on the arriving side of the actual surface.
    #[inline]
    pub fn leave(&self, wi: Vec3) -> Option<(Vec3, Vec3, bool)> {
        let d = self.frame.to_world(wi);
        if wi.z >= 0.0 {
            return Some((d, self.origin, false));
        }
        let ng = if self.front { self.surface.ng } else { -self.surface.ng };
        (d.dot(ng) < 0.0).then_some((d, self.behind, true))
    }

    /// The volumes a ray leaving here is in.
    #[inline]
    pub fn media_after(&self, scene: &Scene, crosses: bool) -> Media {
        let mut media = self.media;
        if crosses && scene.features.volumes && scene.materials[self.surface.material as usize].is_volume() {
            media.cross(self.surface.material, self.front);
        }
        media
    }
}

/// Where a path stands when its ray meets a surface: the surface bounces it made (`depth`), the
/// distance its ray has travelled since the last of them (`travelled`, which null surfaces
/// crossed on the way add to) and how that bounce sampled the ray (`last`).
#[derive(Clone, Copy)]
pub struct Bounces {
    /// Surface scattering events so far (the path tracer counts those in media apart).
    pub depth: u32,
    /// Distance from the last scattering vertex to the ray's origin.
    pub travelled: f32,
    /// How the ray was sampled at that vertex (None for a camera ray).
    pub last: Option<Scattered>,
}

/// What a path does after meeting a surface.
pub enum Step {
    /// Scatter at the vertex `arrive` built in the caller's slot.
    Scatter,
    /// No bounce is left, but light passes straight through (a null lobe) with `weight`,
    /// on along `ray` in `media`.
    Pass {
        /// What the null lobe passes on.
        weight: Spectrum,
        /// The ray beyond the surface.
        ray: Ray,
        /// The volumes it is in.
        media: Media,
    },
    /// The path ends.
    End,
}

/// The ray `ray`, in `media`, meets the surface of `hit`: `found` receives the radiance its
/// front emits back along the ray (nothing from behind), weighted against light sampling,
/// and the next step is returned.
/// The vertex is built in the caller's `slot` (so that it is not moved: it is large); the
/// AOV trace records it. At `max_depth` the vertex is built only where light may pass
/// straight through it (or the AOVs still need it).
#[inline(always)]
pub fn arrive<'a>(
    cx: Context<'a>,
    (ray, hit): (&Ray, &Hit),
    media: Media,
    bounces: Bounces,
    (wl, aov): (&mut Wavelengths, &mut AovTrace),
    slot: &mut Option<Vertex<'a>>,
    found: impl FnOnce(Spectrum),
) -> Step {
    let Context { scene, settings } = cx;
    let surface = scene.surface(hit);
    let Bounces { depth, travelled, last } = bounces;
    if surface.ng.dot(ray.d) < 0.0 {
        found(emitted(cx, &surface, -ray.d, travelled + hit.t, last, wl));
    }
    if depth == settings.max_depth && !scene.features.see_through && media.is_empty() {
        if aov.pending() {
            // Its own wavelengths: the path's must not change for the AOVs' sake.
            aov.surface(&Vertex::new(cx, surface, ray.d, media, &mut Wavelengths::Rgb));
        }
        return Step::End;
    }
    let vertex = slot.insert(Vertex::new(cx, surface, ray.d, media, wl));
    aov.surface(vertex);
    if depth < settings.max_depth {
        return Step::Scatter;
    }
    // No bounce is left, but light passing straight through still goes on.
    match vertex.bsdf.null_transmission(vertex.wo).filter(|p| !p.is_black()) {
        Some(weight) => {
            aov.delta(weight, 1.0);
            let next = Ray { o: vertex.behind, d: ray.d, tmax: f32::INFINITY };
            Step::Pass { weight, ray: next, media: vertex.media_after(scene, true) }
        }
        None => Step::End,
    }
}

//! Bidirectional path tracing (Veach 1997, chapter 10; the formulation of pbrt-v4's
//! BDPTIntegrator): per sample a camera subpath and a light subpath, and every way of
//! joining them, s vertices of the light subpath with t of the camera subpath, weighted by
//! multiple importance sampling with the power heuristic. s = 0 is the camera subpath
//! finding an emitter by itself, s = 1 a light sampled for the camera subpath's last vertex
//! (next-event estimation), t = 1 the light subpath's vertex seen by the camera (light
//! tracing), whose contribution lands on the pixel the connection passes through and is
//! splatted there. Light subpaths carry importance: their BSDFs are evaluated in
//! `TransportMode::Importance`, with Veach's correction for shading normals.
//!
//! Both subpaths of a sample carry the same wavelengths (`Wavelengths`: RGB, or the spectral
//! kernel's hero wavelengths, which a dispersive surface on either subpath reduces to the
//! hero alone), so a prism fans a point light's beam into its spectrum; what the sample
//! splats is turned into RGB once both subpaths are traced. In a scattering medium each
//! segment samples a free flight (`media::flight`, as the volumetric path tracer does) and
//! may end at a medium vertex, whose phase function acts as its BSDF and whose density per
//! unit volume is the direction's over the squared distance; the free flights' own densities
//! are left out of every strategy's weight alike (as pbrt-v3 does), so the weights still sum
//! to 1. Light subpaths start in the volumes around their light. Absorbing volumes
//! attenuate every segment and connection;
//! surfaces crossed straight through (null lobes) are passed without a vertex, as the path
//! tracer passes them. Subpaths have at most `max_depth` bounces, and each surface vertex
//! continues its subpath with a probability of its own, its albedo (Russian roulette): a
//! property of the vertex alone, whichever subpath reaches it, so that every density of a
//! vertex sampled from another carries the other's survival, both ways, and the weights stay
//! those of the true densities (SmallVCM folds the continuation probability into its
//! densities likewise). Without it every subpath ran to `max_depth` in a closed room and a
//! sample traced 4x the rays.
//!
//! The densities of a rough transmission are those of the side the path arrives on; the
//! reverse density through a rough refracting interface is the BSDF's density from the
//! other side, built for it.

use super::Context;
use super::aov::AovTrace;
use super::direct::shadow;
use super::kernel::{PathOutput, View};
use super::media::{Media, flight, transmittance};
use super::photons::{Densities, LightVertex, Photons, light_sampler};
use super::settings::Integrator;
use super::vertex::Vertex;
use crate::bsdf::{LobeFlags, TransportMode};
use crate::math::sampler::Sampler;
use crate::medium::{Flight, phase::HenyeyGreenstein};
use crate::scene::{
    Surface,
    geometry::Ray,
    light::{Light, LightTarget},
};
use crate::spectrum::{Spectrum, Wavelengths};
use arrayvec::ArrayVec;
use glam::{UVec2, Vec2, Vec3};

/// Most vertices a subpath keeps (its camera or light vertex and its bounces).
pub(super) const MAX_VERTICES: usize = 34;

/// A subpath's vertices, kept in place (no allocation per sample).
pub(super) type Subpath<'a> = ArrayVec<PathVertex<'a>, MAX_VERTICES>;

/// The deepest paths bidirectional estimators follow (`max_depth` beyond it is refused).
pub const MAX_DEPTH: u32 = MAX_VERTICES as u32 - 2;

/// What a subpath vertex is.
#[derive(Clone, Copy)]
enum Kind<'a> {
    /// The pinhole camera.
    Camera,
    /// A point on a light (or, for light from infinitely far away, its direction), and the
    /// light with its probability of being chosen.
    Light(&'a Light, f32),
    /// A surface scattering event.
    Surface,
    /// Light scattered in a medium, by its phase function, inside the volumes `media`.
    Medium(HenyeyGreenstein, Media),
}

/// A subpath vertex (pbrt-v4's BDPT `Vertex`).
#[derive(Clone, Copy)]
pub(super) struct PathVertex<'a> {
    kind: Kind<'a>,
    /// Position (for a light at infinity, the direction light arrives from, negated).
    pub(super) p: Vec3,
    /// Geometric normal on the side the subpath arrived from (zero off surfaces).
    pub(super) n: Vec3,
    /// The surface vertex: BSDF, frame, ray origins.
    surface: Option<Vertex<'a>>,
    /// Throughput from the subpath's start up to this vertex, over its density.
    pub(super) beta: Spectrum,
    /// Density of this vertex per unit area (per solid angle for a light at infinity) as the
    /// subpath sampled it, and as the other direction would have.
    pdf_fwd: f32,
    pdf_rev: f32,
    /// A delta lobe scattered the subpath here: no connection can end at it.
    delta: bool,
    /// Probability that a subpath, either one, goes on from here (Russian roulette; 1 at the
    /// camera, at lights and in media).
    survival: f32,
    /// A surface that emits towards the side the subpath arrived from.
    emissive: bool,
    /// What the subpath carries: radiance (camera) or importance (light).
    mode: TransportMode,
}

impl<'a> PathVertex<'a> {
    fn is_light(&self) -> bool {
        match self.kind {
            Kind::Light(..) => true,
            Kind::Surface => self.emissive,
            Kind::Camera | Kind::Medium(..) => false,
        }
    }

    /// A light at infinity (directional or environment): its "position" is a direction.
    pub(super) fn is_infinite(&self) -> bool {
        matches!(self.kind, Kind::Light(Light::Directional(_) | Light::Environment, _))
    }

    /// A light whose position or direction is a delta (point, spot, directional).
    pub(super) fn is_delta_light(&self) -> bool {
        matches!(self.kind, Kind::Light(Light::Point(_) | Light::Spot(_) | Light::Directional(_), _))
    }

    /// Whether a connection may end here: not a delta lobe, not a delta direction.
    fn connectible(&self) -> bool {
        match self.kind {
            Kind::Camera | Kind::Medium(..) => true,
            Kind::Light(l, _) => !matches!(l, Light::Directional(_)),
            Kind::Surface => self.surface.is_some_and(|s| s.bsdf.flags().has_non_specular()),
        }
    }

    /// A surface vertex a merge may join: one with a non-delta lobe.
    fn mergeable(&self) -> bool {
        matches!(self.kind, Kind::Surface) && self.connectible()
    }

    /// Its densities, as multiple importance sampling weighs strategies with them.
    pub(super) fn densities(&self) -> Densities {
        Densities { fwd: self.pdf_fwd, rev: self.pdf_rev, delta: self.delta, merge: self.mergeable() }
    }

    /// Converts a solid-angle density at this vertex towards `next` into a density per unit
    /// area at `next` (or leaves it per solid angle for a light at infinity).
    fn convert(&self, pdf: f32, next: &PathVertex) -> f32 {
        if next.is_infinite() { pdf } else { area_density(pdf, self.p, next.p, next.n) }
    }

    /// Unit direction towards `other`; for light at infinity, the direction it comes from.
    fn towards(&self, other: &PathVertex) -> Vec3 {
        if other.is_infinite() { other.p } else { (other.p - self.p).normalize_or_zero() }
    }

    /// The camera or light vertex a subpath starts at.
    fn end(kind: Kind<'a>, p: Vec3, n: Vec3, beta: Spectrum, mode: TransportMode) -> Self {
        PathVertex {
            kind,
            p,
            n,
            surface: None,
            beta,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            delta: false,
            survival: 1.0,
            emissive: false,
            mode,
        }
    }
}

/// Vertex merging's part of a sample: the iteration's light vertices, and the pixel and
/// iteration whose light subpath the sample's connections use.
#[derive(Clone, Copy)]
pub struct Merging<'p> {
    /// The iteration's light vertices.
    pub photons: &'p Photons,
    /// The sample's pixel.
    pub pixel: UVec2,
    /// The iteration (sample index).
    pub index: u64,
}

/// Where a sample's light subpath draws its numbers: apart from the camera subpath's,
/// whose length varies, so that each light vertex's draws are stratified over the pixel.
const LIGHT_DRAWS: u32 = 1 << 12;

/// Where strategy (s, t) draws its numbers (next-event estimation's light and point, a
/// medium's transmittance), eight draws apiece, each at the same place in every sample.
fn connection_draws(s: usize, t: usize) -> u32 {
    (1 << 13) + 8 * (t * (MAX_VERTICES + 1) + s) as u32
}

/// What one BDPT sample adds to its own pixel, and the light-tracing contributions it splats
/// elsewhere (film positions in pixels). With `merging` (vertex connection and merging) the
/// light subpath is the pixel's of the iteration, and every camera vertex also merges with
/// the iteration's light vertices near it; every strategy's weight then counts the merges.
pub fn radiance(
    cx: Context,
    view: &View,
    ray: Ray,
    sampler: &mut Sampler,
    (splat, aovs): (&mut dyn FnMut(Vec2, Spectrum), bool),
    merging: Option<Merging>,
    wl: &mut Wavelengths,
) -> PathOutput {
    let mut out = PathOutput::default();
    let max = (cx.settings.max_depth as usize + 2).min(MAX_VERTICES);
    let (mut camera, mut light) = (Subpath::new(), Subpath::new());
    let mut aov = AovTrace::new(aovs);
    camera_subpath(cx, view, ray, sampler, max, &mut camera, (&mut out, &mut aov, wl));
    match merging {
        Some(m) => light_subpath(cx, &mut light_sampler(cx, m.pixel, m.index), max - 1, &mut light, (&mut out, wl)),
        None => light_subpath(cx, &mut sampler.fork(LIGHT_DRAWS), max - 1, &mut light, (&mut out, wl)),
    }
    // Both subpaths are traced: the wavelengths they carry are final.
    let wl = &*wl;
    let eta = merging.map_or(0.0, |m| m.photons.eta);
    let mut total = Spectrum::ZERO;
    let only = one_strategy(cx).map(|s| s as usize);
    let mut densities = PathDensities::new(&camera, &light);
    for t in 1..=camera.len() {
        for s in 0..=light.len() {
            let depth = s as i64 + t as i64 - 2;
            if (s == 1 && t == 1) || depth < 0 || depth > cx.settings.max_depth as i64 || only.is_some_and(|o| o != s) {
                continue;
            }
            let sampler = &mut sampler.fork(connection_draws(s, t));
            let weights = (&mut densities, eta);
            if let Some((l, film)) = connect(cx, view, (&light, s), (&camera, t), (sampler, weights, wl), &mut out) {
                match film {
                    Some(film) => splat(film, wl.to_rgb(l)),
                    None => total += l,
                }
            }
        }
    }
    if let Some(m) = merging {
        total += merge(cx, &camera, m.photons, &mut densities, wl);
    }
    out.radiance = total;
    out.aov = aov.finish();
    out
}

/// Vertex merging: each camera vertex with a non-delta lobe, past the camera, joined with
/// the iteration's light vertices within the radius (a photon-density estimate with a
/// constant kernel over the disc pi r^2, of which N light paths each count 1 / N), each
/// weighted against every connection and merge that could have made its path (Georgiev et
/// al. 2012, section 4.2).
fn merge(
    cx: Context,
    camera: &[PathVertex],
    photons: &Photons,
    densities: &mut PathDensities,
    wl: &Wavelengths,
) -> Spectrum {
    let mut total = Spectrum::ZERO;
    for t in 2..=camera.len() {
        let z = &camera[t - 1];
        let Some(zs) = z.surface.as_ref().filter(|_| z.mergeable()) else { continue };
        let wo = z.towards(&camera[t - 2]);
        let lo = zs.frame.to_local(wo);
        let mut sum = Spectrum::ZERO;
        photons.near(z.p, |i| {
            let y = &photons.vertices[i];
            let s = y.index as usize + 1;
            if s + t - 3 > cx.settings.max_depth as usize {
                return;
            }
            let prev = &photons.vertices[i - 1];
            let wi = if prev.infinite { prev.p } else { (prev.p - y.p).normalize_or_zero() };
            let li = zs.frame.to_local(wi);
            if li.z == 0.0 {
                return;
            }
            // The BSDF without its cosine: the light vertices' density already counts it.
            let f = wl.reflectance(zs.bsdf.eval(lo, li, TransportMode::Radiance) / li.z.abs());
            if f.is_black() {
                return;
            }
            let light = &photons.vertices[i + 1 - s..=i];
            let weight = merge_weight(cx, (camera, t), light, (wi, wl), (densities, photons.eta));
            // A light path that kept only its hero wavelength counts for it alone.
            let l = f * y.beta * weight;
            sum += if y.hero_only { wl.hero_only(l) } else { l };
        });
        total += z.beta * sum / photons.eta;
    }
    if total.is_finite() { total } else { Spectrum::ZERO }
}

/// The power-heuristic weight of merging camera vertex t - 1 with light vertex s - 1 (the
/// end of `light`, reached along `wi` from its predecessor): the merge's density against
/// the connection (s, t - 1) that ends the light subpath at the merged point, and every
/// other strategy's by the ratios along the path.
fn merge_weight(
    cx: Context,
    (camera, t): (&[PathVertex], usize),
    light: &[LightVertex],
    (wi, wl): (Vec3, &Wavelengths),
    (densities, eta): (&mut PathDensities, f32),
) -> f32 {
    let s = light.len();
    let (z, before) = (&camera[t - 1], &camera[t - 2]);
    let Some(zs) = z.surface.as_ref() else { return 0.0 };
    let PathDensities { cam, merged: lig, .. } = densities;
    let kept = cam[t - 2];
    for (d, v) in lig.iter_mut().zip(light) {
        *d = v.densities;
    }
    let wo = z.towards(before);
    // The merged vertex, reached from the light side, sampling the camera's previous vertex;
    // the camera's density of the merged vertex; the merged vertex sampling the light's.
    cam[t - 2].rev = z.convert(surface_pdf(cx, zs, wi, wo, wl) * z.survival, before);
    lig[s - 1].rev = z.pdf_fwd;
    if s >= 2 {
        let (prev, pdf) = (&light[s - 2], surface_pdf(cx, zs, wo, wi, wl) * z.survival);
        lig[s - 2].rev = if prev.infinite { pdf } else { area_density(pdf, light[s - 1].p, prev.p, prev.n) };
    }
    let connection = if cam[t - 2].delta { 0.0 } else { 1.0 };
    let sum = strategy_sum(&cam[..t - 1], &lig[..s], light[0].delta_light, eta);
    let m = remap0(lig[s - 1].rev) / remap0(lig[s - 1].fwd) * remap0(lig[s - 1].fwd) * eta;
    let w = m * m / (connection + sum);
    cam[t - 2] = kept;
    if w.is_finite() { w } else { 0.0 }
}

/// A solid-angle density `pdf` at `from` converted to one per unit area at `p`, of normal `n`
/// (zero off surfaces).
fn area_density(pdf: f32, from: Vec3, p: Vec3, n: Vec3) -> f32 {
    let w = p - from;
    let dist2 = w.length_squared();
    if dist2 == 0.0 {
        return 0.0;
    }
    let cos = if n == Vec3::ZERO { 1.0 } else { n.dot(w / dist2.sqrt()).abs() };
    pdf * cos / dist2
}

/// The camera subpath: the camera vertex, then a random walk from the camera ray.
fn camera_subpath<'a>(
    cx: Context<'a>,
    view: &View,
    ray: Ray,
    sampler: &mut Sampler,
    max: usize,
    path: &mut Subpath<'a>,
    (out, aov, wl): (&mut PathOutput, &mut AovTrace, &mut Wavelengths),
) {
    let pdf_dir = view.rays.pdf_dir(ray.d);
    path.push(PathVertex::end(Kind::Camera, ray.o, Vec3::ZERO, Spectrum::ONE, TransportMode::Radiance));
    let start = (ray, view.media);
    walk(cx, start, Spectrum::ONE, pdf_dir, TransportMode::Radiance, sampler, max, path, (out, aov, wl));
}

/// The light subpath: a light chosen by power, a ray leaving it, then a random walk.
pub(super) fn light_subpath<'a>(
    cx: Context<'a>,
    sampler: &mut Sampler,
    max: usize,
    path: &mut Subpath<'a>,
    (out, wl): (&mut PathOutput, &mut Wavelengths),
) {
    let (u_select, u_pos, u_dir) = (sampler.next_2d(), sampler.next_2d(), sampler.next_2d());
    if max == 0 {
        return;
    }
    let Some((light, pmf)) = cx.scene.light_sampler.sample(u_select) else { return };
    let Some(le) = light.sample_le(cx.scene, u_pos, u_dir) else { return };
    let cos = le.n.map_or(1.0, |n| n.dot(le.ray.d).abs());
    let p = if matches!(light, Light::Directional(_) | Light::Environment) { -le.ray.d } else { le.ray.o };
    let radiance = wl.illuminant(le.radiance);
    let beta = radiance / (pmf * le.pdf_pos);
    let mut vertex =
        PathVertex::end(Kind::Light(light, pmf), p, le.n.unwrap_or(Vec3::ZERO), beta, TransportMode::Importance);
    vertex.pdf_fwd = light_origin_density(cx, &vertex);
    let infinite = vertex.is_infinite();
    path.push(vertex);
    let beta = radiance * (cos / (pmf * le.pdf_pos * le.pdf_dir));
    let start = path.len();
    // Light paths start in the scattering volumes around the light (light from infinitely
    // far away, and light in scenes without scattering volumes, outside every volume).
    let media =
        if cx.scene.features.media && !infinite { Media::containing(cx.scene, le.ray.o) } else { Media::default() };
    let (from, aov) = ((le.ray, media), &mut AovTrace::off());
    walk(cx, from, beta, le.pdf_dir, TransportMode::Importance, sampler, max, path, (out, aov, wl));
    // From light at infinity the first surface's density is the disc's, projected.
    if infinite && path.len() > start {
        let first = &mut path[start];
        first.pdf_fwd = le.pdf_pos * if first.n == Vec3::ZERO { 1.0 } else { first.n.dot(le.ray.d).abs() };
    }
}

/// A random walk from `ray` in `media` with throughput `beta`, its direction drawn with
/// solid-angle density `pdf`, adding vertices to `path` up to `max` (pbrt-v4's RandomWalk).
#[allow(clippy::too_many_arguments)]
fn walk<'a>(
    cx: Context<'a>,
    (mut ray, mut media): (Ray, Media),
    mut beta: Spectrum,
    mut pdf: f32,
    mode: TransportMode,
    sampler: &mut Sampler,
    max: usize,
    path: &mut Subpath<'a>,
    (out, aov, wl): (&mut PathOutput, &mut AovTrace, &mut Wavelengths),
) {
    let Context { scene, settings } = cx;
    let mut travelled = 0.0f32;
    let mut crossings = 0;
    while path.len() < max {
        out.rays += 1;
        let first = path.len() == 1;
        let hit = scene.intersect(&ray, settings.watertight, first && mode == TransportMode::Radiance);
        // A scattering medium: where it scatters the subpath first, if before the surface.
        if scene.features.media
            && let Some(volume) = media.volume(&scene.materials).filter(|v| v.scatters())
        {
            let length = ray.d.length();
            let t_max = hit.map_or(f32::INFINITY, |h| h.t * length);
            match flight(scene, &volume, (&ray, t_max), beta, sampler, wl) {
                Flight::Pass { weight } => beta *= weight,
                Flight::Scatter { t, weight } => {
                    beta *= weight;
                    let (wo, phase) = (-ray.d / length, volume.phase());
                    aov.medium(volume.albedo, wo);
                    let p = ray.o + ray.d * (t / length);
                    let mut v = PathVertex::end(Kind::Medium(phase, media), p, Vec3::ZERO, beta, mode);
                    v.pdf_fwd = pdf / (travelled + t).powi(2);
                    if path.len() + 1 == max {
                        path.push(v);
                        return;
                    }
                    // The phase function is its own density, and symmetric: the reverse
                    // density is the forward one, and the weight is 1.
                    let next = phase.sample(wo, sampler.next_2d());
                    pdf = next.pdf;
                    path.push(v);
                    let k = path.len() - 2;
                    let (before, last) = path.split_at_mut(k + 1);
                    before[k].pdf_rev = last[0].convert(next.pdf, &before[k]);
                    (ray, travelled) = (Ray { o: p, d: next.wi, tmax: f32::INFINITY }, 0.0);
                    continue;
                }
            }
        } else if let Some(hit) = hit
            && scene.features.volumes
        {
            beta *= transmittance(wl.reflectance(media.sigma_t(&scene.materials)), hit.t * ray.d.length());
        }
        let Some(hit) = hit else {
            // The camera subpath may end on the environment: a vertex of light at infinity.
            if mode == TransportMode::Radiance
                && scene.environment.is_some()
                && let Some(env) = environment_light(cx)
            {
                let pmf = scene.light_sampler.environment_pmf();
                let d = ray.d.normalize();
                let mut v = PathVertex::end(
                    Kind::Light(env, pmf),
                    d,
                    Vec3::ZERO,
                    beta * escaped_transmittance(cx, &media, wl),
                    mode,
                );
                // Per solid angle: a light at infinity has no area.
                v.pdf_fwd = pdf;
                path.push(v);
            }
            return;
        };
        let surface: Surface = scene.surface(&hit);
        let vertex = Vertex::new(cx, surface, ray.d, media, wl);
        aov.surface(&vertex);
        let n = if vertex.front { surface.ng } else { -surface.ng };
        let emissive = vertex.front && scene.materials[surface.material as usize].is_emissive();
        let mut v = PathVertex {
            kind: Kind::Surface,
            p: surface.p,
            n,
            surface: Some(vertex),
            beta,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            delta: false,
            survival: survival(&vertex),
            emissive,
            mode,
        };
        // The distance runs from the last vertex, across the surfaces passed straight through.
        v.pdf_fwd = pdf * n.dot(ray.d).abs() / (travelled + hit.t * ray.d.length()).powi(2);
        if path.len() + 1 == max {
            path.push(v);
            return;
        }
        let (u_lobe, u, u_rr) = (sampler.next_1d(), sampler.next_2d(), sampler.next_1d());
        let Some(bs) = vertex.bsdf.sample(vertex.wo, u_lobe, u, mode) else {
            path.push(v);
            return;
        };
        let Some((d, origin, crosses)) = vertex.leave(bs.wi) else {
            path.push(v);
            return;
        };
        aov.delta(bs.weight, bs.eta);
        if bs.flags.contains(LobeFlags::NULL) {
            crossings += 1;
            if crossings > 64 {
                return;
            }
            beta *= wl.reflectance(bs.weight);
            travelled += hit.t * ray.d.length();
            media = vertex.media_after(scene, crosses);
            ray = Ray { o: origin, d, tmax: f32::INFINITY };
            continue;
        }
        travelled = 0.0;
        let wo = vertex.frame.to_world(vertex.wo);
        beta *= wl.reflectance(bs.weight) / v.survival;
        if mode == TransportMode::Importance {
            beta *= shading_correction(&vertex, wo, d);
        }
        if bs.is_specular() {
            v.delta = true;
            pdf = 0.0;
        } else {
            pdf = bs.pdf * v.survival;
        }
        let rev = if v.delta { 0.0 } else { surface_pdf(cx, &vertex, d, wo, wl) * v.survival };
        let ends = u_rr >= v.survival;
        path.push(v);
        let k = path.len() - 2;
        let (before, last) = path.split_at_mut(k + 1);
        before[k].pdf_rev = last[0].convert(rev, &before[k]);
        media = vertex.media_after(scene, crosses);
        ray = Ray { o: origin, d, tmax: f32::INFINITY };
        if ends || beta.is_black() {
            return;
        }
    }
}

/// Probability that a subpath goes on from surface vertex `v`: its albedo's largest
/// component (at normal incidence, so that it is the same whichever side and direction a
/// subpath arrives from), kept from 0.1 (a black glossy coat still reflects) to 0.995 (a
/// clear glass ball's internal reflections still end).
fn survival(v: &Vertex) -> f32 {
    v.bsdf.albedo(Vec3::Z).max_element().clamp(0.1, 0.995)
}

/// The environment light (its map is the scene's).
static ENVIRONMENT: Light = Light::Environment;

/// The environment, if the light sampler may choose it.
fn environment_light(cx: Context) -> Option<&'static Light> {
    (cx.scene.light_sampler.environment_pmf() > 0.0).then_some(&ENVIRONMENT)
}

/// What the volume a ray leaves the scene in lets through (nothing for an absorbing one).
fn escaped_transmittance(cx: Context, media: &Media, wl: &Wavelengths) -> Spectrum {
    if cx.scene.features.volumes {
        transmittance(wl.reflectance(media.sigma_t(&cx.scene.materials)), f32::INFINITY)
    } else {
        Spectrum::ONE
    }
}

/// Veach's correction of importance transported with shading normals (thesis eq. 5.17):
/// |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|), for world directions `wo` (back along the path)
/// and `wi` (onwards), bounded by `MAX_SHADING_CORRECTION`.
fn shading_correction(v: &Vertex, wo: Vec3, wi: Vec3) -> f32 {
    let (ns, ng) = (v.frame.n, v.surface.ng);
    let den = wo.dot(ng).abs() * wi.dot(ns).abs();
    if den == 0.0 { 0.0 } else { (wo.dot(ns).abs() * wi.dot(ng).abs() / den).min(MAX_SHADING_CORRECTION) }
}

/// Bound of the shading-normal correction. It grows without bound as light arrives grazing
/// the geometric surface while the shading normal faces it, and there single light-traced
/// samples carried the image: GlassVaseFlowers' thin petals, 128x128 at 1,312 spp, RMSE 0.62
/// against a path-traced reference with the correction unbounded, 0.044 bounded at 10 or at
/// 2 alike. Bounded, BDPT is biased only for light within a few degrees of such a surface.
const MAX_SHADING_CORRECTION: f32 = 10.0;

/// Solid-angle density with which the BSDF at `v` samples world direction `wi` for light
/// arriving from world direction `wo` (both unit, pointing away): from the side `wo` lies
/// on, the vertex rebuilt from that side (at the path's hero wavelength `wl`) where it is
/// not the side the path arrived on.
fn surface_pdf(cx: Context, v: &Vertex, wo: Vec3, wi: Vec3, wl: &Wavelengths) -> f32 {
    let (lo, li) = (v.frame.to_local(wo), v.frame.to_local(wi));
    if lo.z > 0.0 {
        return v.bsdf.pdf(lo, li);
    }
    if !v.bsdf.transmits() {
        return 0.0;
    }
    let other = Vertex::new(cx, v.surface, -wo, v.media_after(cx.scene, true), &mut wl.clone());
    other.bsdf.pdf(other.frame.to_local(wo), other.frame.to_local(wi))
}

/// f |cos| at `v` for light between world directions `wo` (back along the subpath) and `wi`
/// (towards the connection), in `mode`, with the shading-normal correction for importance,
/// at the wavelengths `wl`; and `surface_pdf` of the same directions, which the BSDF
/// evaluates with f.
fn surface_f(
    cx: Context,
    v: &Vertex,
    (wo, wi): (Vec3, Vec3),
    mode: TransportMode,
    wl: &Wavelengths,
) -> (Spectrum, f32) {
    let (lo, li) = (v.frame.to_local(wo), v.frame.to_local(wi));
    let (f, pdf) = v.bsdf.eval_pdf(lo, li, mode);
    let pdf = if lo.z > 0.0 { pdf } else { surface_pdf(cx, v, wo, wi, wl) };
    let f = wl.reflectance(f);
    (if mode == TransportMode::Importance { f * shading_correction(v, wo, wi) } else { f }, pdf)
}

/// The density (per unit area at `next`, or per solid angle for light at infinity) with
/// which vertex `v`, reached from `prev`, would sample `next` (at the hero wavelength `wl`).
fn density(
    (cx, view, wl): (Context, &View, &Wavelengths),
    v: &PathVertex,
    prev: Option<&PathVertex>,
    next: &PathVertex,
) -> f32 {
    match v.kind {
        Kind::Camera => v.convert(view.rays.pdf_dir(v.towards(next)), next),
        Kind::Light(..) => light_density(cx, v, next),
        Kind::Medium(phase, _) => match prev {
            Some(prev) => v.convert(phase.eval(v.towards(prev), v.towards(next)), next),
            None => 0.0,
        },
        Kind::Surface => {
            let (Some(s), Some(prev)) = (v.surface.as_ref(), prev) else { return 0.0 };
            v.convert(surface_pdf(cx, s, v.towards(prev), v.towards(next), wl) * v.survival, next)
        }
    }
}

/// The density with which light vertex (or emitting surface) `v` would emit towards `next`
/// (pbrt-v4's `PdfLight`), per unit area at `next`.
fn light_density(cx: Context, v: &PathVertex, next: &PathVertex) -> f32 {
    match v.kind {
        Kind::Light(light, _) if v.is_infinite() => {
            // From infinitely far: the disc's density, projected onto the surface.
            let (pdf_pos, _) = light.pdf_le(cx.scene, v.n, -v.p);
            pdf_pos * if next.n == Vec3::ZERO { 1.0 } else { next.n.dot(-v.p).abs() }
        }
        Kind::Light(light, _) => v.convert(light.pdf_le(cx.scene, v.n, v.towards(next)).1, next),
        // An emitting surface emits cosine-distributed (`TriangleLight::sample_le`).
        Kind::Surface => {
            let cos = v.n.dot(v.towards(next));
            if cos > 0.0 { v.convert(crate::math::warp::cos_hemisphere_pdf(cos), next) } else { 0.0 }
        }
        Kind::Camera | Kind::Medium(..) => 0.0,
    }
}

/// The density per unit area (per solid angle at infinity) with which a light subpath
/// starts at `v`, a point of a light (pbrt-v4's `PdfLightOrigin`).
fn light_origin_density(cx: Context, v: &PathVertex) -> f32 {
    match v.kind {
        Kind::Light(light, pmf) => match light {
            Light::Environment => {
                let env = cx.scene.environment.as_ref().map_or(0.0, |e| e.pdf(v.p));
                pmf * env
            }
            _ => pmf * light.pdf_le(cx.scene, v.n, v.n).0,
        },
        Kind::Surface => {
            let tri = v.surface.map_or(0, |s| s.surface.tri);
            let pick = cx.scene.light_sampler.triangle_pmf(tri);
            let area = cx.scene.light_sampler.triangle_area(tri);
            if area > 0.0 { pick / area } else { 0.0 }
        }
        Kind::Camera | Kind::Medium(..) => 0.0,
    }
}

/// Radiance the emitting vertex `v` sends towards `w` (unit): an emitting surface's front,
/// or the environment.
fn emitted(cx: Context, v: &PathVertex, w: Vec3, wl: &Wavelengths) -> Spectrum {
    match v.kind {
        Kind::Light(Light::Environment, _) => {
            cx.scene.environment.as_ref().map_or(Spectrum::ZERO, |e| wl.illuminant(e.radiance(v.p)))
        }
        Kind::Surface => match v.surface {
            Some(s) if s.front && v.n.dot(w) > 0.0 => wl.illuminant(cx.scene.emission(&s.surface)),
            _ => Spectrum::ZERO,
        },
        _ => Spectrum::ZERO,
    }
}

/// The strategy (s, t): its contribution and, for light tracing (t = 1), the film position
/// it lands on; None where it contributes nothing.
fn connect(
    cx: Context,
    view: &View,
    (light, s): (&[PathVertex], usize),
    (camera, t): (&[PathVertex], usize),
    (sampler, (densities, eta), wl): (&mut Sampler, (&mut PathDensities, f32), &Wavelengths),
    out: &mut PathOutput,
) -> Option<(Spectrum, Option<Vec2>)> {
    let pt = &camera[t - 1];
    if t > 1 && s != 0 && pt.is_infinite() {
        return None;
    }
    let mut sampled: Option<PathVertex> = None;
    let mut film = None;
    // The connection's ends' densities of each other's directions, where evaluating f gave them.
    let mut known = (None, None);
    let l = if s == 0 {
        // The camera subpath found a light by itself.
        if !pt.is_light() {
            return None;
        }
        pt.beta * emitted(cx, pt, pt.towards(&camera[t - 2]), wl)
    } else if t == 1 {
        // Light tracing: the camera sees the light subpath's vertex s - 1.
        let qs = &light[s - 1];
        if !qs.connectible() || qs.is_infinite() {
            return None;
        }
        let origin = view.rays.origin();
        let to_camera = origin - qs.p;
        let dist2 = to_camera.length_squared();
        let wi = to_camera / dist2.sqrt();
        let (we, position) = view.rays.importance(-wi)?;
        // The camera does not see the back of a single-sided surface.
        if let Some(v) = qs.surface
            && cx.scene.features.cutouts
            && cx.scene.materials[v.surface.material as usize].culled_from(-wi, v.surface.ng)
        {
            return None;
        }
        let pdf = dist2 / view.rays.cos(-wi);
        let camera_vertex =
            PathVertex::end(Kind::Camera, origin, Vec3::ZERO, Spectrum::splat(we / pdf), TransportMode::Radiance);
        let (f, pdf_qs) = vertex_f(cx, qs, light.get(s.wrapping_sub(2)), wi, wl)?;
        known = (None, Some(pdf_qs));
        let l = qs.beta * f * camera_vertex.beta;
        if l.is_black() {
            return None;
        }
        let tr = visibility(cx, qs, (origin, LightTarget::Point(origin)), (sampler, wl), out)?;
        sampled = Some(camera_vertex);
        film = Some(position);
        l * tr
    } else if s == 1 {
        // Next-event estimation from the camera subpath's vertex t - 1.
        if !pt.connectible() || !matches!(pt.kind, Kind::Surface | Kind::Medium(..)) {
            return None;
        }
        let (u_select, u) = (sampler.next_2d(), sampler.next_2d());
        let ls = cx.scene.sample_li(pt.p, u_select, u)?;
        // The light the sample chose (the same uniforms choose it again).
        let (light, pmf) = cx.scene.light_sampler.sample(u_select)?;
        let (p, n) = match ls.target {
            LightTarget::Surface { p, n, .. } => (p, n),
            LightTarget::Point(p) => (p, Vec3::ZERO),
            LightTarget::Infinite => (ls.wi, Vec3::ZERO),
        };
        let radiance = wl.illuminant(ls.radiance);
        let mut v = PathVertex::end(Kind::Light(light, pmf), p, n, radiance / ls.pdf, TransportMode::Importance);
        v.pdf_fwd = light_origin_density(cx, &v);
        let (f, pdf_pt) = vertex_f(cx, pt, Some(&camera[t - 2]), ls.wi, wl)?;
        known = (Some(pdf_pt), None);
        let l = pt.beta * f * v.beta;
        if l.is_black() {
            return None;
        }
        let tr = visibility(cx, pt, (pt.p + ls.wi, ls.target), (sampler, wl), out)?;
        sampled = Some(v);
        l * tr
    } else {
        // Both subpaths joined by a segment.
        let qs = &light[s - 1];
        if !qs.connectible() || !pt.connectible() || qs.is_infinite() {
            return None;
        }
        let d = qs.p - pt.p;
        let dist2 = d.length_squared();
        let w = d / dist2.sqrt();
        let (f_pt, pdf_pt) = vertex_f(cx, pt, Some(&camera[t - 2]), w, wl)?;
        let (f_qs, pdf_qs) = vertex_f(cx, qs, light.get(s.wrapping_sub(2)), -w, wl)?;
        known = (Some(pdf_pt), Some(pdf_qs));
        let l = qs.beta * f_qs * f_pt * pt.beta / dist2;
        if l.is_black() {
            return None;
        }
        let target = match qs.surface {
            Some(v) => LightTarget::Surface { p: v.surface.p, error: v.surface.p_error, n: qs.n },
            None => LightTarget::Point(qs.p),
        };
        l * visibility(cx, pt, (qs.p, target), (sampler, wl), out)?
    };
    if l.is_black() || !l.is_finite() {
        return None;
    }
    if one_strategy(cx).is_some() {
        return Some((l, film));
    }
    let weight = mis_weight((cx, view, wl), (light, s), (camera, t), (sampled.as_ref(), known), (densities, eta));
    Some((l * weight, film))
}

/// The one strategy (its number of light vertices) bidirectional path tracing shows alone
/// and unweighted, if the settings ask for it.
fn one_strategy(cx: Context) -> Option<u32> {
    cx.settings.strategy.filter(|_| cx.settings.integrator == Integrator::Bdpt)
}

/// f |cos| at the surface or medium vertex `v`, reached from `prev`, towards unit `w`, as its
/// subpath carries light at the wavelengths `wl`, and the density (per solid angle, its
/// survival included) with which `v` samples `w` from there; None where f is zero.
fn vertex_f(
    cx: Context,
    v: &PathVertex,
    prev: Option<&PathVertex>,
    w: Vec3,
    wl: &Wavelengths,
) -> Option<(Spectrum, f32)> {
    let wo = v.towards(prev?);
    let (f, pdf) = match (v.kind, v.surface.as_ref()) {
        (Kind::Medium(phase, _), _) => {
            let p = phase.eval(wo, w);
            (Spectrum::splat(p), p)
        }
        (_, Some(s)) => {
            let (f, pdf) = surface_f(cx, s, (wo, w), v.mode, wl);
            (f, pdf * v.survival)
        }
        _ => return None,
    };
    (!f.is_black()).then_some((f, pdf))
}

/// Transmittance of the segment from vertex `from` to `end` (`target`), or None if
/// something blocks it.
fn visibility(
    cx: Context,
    from: &PathVertex,
    (end, target): (Vec3, LightTarget),
    (sampler, wl): (&mut Sampler, &Wavelengths),
    out: &mut PathOutput,
) -> Option<Spectrum> {
    let w = (end - from.p).normalize_or_zero();
    let (origin, media) = match (from.surface, from.kind) {
        (Some(v), _) => {
            let (_, origin, crosses) = v.leave(v.frame.to_local(w))?;
            (origin, v.media_after(cx.scene, crosses))
        }
        (None, Kind::Medium(_, media)) => (from.p, media),
        (None, _) => (from.p, Media::default()),
    };
    out.rays += 1;
    out.shadow_rays += 1;
    let tr = shadow(cx, (origin, w, target), media, sampler, wl);
    (!tr.is_black()).then_some(tr)
}

/// 0 mapped to 1, for density ratios where a delta's density is 0.
fn remap0(x: f32) -> f32 {
    if x != 0.0 { x } else { 1.0 }
}

/// The power-heuristic weight of strategy (s, t) (pbrt-v4's `MISWeight`, squared ratios):
/// the densities of the connection's end vertices and their predecessors are recomputed
/// for the connection, and each other strategy's density is reached by the ratios of
/// reverse to forward densities along the path; with vertex merging (`eta` > 0) the merges
/// at every vertex count too.
fn mis_weight(
    (cx, view, wl): (Context, &View, &Wavelengths),
    (light, s): (&[PathVertex], usize),
    (camera, t): (&[PathVertex], usize),
    (sampled, known): (Option<&PathVertex>, (Option<f32>, Option<f32>)),
    (densities, eta): (&mut PathDensities, f32),
) -> f32 {
    if s + t == 2 {
        return 1.0;
    }
    // The densities this strategy sees, per vertex: the subpaths' own but at the
    // connection's ends and their predecessors, which are put back afterwards.
    let PathDensities { cam, lig, .. } = densities;
    let kept = (cam[t - 1], cam[t.saturating_sub(2)], lig[s.saturating_sub(1)], lig[s.saturating_sub(2)]);
    let mut qs = (s > 0).then(|| &light[s - 1]);
    let mut pt = &camera[t - 1];
    if s == 1 {
        qs = sampled;
        if let Some(q) = qs {
            lig[0] = Densities { delta: false, ..q.densities() };
        }
    } else if t == 1 {
        pt = sampled.unwrap_or(pt);
        cam[0] = Densities { delta: false, ..pt.densities() };
    }
    // The connection's ends are not deltas.
    cam[t - 1].delta = false;
    if s > 0 {
        lig[s - 1].delta = false;
    }
    // pt's reverse density: qs sampling pt (or the light subpath starting at pt).
    cam[t - 1].rev = match (qs, known.1) {
        (Some(q), Some(pdf)) => q.convert(pdf, pt),
        (Some(q), None) => density((cx, view, wl), q, if s > 1 { Some(&light[s - 2]) } else { None }, pt),
        (None, _) => light_origin_density(cx, pt),
    };
    // pt's predecessor, from pt.
    if t > 1 {
        cam[t - 2].rev = match qs {
            Some(q) => density((cx, view, wl), pt, Some(q), &camera[t - 2]),
            None => light_density(cx, pt, &camera[t - 2]),
        };
    }
    if let Some(q) = qs {
        // qs's reverse density: pt sampling qs; and qs's predecessor, from qs.
        lig[s - 1].rev = match known.0 {
            Some(pdf) => pt.convert(pdf, q),
            None => density((cx, view, wl), pt, if t > 1 { Some(&camera[t - 2]) } else { None }, q),
        };
        if s > 1 {
            lig[s - 2].rev = density((cx, view, wl), q, Some(pt), &light[s - 2]);
        }
    }
    let origin_delta = match (s, qs) {
        (0, _) => false,
        (1, Some(q)) => q.is_delta_light(),
        _ => light[0].is_delta_light(),
    };
    let w = 1.0 / (1.0 + strategy_sum(&cam[..t], &lig[..s], origin_delta, eta));
    // Each was kept before any changed, so where two are one vertex both put back the same.
    (cam[t - 1], cam[t.saturating_sub(2)]) = (kept.0, kept.1);
    (lig[s.saturating_sub(1)], lig[s.saturating_sub(2)]) = (kept.2, kept.3);
    if w.is_finite() { w } else { 0.0 }
}

/// Every vertex's densities of a sample's two subpaths, as its strategies' weights start
/// from them (each then changes the few its connection changes, and puts them back), and
/// room for the light subpath of a merge.
struct PathDensities {
    cam: [Densities; MAX_VERTICES],
    lig: [Densities; MAX_VERTICES],
    merged: [Densities; MAX_VERTICES],
}

impl PathDensities {
    fn new(camera: &[PathVertex], light: &[PathVertex]) -> Self {
        let mut d = PathDensities {
            cam: [Densities::default(); MAX_VERTICES],
            lig: [Densities::default(); MAX_VERTICES],
            merged: [Densities::default(); MAX_VERTICES],
        };
        for (d, v) in d.cam.iter_mut().zip(camera) {
            *d = v.densities();
        }
        for (d, v) in d.lig.iter_mut().zip(light) {
            *d = v.densities();
        }
        d
    }
}

/// The sum, over every strategy but the one whose subpaths end at `cam` and `lig`'s last
/// vertices, of the squared ratio of its density to that one's: each connection (s', t')
/// by the products of reverse over forward densities walking the connection along the
/// path (pbrt-v4's `MISWeight`), and, where `eta` > 0, each merge at a vertex with a
/// non-delta lobe (past the light and the camera): the connection whose camera subpath ends
/// there, times the light subpath's density of the vertex and eta (Georgiev et al. 2012,
/// eq. 11). `origin_delta`: the light subpath starts on a delta light, which no camera
/// subpath can reach.
fn strategy_sum(cam: &[Densities], lig: &[Densities], origin_delta: bool, eta: f32) -> f32 {
    let mut sum = 0.0f32;
    let mut ri = 1.0f32;
    // Without a light subpath the camera's last vertex is the light's, where nothing merges.
    let last = if lig.is_empty() { cam.len() - 1 } else { cam.len() };
    for i in (1..cam.len()).rev() {
        if eta > 0.0 && cam[i].merge && i < last {
            let m = ri * remap0(cam[i].rev) * eta;
            sum += m * m;
        }
        ri *= remap0(cam[i].rev) / remap0(cam[i].fwd);
        if !cam[i].delta && !cam[i - 1].delta {
            sum += ri * ri;
        }
    }
    ri = 1.0;
    for i in (0..lig.len()).rev() {
        ri *= remap0(lig[i].rev) / remap0(lig[i].fwd);
        if eta > 0.0 && i > 0 && lig[i].merge {
            let m = ri * remap0(lig[i].fwd) * eta;
            sum += m * m;
        }
        let delta_before = if i > 0 { lig[i - 1].delta } else { origin_delta };
        if !lig[i].delta && !delta_before {
            sum += ri * ri;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The weights of every connection and merge that can make one path, computed as the
    /// integrator computes them, each with itself as the reference.
    fn weights(pl: &[f32], pc: &[f32], delta: &[bool], origin_delta: bool, eta: f32) -> Vec<f32> {
        let n = pl.len();
        // As vertices flag themselves: every surface vertex without a delta lobe, the light's
        // (an emitting surface) included; the camera's not.
        let merge = |i: usize| i + 1 < n && !delta[i];
        let light = |i: usize| Densities { fwd: pl[i], rev: pc[i], delta: delta[i], merge: merge(i) };
        let camera = |i: usize| Densities { fwd: pc[i], rev: pl[i], delta: delta[i], merge: merge(i) };
        // Subpaths of strategy s: the light's x_0..x_{s-1}, the camera's x_{n-1}..x_s.
        let split = |s: usize| -> (Vec<Densities>, Vec<Densities>) {
            ((0..s).map(light).collect(), (s..n).rev().map(camera).collect())
        };
        let mut w = Vec::new();
        // Connections (s, t), t >= 1, their ends not deltas (s = 0: the light is hit).
        for s in 0..n {
            let ends_ok = !delta[s] && if s == 0 { !origin_delta } else { !delta[s - 1] };
            if !ends_ok {
                continue;
            }
            let (mut lig, mut cam) = split(s);
            if let Some(l) = lig.last_mut() {
                l.delta = false;
            }
            cam.last_mut().unwrap().delta = false;
            w.push(1.0 / (1.0 + strategy_sum(&cam, &lig, origin_delta, eta)));
        }
        // Merges at x_j: against the connection whose light subpath ends there.
        for j in (1..n - 1).filter(|&j| eta > 0.0 && merge(j)) {
            let (lig, cam) = split(j + 1);
            let connection = if cam.last().unwrap().delta { 0.0 } else { 1.0 };
            let m = remap0(pc[j]) / remap0(pl[j]) * remap0(pl[j]) * eta;
            w.push(m * m / (connection + strategy_sum(&cam, &lig, origin_delta, eta)));
        }
        w
    }

    #[test]
    fn the_weights_of_every_strategy_of_a_path_sum_to_one() {
        let mut rng = rand_pcg::Pcg32::new(7, 1);
        let mut next = || (rand_core::RngCore::next_u32(&mut rng) >> 8) as f32 / (1u32 << 24) as f32;
        for case in 0..2000 {
            let n = 3 + case % 6;
            let delta: Vec<bool> = (0..n).map(|i| i > 0 && i + 1 < n && next() < 0.3).collect();
            let origin_delta = next() < 0.3;
            let mut pl: Vec<f32> = (0..n).map(|_| 0.05 + 4.0 * next()).collect();
            let mut pc: Vec<f32> = (0..n).map(|_| 0.05 + 4.0 * next()).collect();
            // A delta lobe's neighbours are sampled through it with no finite density.
            for i in (1..n - 1).filter(|&i| delta[i]) {
                pl[i + 1] = 0.0;
                pc[i - 1] = 0.0;
            }
            for eta in [0.0, 0.01 + 5.0 * next()] {
                let w = weights(&pl, &pc, &delta, origin_delta, eta);
                let sum: f32 = w.iter().sum();
                if w.is_empty() {
                    continue;
                }
                assert!((sum - 1.0).abs() < 1e-4, "case {case}, eta {eta}: weights {w:?} sum to {sum}");
            }
        }
    }
}

//! The path tracer (textbook section 10.7): one BSDF-sampled direction per bounce, with
//! importance sampling (10.8), explicit light sampling (10.9) or MIS, and Russian roulette.
//! Monomorphised over the scene's `Features`, so absent effects cost nothing.

use super::media::{Media, transmittance};
use super::nan::{NanCause, check};
use super::settings::{Integrator, LightSampling, PixelSampling, Settings};
use crate::bsdf::{Bsdf, Strategy};
use crate::math::{
    float::{interpolation_error, offset_ray_origin},
    frame::Frame,
    sampler::{Sampler, hash3},
    warp,
};
use crate::scene::{
    Features, Scene, Surface,
    camera::RayGenerator,
    geometry::{Hit, Ray},
    light::{LightRef, PunctualKind},
    shading::bend_normal,
};
use glam::{UVec2, Vec2, Vec3};

/// The radiance one pixel sample carries, and how many rays it traced.
#[derive(Clone, Copy, Debug)]
pub struct PathOutput {
    /// Radiance estimate (may be NaN or infinite if something went wrong; the film drops it).
    pub radiance: Vec3,
    /// Camera, bounce and shadow rays traced.
    pub rays: u32,
}

/// One pixel sample: (scene, settings, camera rays, pixel, sample index) -> radiance.
/// A pure function of its arguments.
pub type SampleFn = fn(&Scene, &Settings, &RayGenerator, UVec2, u64) -> PathOutput;

macro_rules! kernels {
    ($f:expr; $(($e:literal, $p:literal, $t:literal, $g:literal)),* $(,)?) => {
        match ($f.emissive, $f.punctual, $f.textures, $f.glossy) {
            $(($e, $p, $t, $g) => sample_pixel::<$e, $p, $t, $g> as SampleFn,)*
        }
    };
}

/// The path-tracing kernel specialised for a feature set. `P` covers every light that is
/// not an emissive triangle: punctual lights and the environment.
pub fn kernel(features: Features) -> SampleFn {
    let features = Features { punctual: features.punctual || features.environment, ..features };
    kernels!(features;
        (false, false, false, false), (false, false, false, true),
        (false, false, true, false), (false, false, true, true),
        (false, true, false, false), (false, true, false, true),
        (false, true, true, false), (false, true, true, true),
        (true, false, false, false), (true, false, false, true),
        (true, false, true, false), (true, false, true, true),
        (true, true, false, false), (true, true, false, true),
        (true, true, true, false), (true, true, true, true),
    )
}

/// Offset of a sample inside its pixel, in [0, 1)^2, per the pixel-sampling mode.
fn pixel_offset(settings: &Settings, pixel: UVec2, index: u64, sampler: &mut Sampler) -> Vec2 {
    let jitter = sampler.next_2d();
    let k = settings.strata.max(1) as u64;
    let cells = k * k;
    let cell = |c: u64| Vec2::new((c % k) as f32, (c / k) as f32);
    match settings.pixel_sampling {
        PixelSampling::Random => jitter,
        PixelSampling::Stratified => {
            let round = index / cells;
            let rotation = hash3((pixel.x as u64) << 32 | pixel.y as u64, round, settings.seed) % cells;
            (cell((index % cells + rotation) % cells) + jitter) / k as f32
        }
        PixelSampling::Grid => (cell(index % cells) + Vec2::splat(0.5)) / k as f32,
    }
}

fn sample_pixel<const E: bool, const P: bool, const T: bool, const G: bool>(
    scene: &Scene,
    settings: &Settings,
    camera: &RayGenerator,
    pixel: UVec2,
    index: u64,
) -> PathOutput {
    let mut sampler = Sampler::of_kind(settings.sampler, pixel, index, settings.seed);
    let film = pixel.as_vec2() + pixel_offset(settings, pixel, index, &mut sampler);
    let ray = camera.ray(film);
    check(NanCause::CameraRay, ray.o + ray.d);
    let mut out = match settings.integrator {
        Integrator::Path => radiance::<E, P, T, G>(scene, settings, ray, &mut sampler),
        Integrator::Distribution => super::drt::radiance::<E, P, T, G>(scene, settings, ray, &mut sampler),
    };
    if let Some(c) = settings.firefly_clamp {
        let m = out.radiance.max_element();
        if m > c {
            out.radiance *= c / m;
        }
    }
    out
}

/// Power heuristic with exponent 2 (Veach 1997): weight of the strategy with pdf `a`.
pub(super) fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// Shading frame at `surface` for a ray arriving from `wo`, turned to the side it arrived
/// from (`front`; every surface is shaded two-sided). A shading normal on the other side of
/// the surface falls back to the geometric one, and one that would reflect the view below
/// the surface is bent (`bend_normal`).
pub(super) fn shading_frame(surface: &Surface, front: bool, wo: Vec3) -> Frame {
    let ng = if front { surface.ng } else { -surface.ng };
    let ns = if front { surface.ns } else { -surface.ns };
    Frame::from_normal(bend_normal(ng, wo, if ns.dot(ng) > 0.0 { ns } else { ng }))
}

/// Where the previous bounce sampled its direction from, for MIS on emitters hit later.
#[derive(Clone, Copy)]
struct PrevBounce {
    pdf: f32,
}

/// Radiance emitted towards `wo` by the front of `surface`, reached at distance `t` by a
/// ray the previous bounce sampled with density `prev_pdf` (None for camera rays),
/// weighted so that light sampling at that bounce does not count it twice.
pub(super) fn emitted<const T: bool>(
    scene: &Scene,
    settings: &Settings,
    surface: &Surface,
    wo: Vec3,
    t: f32,
    prev_pdf: Option<f32>,
) -> Vec3 {
    let material = &scene.materials[surface.material as usize];
    if !material.is_emissive() {
        return Vec3::ZERO;
    }
    let le = material.emission::<T>(&scene.textures, &scene.images, surface);
    let weight = match (settings.light_sampling, prev_pdf) {
        (LightSampling::Off, _) | (_, None) => 1.0,
        (LightSampling::Explicit, Some(_)) => 0.0,
        (LightSampling::Mis, Some(pdf)) => {
            let cos_light = surface.ng.dot(wo);
            let area = scene.triangle_area(surface.tri);
            let pdf_light = scene.light_sampler.triangle_pmf(surface.tri) * t * t / (cos_light * area);
            power_heuristic(pdf, pdf_light)
        }
    };
    check(NanCause::Emission, le);
    le * weight
}

/// Radiance from the environment along unit direction `d` of a ray that left the scene,
/// sampled by the previous bounce with density `prev_pdf` (None for camera rays), weighted
/// as `emitted` weights emitters, and attenuated by the volume the ray was in.
pub(super) fn escaped(scene: &Scene, settings: &Settings, d: Vec3, prev_pdf: Option<f32>, media: &Media) -> Vec3 {
    let Some(env) = &scene.environment else { return Vec3::ZERO };
    let weight = match (settings.light_sampling, prev_pdf) {
        (LightSampling::Off, _) | (_, None) => 1.0,
        (LightSampling::Explicit, Some(_)) => 0.0,
        (LightSampling::Mis, Some(pdf)) => power_heuristic(pdf, scene.light_sampler.environment_pmf() * env.pdf(d)),
    };
    if weight == 0.0 {
        return Vec3::ZERO;
    }
    let le = env.radiance(d) * weight;
    check(NanCause::Emission, le);
    if scene.features.volumes { le * transmittance(media.sigma_a(&scene.materials), f32::INFINITY) } else { le }
}

/// A scattering event: the surface, its shading frame turned to the side the path arrived
/// from, the BSDF there, where rays leave from, and the volumes the path is in.
pub(super) struct Vertex<'a> {
    pub(super) surface: Surface,
    /// The path arrived on the front (glTF winding) side.
    pub(super) front: bool,
    pub(super) frame: Frame,
    /// Direction back along the arriving ray, in the shading frame.
    pub(super) wo: Vec3,
    pub(super) bsdf: Bsdf<'a>,
    pub(super) strategy: Strategy,
    /// Origin of rays leaving on the arriving side (see `Scene::reflection_origin`).
    pub(super) origin: Vec3,
    /// Origin of rays crossing the surface.
    pub(super) behind: Vec3,
    /// Volumes the path is in when it arrives.
    pub(super) media: Media,
}

impl<'a> Vertex<'a> {
    /// The vertex where a ray travelling along `d` meets `surface`.
    pub(super) fn new<const T: bool, const G: bool>(
        scene: &'a Scene,
        settings: &Settings,
        surface: Surface,
        d: Vec3,
        media: Media,
    ) -> Self {
        let wo_world = -d;
        let front = surface.ng.dot(wo_world) > 0.0;
        let frame = shading_frame(&surface, front, wo_world);
        let material = &scene.materials[surface.material as usize];
        let outside_ior =
            if scene.features.volumes { media.outside_ior(&scene.materials, surface.material, front) } else { 1.0 };
        let bsdf = material.bsdf::<T, G>(&scene.textures, &scene.images, &surface, front, outside_ior);
        let robust = settings.robustness;
        let origin = scene.reflection_origin(&surface, front, robust.terminator, robust.offset_origins);
        let behind = if bsdf.transmits() {
            scene.reflection_origin(&surface, !front, false, robust.offset_origins)
        } else {
            origin
        };
        let strategy = if settings.importance_sampling { Strategy::Importance } else { Strategy::Uniform };
        Self { wo: frame.to_local(wo_world), surface, front, frame, bsdf, strategy, origin, behind, media }
    }

    /// The ray leaving along shading-frame direction `wi`: world direction, origin, and
    /// whether it crosses the surface. None for a transmitted direction that the shading
    /// normal put on the arriving side of the actual surface.
    pub(super) fn leave(&self, wi: Vec3) -> Option<(Vec3, Vec3, bool)> {
        let d = self.frame.to_world(wi);
        if wi.z >= 0.0 {
            return Some((d, self.origin, false));
        }
        let ng = if self.front { self.surface.ng } else { -self.surface.ng };
        (d.dot(ng) < 0.0).then_some((d, self.behind, true))
    }

    /// The volumes a ray leaving here is in.
    pub(super) fn media_after(&self, scene: &Scene, crosses: bool) -> Media {
        let mut media = self.media;
        if crosses && scene.features.volumes && scene.materials[self.surface.material as usize].is_volume() {
            media.cross(self.surface.material, self.front);
        }
        media
    }

    /// f |cos| towards world direction `wi`.
    fn eval(&self, wi: Vec3) -> Vec3 {
        self.bsdf.eval_cos(self.wo, self.frame.to_local(wi))
    }
}

fn radiance<const E: bool, const P: bool, const T: bool, const G: bool>(
    scene: &Scene,
    settings: &Settings,
    mut ray: Ray,
    sampler: &mut Sampler,
) -> PathOutput {
    let mut radiance = Vec3::ZERO;
    let mut throughput = Vec3::ONE;
    let mut rays = 0u32;
    let mut prev: Option<PrevBounce> = None;
    let mut depth = 0u32;
    let mut media = Media::default();
    let robust = settings.robustness;
    loop {
        rays += 1;
        let Some(hit) = scene.intersect(&ray, robust.watertight, depth == 0) else {
            if P {
                let d = ray.d.normalize();
                radiance += throughput * escaped(scene, settings, d, prev.map(|b| b.pdf), &media);
            }
            break;
        };
        if scene.features.volumes {
            throughput *= transmittance(media.sigma_a(&scene.materials), hit.t * ray.d.length());
        }
        let surface = scene.surface(&hit);
        let front = surface.ng.dot(ray.d) < 0.0;

        if E && front {
            radiance += throughput * emitted::<T>(scene, settings, &surface, -ray.d, hit.t, prev.map(|b| b.pdf));
        }
        if depth == settings.max_depth {
            break;
        }
        let vertex = Vertex::new::<T, G>(scene, settings, surface, ray.d, media);

        // Light sampling: one shadow ray towards a light chosen by power.
        if (E || P) && settings.light_sampling != LightSampling::Off {
            let (l, traced) = sample_light::<E, P, T>(scene, settings, &vertex, sampler);
            check(NanCause::LightSample, l);
            radiance += throughput * l;
            rays += traced as u32;
        }

        // BSDF sampling: the direction of the next segment.
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = vertex.bsdf.sample(vertex.wo, u_lobe, u, vertex.strategy) else { break };
        check(NanCause::BsdfSample, bs.weight);
        let Some((d, origin, crosses)) = vertex.leave(bs.wi) else { break };
        throughput *= bs.weight;
        prev = Some(PrevBounce { pdf: bs.pdf });
        media = vertex.media_after(scene, crosses);
        ray = Ray { o: origin, d, tmax: f32::INFINITY };
        depth += 1;

        // Termination: Russian roulette on the throughput, survival capped below 1.
        let u_rr = sampler.next_1d();
        if depth >= settings.rr_depth {
            let survive = throughput.max_element().min(0.95);
            if u_rr >= survive {
                break;
            }
            throughput /= survive;
        }
    }
    PathOutput { radiance, rays }
}

/// The shadow ray from `vertex` towards `target` (a point, or a direction if None) along
/// world direction `wi`, and the transmittance of the volume it runs through; None if `wi`
/// leaves on a side the BSDF does not reach.
fn shadow_ray(scene: &Scene, vertex: &Vertex, wi: Vec3, target: Option<Vec3>) -> Option<(Ray, Vec3)> {
    let (_, origin, crosses) = vertex.leave(vertex.frame.to_local(wi))?;
    let (d, tmax) = match target {
        Some(t) => (t - origin, 1.0),
        None => (wi, f32::INFINITY),
    };
    let tr = if scene.features.volumes {
        let sigma = vertex.media_after(scene, crosses).sigma_a(&scene.materials);
        transmittance(sigma, d.length() * tmax)
    } else {
        Vec3::ONE
    };
    Some((Ray { o: origin, d, tmax }, tr))
}

/// Direct light from one light chosen in proportion to power: the estimate and whether a
/// shadow ray was traced. Area lights are sampled uniformly by area and converted to solid
/// angle: Le f cos_s cos_l / (d^2 p_area p_select), with no clamp.
pub(super) fn sample_light<const E: bool, const P: bool, const T: bool>(
    scene: &Scene,
    settings: &Settings,
    vertex: &Vertex,
    sampler: &mut Sampler,
) -> (Vec3, bool) {
    let u_select = sampler.next_2d();
    let u = sampler.next_2d();
    let Some((light, pmf)) = scene.light_sampler.sample(u_select) else { return (Vec3::ZERO, false) };
    let p = vertex.surface.p;
    match light {
        LightRef::Triangle(tri) if E => {
            let positions = scene.geometry.positions(tri);
            let b = warp::uniform_triangle(u);
            let emitter = scene.surface(&Hit { tri, t: 0.0, b });
            let q = emitter.p;
            let to_light = q - p;
            let dist2 = to_light.length_squared();
            let wi = to_light / dist2.sqrt();
            let cos_light = -wi.dot(emitter.ng);
            if cos_light <= 0.0 || !wi.is_finite() {
                return (Vec3::ZERO, false);
            }
            let f = vertex.eval(wi);
            if f == Vec3::ZERO {
                return (Vec3::ZERO, false);
            }
            let material = &scene.materials[emitter.material as usize];
            let le = material.emission::<T>(&scene.textures, &scene.images, &emitter);
            let pdf = pmf * dist2 / (cos_light * scene.triangle_area(tri));
            let weight = match settings.light_sampling {
                LightSampling::Mis => {
                    power_heuristic(pdf, vertex.bsdf.pdf(vertex.wo, vertex.frame.to_local(wi), vertex.strategy))
                }
                _ => 1.0,
            };
            let target = if settings.robustness.offset_origins {
                offset_ray_origin(q, interpolation_error(b, *positions), emitter.ng, -wi)
            } else {
                q
            };
            let Some((shadow, tr)) = shadow_ray(scene, vertex, wi, Some(target)) else { return (Vec3::ZERO, false) };
            if scene.occluded(&shadow, settings.robustness.watertight) {
                return (Vec3::ZERO, true);
            }
            (le * f * tr * (weight / pdf), true)
        }
        LightRef::Punctual(i) if P => {
            let light = &scene.lights[i as usize];
            let (wi, arriving, target) = match light.kind {
                PunctualKind::Directional => (-light.direction, light.intensity, None),
                _ => {
                    let to_light = light.position - p;
                    let dist2 = to_light.length_squared();
                    let wi = to_light / dist2.sqrt();
                    (wi, light.intensity_towards(-wi) / dist2, Some(light.position))
                }
            };
            if arriving == Vec3::ZERO || !wi.is_finite() {
                return (Vec3::ZERO, false);
            }
            let f = vertex.eval(wi);
            if f == Vec3::ZERO {
                return (Vec3::ZERO, false);
            }
            let Some((shadow, tr)) = shadow_ray(scene, vertex, wi, target) else { return (Vec3::ZERO, false) };
            if scene.occluded(&shadow, settings.robustness.watertight) {
                return (Vec3::ZERO, true);
            }
            (arriving * f * tr / pmf, true)
        }
        LightRef::Environment if P => {
            let Some(env) = &scene.environment else { return (Vec3::ZERO, false) };
            let Some((wi, le, pdf_dir)) = env.sample(u) else { return (Vec3::ZERO, false) };
            let f = vertex.eval(wi);
            if f == Vec3::ZERO || le == Vec3::ZERO {
                return (Vec3::ZERO, false);
            }
            let pdf = pmf * pdf_dir;
            let weight = match settings.light_sampling {
                LightSampling::Mis => {
                    power_heuristic(pdf, vertex.bsdf.pdf(vertex.wo, vertex.frame.to_local(wi), vertex.strategy))
                }
                _ => 1.0,
            };
            let Some((shadow, tr)) = shadow_ray(scene, vertex, wi, None) else { return (Vec3::ZERO, false) };
            if scene.occluded(&shadow, settings.robustness.watertight) {
                return (Vec3::ZERO, true);
            }
            (le * f * tr * (weight / pdf), true)
        }
        _ => (Vec3::ZERO, false),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn offsets(mode: PixelSampling, strata: u32, count: u64) -> Vec<Vec2> {
        let settings = Settings { pixel_sampling: mode, strata, seed: 4, ..Settings::default() };
        let pixel = UVec2::new(3, 9);
        (0..count).map(|i| pixel_offset(&settings, pixel, i, &mut Sampler::new(pixel, i, 4))).collect()
    }

    #[test]
    fn stratified_rounds_put_one_sample_in_every_stratum() {
        let k = 3u32;
        for round in offsets(PixelSampling::Stratified, k, 4 * 9).chunks(9) {
            let mut seen = [false; 9];
            for o in round {
                assert!(o.x >= 0.0 && o.x < 1.0 && o.y >= 0.0 && o.y < 1.0);
                let cell = (o.y * k as f32) as usize * k as usize + (o.x * k as f32) as usize;
                assert!(!seen[cell], "stratum {cell} twice in a round");
                seen[cell] = true;
            }
        }
    }

    #[test]
    fn grid_samples_the_cell_midpoints_and_repeats() {
        let o = offsets(PixelSampling::Grid, 2, 8);
        assert_eq!(
            &o[..4],
            &[Vec2::new(0.25, 0.25), Vec2::new(0.75, 0.25), Vec2::new(0.25, 0.75), Vec2::new(0.75, 0.75)]
        );
        assert_eq!(o[..4], o[4..]);
    }

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0f32, 3.0f32), (0.2, 0.2), (5.0, 0.0)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
        }
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
    }
}

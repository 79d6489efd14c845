//! One pixel sample, a pure function of (scene, settings, camera, pixel, sample index): the
//! position in the pixel (section 10.3's pixel-area integration), the estimator, and the
//! optional firefly clamp.
//!
//! Effects a scene lacks are skipped by runtime switches on `scene.features` (media
//! tracking, alpha and culling in traversal) and on the scene's own data (no light: no
//! light sampling; no environment: nothing on escape; a Lambertian material: no GGX): the
//! branches are cheap and predictable. Compile-time specialisation is kept for what changes
//! per-segment work substantially: participating media (the path tracer's `MEDIA`, chosen
//! when the scene has a scattering volume). Spectral transport is chosen per sample
//! (`Wavelengths`: RGB, whose conversions do nothing, or sampled wavelengths). What these
//! choices cost is measured in docs/performance.md.

use super::Context;
use super::aov::Aov;
use super::bdpt::Merging;
use super::edges::{EmitterEdges, PixelEdges};
use super::media::Media;
use super::nan::{NanCause, check};
use super::photons::Photons;
use super::settings::{Integrator, PixelSampling, Settings};
use crate::math::sampler::{PixelSequence, Sampler, hash3};
use crate::scene::{
    Scene,
    camera::{Camera, RayGenerator},
};
use crate::spectrum::{Spectrum, Wavelengths, sampled::Sampled};
use glam::{UVec2, Vec2};
use std::ops::Range;

/// The radiance one pixel sample carries, how many rays it traced, and the AOVs if asked.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathOutput {
    /// Radiance estimate (may be NaN or infinite if something went wrong; the film drops it).
    pub radiance: Spectrum,
    /// Camera, bounce and shadow rays traced.
    pub rays: u32,
    /// Of those, shadow rays.
    pub shadow_rays: u32,
    /// The denoiser's albedo and normal, when asked for (`sample_pixel`'s `aovs`).
    pub aov: Option<Aov>,
}

/// A camera's view of a scene for one image: its rays, and the volumes it sits in.
pub struct View {
    /// Camera rays through the film.
    pub rays: RayGenerator,
    /// The volumes that contain the camera (paths start in them).
    pub media: Media,
    /// The pixels on the outlines of emitters the camera sees (`edges`).
    pub edges: EmitterEdges,
}

impl View {
    /// The view of `scene` through `camera` on a `width` x `height` film.
    pub fn new(scene: &Scene, camera: &Camera, width: u32, height: u32) -> Self {
        let rays = camera.rays(width, height);
        let edges = EmitterEdges::new(scene, &rays, width, height);
        Self { rays, media: Media::containing(scene, camera.position), edges }
    }
}

/// The effects the kernel simulates for `scene` with `settings`, one line for users
/// ("participating media, see-through shadows, spectral: 2 dispersive materials").
pub fn simulated_effects(scene: &Scene, settings: &Settings) -> String {
    let f = scene.features;
    let dispersive = scene.materials.iter().filter(|m| m.is_dispersive()).count();
    let spectral = match (is_spectral(scene, settings), dispersive) {
        (false, _) => None,
        (true, 0) => Some("spectral (asked for)".to_string()),
        (true, 1) => Some("spectral: 1 dispersive material".to_string()),
        (true, n) => Some(format!("spectral: {n} dispersive materials")),
    };
    let effects: Vec<&str> = [
        (f.media, "participating media"),
        (f.volumes && !f.media, "absorbing volumes"),
        (f.see_through, "shadow rays through see-through surfaces"),
        (f.environment, "environment light"),
        (f.cutouts, "alpha and single-sided surfaces"),
    ]
    .into_iter()
    .filter_map(|(on, name)| on.then_some(name))
    .chain(spectral.as_deref())
    .collect();
    if effects.is_empty() { "surfaces only".into() } else { effects.join(", ") }
}

/// Whether paths carry sampled wavelengths: asked for, or needed by a dispersive material.
/// Distribution ray tracing stays RGB (the session refuses it for spectral scenes).
pub fn is_spectral(scene: &Scene, settings: &Settings) -> bool {
    settings.integrator != Integrator::Distribution && settings.wants_spectral(scene.features.dispersion)
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

/// Where a sample's light-tracing contributions go: each at a film position (pixels), for
/// the film to add to the pixel there (bidirectional path tracing; other estimators make
/// none).
pub type Splat<'a> = &'a mut dyn FnMut(Vec2, Spectrum);

/// Sample `index` of `pixel`; with `aovs`, also its albedo and normal for the denoiser (the
/// radiance is the same bits either way). Contributions to other pixels go to `splat`.
/// Vertex connection and merging, lone samples without an iteration's light vertices, is
/// bidirectional path tracing with its light subpaths.
pub fn sample_pixel(
    scene: &Scene,
    settings: &Settings,
    view: &View,
    pixel: UVec2,
    index: u64,
    aovs: bool,
    splat: Splat,
) -> PathOutput {
    let pixel = Pixel { at: pixel, sequence: &sequence(settings, pixel), edges: edges(settings, view, pixel) };
    sample(Context { scene, settings }, view, pixel, (index, aovs), (splat, None))
}

/// Samples `indices` of `pixel`, each handed to `add` with its index: the bits of
/// `sample_pixel` for each, with what the pixel's samples share computed once; vertex
/// connection and merging merges with `photons`, the light vertices of the iteration
/// `indices` must then hold alone.
#[allow(clippy::too_many_arguments)]
pub fn sample_pixels(
    scene: &Scene,
    settings: &Settings,
    view: &View,
    pixel: UVec2,
    indices: Range<u64>,
    aovs: bool,
    mut add: impl FnMut(u64, PathOutput),
    (splat, photons): (Splat, Option<&Photons>),
) {
    let (sequence, edges) = (sequence(settings, pixel), edges(settings, view, pixel));
    let (cx, pixel) = (Context { scene, settings }, Pixel { at: pixel, sequence: &sequence, edges });
    for i in indices {
        add(i, sample(cx, view, pixel, (i, aovs), (&mut *splat, photons)));
    }
}

/// The outlines of seen emitters partly covering `pixel`, if `settings` ask for their
/// control variate.
fn edges<'a>(settings: &Settings, view: &'a View, pixel: UVec2) -> PixelEdges<'a> {
    if settings.edge_control_variate() { view.edges.pixel(pixel) } else { PixelEdges::NONE }
}

/// The numbers of `pixel`'s samples for `settings`.
fn sequence(settings: &Settings, pixel: UVec2) -> PixelSequence {
    PixelSequence::new(settings.sampler, settings.replicates(), pixel, settings.seed)
}

/// What a pixel's samples share: where it is, its numbers, and the outlines of seen
/// emitters that cover part of it.
#[derive(Clone, Copy)]
struct Pixel<'a> {
    at: UVec2,
    sequence: &'a PixelSequence,
    edges: PixelEdges<'a>,
}

/// `sample_pixel` with what the pixel's samples share.
#[inline]
fn sample(
    cx: Context,
    view: &View,
    Pixel { at: pixel, sequence, edges }: Pixel,
    (index, aovs): (u64, bool),
    (splat, photons): (Splat, Option<&Photons>),
) -> PathOutput {
    let Context { scene, settings } = cx;
    let mut sampler = sequence.sampler(index);
    let offset = pixel_offset(settings, pixel, index, &mut sampler);
    let ray = view.rays.ray(pixel.as_vec2() + offset);
    check(NanCause::CameraRay, Spectrum::from_rgb(ray.o + ray.d));
    let media = view.media;
    // Vertex merging joins paths of the whole iteration, which therefore share wavelengths.
    let mut wl = if settings.integrator == Integrator::Vcm && photons.is_some() {
        super::photons::wavelengths(cx, index)
    } else if is_spectral(scene, settings) {
        Wavelengths::Sampled(Sampled::new(sampler.next_1d()))
    } else {
        Wavelengths::Rgb
    };
    let mut out = match (settings.integrator, scene.features.media) {
        (Integrator::Path, false) => super::path::radiance::<false>(cx, ray, media, &mut sampler, &mut wl, aovs),
        (Integrator::Path, true) => super::path::radiance::<true>(cx, ray, media, &mut sampler, &mut wl, aovs),
        (Integrator::Distribution, _) => super::drt::radiance(cx, ray, media, &mut sampler, aovs),
        (Integrator::Bdpt, _) => super::bdpt::radiance(cx, view, ray, &mut sampler, (splat, aovs), None, &mut wl),
        (Integrator::Vcm, _) => {
            let merging = photons.map(|photons| Merging { photons, pixel, index });
            super::bdpt::radiance(cx, view, ray, &mut sampler, (splat, aovs), merging, &mut wl)
        }
    };
    out.radiance = wl.to_rgb(out.radiance);
    if !edges.is_empty() {
        out.radiance += Spectrum::from_rgb(edges.correction(pixel, offset));
    }
    if let Some(c) = settings.firefly_clamp {
        let m = out.radiance.max_element();
        if m > c {
            out.radiance *= c / m;
        }
    }
    out
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
}

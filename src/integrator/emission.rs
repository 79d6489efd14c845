//! Light a path finds by itself: the emitters its rays hit and the environment where they
//! leave the scene, each weighted against light sampling so nothing is counted twice.

use super::Context;
use super::media::{Media, transmittance};
use super::mis::{Scattered, emission_weight};
use super::nan::{NanCause, check};
use crate::scene::{Surface, light::LightHit};
use crate::spectrum::{Spectrum, Wavelengths};
use glam::Vec3;

/// Radiance emitted towards `wo` by the front of `surface`, reached at distance `t` (in
/// units of the ray's direction, which was `-wo`) by a ray sampled as `last`.
#[inline]
pub fn emitted(
    cx: Context,
    surface: &Surface,
    wo: Vec3,
    t: f32,
    last: Option<Scattered>,
    wl: &Wavelengths,
) -> Spectrum {
    let Context { scene, settings } = cx;
    let material = &scene.materials[surface.material as usize];
    if !material.is_emissive() {
        return Spectrum::ZERO;
    }
    // An unlit surface is seen by camera rays and through delta bounces only.
    if material.unlit && last.is_some_and(|s| !s.specular) {
        return Spectrum::ZERO;
    }
    let le = wl.illuminant(scene.emission(surface));
    let weight = emission_weight(settings, last, || scene.pdf_li(LightHit::Emitter { surface, wo, distance: t }));
    check(NanCause::Emission, le);
    le * weight
}

/// Radiance from the environment along `d`, the direction of a ray sampled as `last` that
/// left the scene, attenuated by the volume the ray was in.
#[inline]
pub fn escaped(cx: Context, d: Vec3, last: Option<Scattered>, media: &Media, wl: &Wavelengths) -> Spectrum {
    let Context { scene, settings } = cx;
    let Some(env) = &scene.environment else { return Spectrum::ZERO };
    let d = d.normalize();
    let weight = emission_weight(settings, last, || scene.pdf_li(LightHit::Escaped(d)));
    if weight == 0.0 {
        return Spectrum::ZERO;
    }
    let le = wl.illuminant(env.radiance(d)) * weight;
    check(NanCause::Emission, le);
    if scene.features.volumes {
        le * transmittance(wl.reflectance(media.sigma_t(&scene.materials)), f32::INFINITY)
    } else {
        le
    }
}

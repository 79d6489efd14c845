//! Denoising with Intel Open Image Denoise's `RT` filter (loaded at run time, `film::oidn`).
//! The noisy image is HDR linear radiance; the albedo and normal of the first non-specular
//! hit guide the filter as its documentation asks. They are averages of the same pixel
//! samples as the image, so they carry noise where a pixel covers edges or sees through
//! glass: `cleanAux` stays off, the setting the documentation gives for noisy auxiliary
//! images (its other choice, prefiltering them with filters of their own, would double the
//! filter's time). Where the library is not installed, `denoise` fails with one line saying
//! what to run.

use super::accum::AovImages;
use glam::Vec3;

/// Whether Open Image Denoise can be loaded, or one line saying why not and what to run.
pub fn available() -> Result<(), String> {
    super::oidn::available()
}

/// Denoises the row-major `width` x `height` HDR image `color`, guided by `aovs` (the same
/// pixels' albedo and normal) if given. Errors are one line.
pub fn denoise(color: &[Vec3], aovs: Option<&AovImages>, width: u32, height: u32) -> Result<Vec<Vec3>, String> {
    let n = width as usize * height as usize;
    if color.len() != n || aovs.is_some_and(|a| a.albedo.len() != n || a.normal.len() != n) {
        return Err(format!("denoise: the images do not all have {width}x{height} pixels"));
    }
    run(color, aovs, width as usize, height as usize)
}

fn run(color: &[Vec3], aovs: Option<&AovImages>, width: usize, height: usize) -> Result<Vec<Vec3>, String> {
    let flat = |image: &[Vec3]| -> Vec<f32> { image.iter().flat_map(|p| p.to_array()).collect() };
    // Normals must lie in [-1, 1]; albedo in [0, 1] (both are, as averages of such values).
    let guide = aovs.map(|a| (flat(&a.albedo), flat(&a.normal)));
    let output = super::oidn::filter(&flat(color), guide.as_ref().map(|(a, n)| (&a[..], &n[..])), width, height)?;
    Ok(output.chunks_exact(3).map(Vec3::from_slice).collect())
}

//! Denoising with Intel Open Image Denoise's `RT` filter (the `denoise` feature; the `oidn`
//! crate binds its C API). The noisy image is HDR linear radiance; the albedo and normal of
//! the first non-specular hit guide the filter as its documentation asks. They are averages
//! of the same pixel samples as the image, so they carry noise where a pixel covers edges or
//! sees through glass: `cleanAux` stays off, the setting the documentation gives for noisy
//! auxiliary images (its other choice, prefiltering them with filters of their own, is not
//! offered by the crate, which always binds a colour image). Without the feature, `denoise`
//! fails with `NOT_BUILT`, one line saying how to build it in.

use super::accum::AovImages;
use glam::Vec3;

/// Whether this build has the denoiser.
pub const AVAILABLE: bool = cfg!(feature = "denoise");

/// Why a build without the `denoise` feature cannot denoise, and how to build it in.
pub const NOT_BUILT: &str = "the denoiser is not built in: pip install pyoidn, then build with OIDN_DIR=<site-packages>/pyoidn/oidn cargo build --release --features denoise";

/// Denoises the row-major `width` x `height` HDR image `color`, guided by `aovs` (the same
/// pixels' albedo and normal) if given. Errors are one line.
pub fn denoise(color: &[Vec3], aovs: Option<&AovImages>, width: u32, height: u32) -> Result<Vec<Vec3>, String> {
    let n = width as usize * height as usize;
    if color.len() != n || aovs.is_some_and(|a| a.albedo.len() != n || a.normal.len() != n) {
        return Err(format!("denoise: the images do not all have {width}x{height} pixels"));
    }
    run(color, aovs, width as usize, height as usize)
}

#[cfg(feature = "denoise")]
fn run(color: &[Vec3], aovs: Option<&AovImages>, width: usize, height: usize) -> Result<Vec<Vec3>, String> {
    let flat = |image: &[Vec3]| -> Vec<f32> { image.iter().flat_map(|p| p.to_array()).collect() };
    let fail = |e: oidn::Error| format!("Open Image Denoise: {e}");
    let device = oidn::Device::new().map_err(fail)?;
    let mut filter = oidn::RayTracing::try_new(&device).map_err(fail)?;
    filter.image_dimensions(width, height).hdr(true);
    if let Some(a) = aovs {
        // Normals must lie in [-1, 1]; albedo in [0, 1] (both are, as averages of such values).
        filter.albedo_normal(&flat(&a.albedo), &flat(&a.normal));
    }
    let mut output = vec![0.0f32; 3 * width * height];
    filter.filter(&flat(color), &mut output).map_err(fail)?;
    Ok(output.chunks_exact(3).map(Vec3::from_slice).collect())
}

#[cfg(not(feature = "denoise"))]
fn run(_: &[Vec3], _: Option<&AovImages>, _: usize, _: usize) -> Result<Vec<Vec3>, String> {
    Err(NOT_BUILT.into())
}

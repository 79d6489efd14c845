//! False colours of per-pixel quantities, for the viewer's views and the adaptive bench's
//! maps: the relative error (colorous' inferno, log scale from 0.1% to 100%) and the samples
//! per pixel (viridis, log scale from the fewest to the most).

/// The range of the error scale: 0.1% to 100%.
pub const ERROR_RANGE: (f32, f32) = (1e-3, 1.0);

/// Position in [0, 1] of `value` on a log scale from `low` to `high` (NaN at the top).
fn log_position(value: f64, low: f64, high: f64) -> f64 {
    if !value.is_finite() {
        return 1.0;
    }
    if high <= low {
        return 0.5;
    }
    ((value.max(low).ln() - low.ln()) / (high.ln() - low.ln())).clamp(0.0, 1.0)
}

/// The colour at position `t` in [0, 1] of a gradient, as RGBA8.
fn rgba(gradient: colorous::Gradient, t: f64) -> [u8; 4] {
    let c = gradient.eval_continuous(t);
    [c.r, c.g, c.b, 255]
}

/// False colour of a relative standard error: dark at 0.1% and below, bright at 100% and above.
pub fn error_colour(relative: f32) -> [u8; 4] {
    rgba(colorous::INFERNO, log_position(relative as f64, ERROR_RANGE.0 as f64, ERROR_RANGE.1 as f64))
}

/// The colour at position `t` in [0, 1] of the error scale (for legends).
pub fn error_scale(t: f64) -> [u8; 4] {
    rgba(colorous::INFERNO, t)
}

/// False colour of a pixel's samples, on a log scale over `range` (fewest, most): dark
/// blue at the fewest, yellow at the most.
pub fn spp_colour(spp: u32, range: (u32, u32)) -> [u8; 4] {
    rgba(colorous::VIRIDIS, log_position(spp.max(1) as f64, range.0.max(1) as f64, range.1.max(1) as f64))
}

/// The colour at position `t` in [0, 1] of the samples scale (for legends).
pub fn spp_scale(t: f64) -> [u8; 4] {
    rgba(colorous::VIRIDIS, t)
}

/// The fewest and most samples of a row-major per-pixel count (`(spp, spp)` where
/// `pixel_spp` is empty, every pixel having taken `spp`).
pub fn spp_range(pixel_spp: &[u32], spp: u32) -> (u32, u32) {
    let low = pixel_spp.iter().min().copied().unwrap_or(spp);
    (low, pixel_spp.iter().max().copied().unwrap_or(spp))
}

/// Writes a row-major RGBA8 false-colour image as a PNG, through a temporary file.
pub fn write_png(
    path: &std::path::Path,
    width: u32,
    height: u32,
    pixels: &[[u8; 4]],
) -> Result<(), super::output::OutputError> {
    super::output::replace_file(path, |tmp| {
        image::RgbaImage::from_raw(width, height, pixels.as_flattened().to_vec())
            .expect("buffer matches size")
            .save_with_format(tmp, image::ImageFormat::Png)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brightness(c: [u8; 4]) -> u32 {
        c[0] as u32 + c[1] as u32 + c[2] as u32
    }

    #[test]
    fn false_colours_brighten_with_the_error_and_the_samples() {
        assert!(brightness(error_colour(1e-3)) < brightness(error_colour(0.03)));
        assert!(brightness(error_colour(0.03)) < brightness(error_colour(1.0)));
        assert_eq!(error_colour(f32::NAN), error_colour(10.0));
        assert_eq!(error_colour(1e-5), error_scale(0.0));
        let range = (16, 1024);
        assert_eq!(spp_colour(16, range), spp_scale(0.0));
        assert_eq!(spp_colour(1024, range), spp_scale(1.0));
        assert_eq!(spp_colour(128, range), spp_scale(0.5), "log scale: 128 is halfway from 16 to 1024");
        assert!(brightness(spp_colour(16, range)) < brightness(spp_colour(1024, range)));
        assert_eq!(spp_colour(64, (64, 64)), spp_scale(0.5), "a uniform render sits mid-scale");
        assert_eq!(spp_range(&[], 8), (8, 8));
        assert_eq!(spp_range(&[16, 4, 9], 16), (4, 16));
    }
}

//! Writing images: tonemapped sRGB PNG or linear 32-bit float OpenEXR, chosen by extension,
//! written to a temporary file and renamed, so no half-written file is ever left behind.

use super::tonemap::Display;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Output file formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// 8-bit sRGB PNG after exposure and clamping.
    Png,
    /// Linear radiance, 32-bit float RGB OpenEXR.
    Exr,
}

/// Why an image could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The extension names no supported format.
    #[error("cannot tell the image format of {0}: use .png or .exr")]
    UnknownFormat(PathBuf),
    /// The file could not be created or written.
    #[error("cannot write {path}: {reason}")]
    Write {
        /// Destination.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
}

/// Format for a path, from its extension.
pub fn format_of(path: &Path) -> Result<Format, OutputError> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => Ok(Format::Png),
        Some("exr") => Ok(Format::Exr),
        _ => Err(OutputError::UnknownFormat(path.to_owned())),
    }
}

fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.partial-{}", std::process::id()))
}

/// Checks that `path` can be written, before spending time rendering.
pub fn check_writable(path: &Path) -> Result<Format, OutputError> {
    let format = format_of(path)?;
    check_can_write(path)?;
    Ok(format)
}

/// Checks that a file (of any kind) can be written at `path`.
pub fn check_can_write(path: &Path) -> Result<(), OutputError> {
    if path.is_dir() {
        return Err(OutputError::Write { path: path.to_owned(), reason: "it is a directory".into() });
    }
    let tmp = temp_path(path);
    std::fs::write(&tmp, b"")
        .and_then(|_| std::fs::remove_file(&tmp))
        .map_err(|e| OutputError::Write { path: path.to_owned(), reason: e.to_string() })
}

/// Writes `path` through a temporary file beside it that `write` fills and that is then
/// renamed into place, so a failure never leaves a half-written file; errors name `path`.
pub fn replace_file<E: std::fmt::Display>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), OutputError> {
    let tmp = temp_path(path);
    let result =
        write(&tmp).map_err(|e| e.to_string()).and_then(|_| std::fs::rename(&tmp, path).map_err(|e| e.to_string()));
    result.map_err(|reason| {
        let _ = std::fs::remove_file(&tmp);
        OutputError::Write { path: path.to_owned(), reason }
    })
}

/// Writes a row-major linear image, shown through `display` for PNG.
pub fn write_image(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[Vec3],
    display: &Display,
) -> Result<(), OutputError> {
    let format = format_of(path)?;
    replace_file(path, |tmp| match format {
        Format::Png => {
            let bytes: Vec<u8> = pixels.iter().flat_map(|&p| display.to_srgb8(p)).collect();
            image::RgbImage::from_raw(width, height, bytes)
                .expect("buffer matches size")
                .save_with_format(tmp, image::ImageFormat::Png)
        }
        Format::Exr => {
            let floats: Vec<f32> = pixels.iter().flat_map(|p| p.to_array()).collect();
            image::Rgb32FImage::from_raw(width, height, floats)
                .expect("buffer matches size")
                .save_with_format(tmp, image::ImageFormat::OpenExr)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trips_linear_values_exactly() {
        let dir = tempfile::Builder::new().prefix("lucent-out-").tempdir().unwrap();
        let path = dir.path().join("x.exr");
        let pixels = vec![Vec3::new(0.1, 2.5, 1e4), Vec3::new(0.0, 1e-6, 3.0)];
        write_image(&path, 2, 1, &pixels, &Display::default()).unwrap();
        let back = image::open(&path).unwrap().into_rgb32f();
        assert_eq!(back.as_raw().as_slice(), &[0.1, 2.5, 1e4, 0.0, 1e-6, 3.0]);
        assert!(format_of(Path::new("a.jpg")).is_err());
    }
}

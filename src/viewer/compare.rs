//! Before/after: an image pinned as the reference, composed with the live one for display
//! (a split at a movable column, the pinned image alone, or the difference in stops), and
//! kept on disk per scene, so that it survives a restart of accumulation and of the program.
//!
//! The pin is a linear 32-bit float OpenEXR (exact round trip) with a TOML sidecar for what
//! rendered it, in the user's cache folder (`$XDG_CACHE_HOME/lucent/pins`, or
//! `~/.cache/lucent/pins`; the platform's cache folder elsewhere), named after the scene
//! file and a hash of its canonical path: writing beside the scene would litter asset
//! folders, which may be read-only.

use crate::film::output::{replace_file, write_image};
use crate::film::tonemap::Display;
use crate::math::luminance;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// What rendered a pinned image, kept beside it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PinInfo {
    /// Scene name.
    pub scene: String,
    /// Samples per pixel.
    pub spp: u32,
    /// Render time in seconds.
    pub seconds: f64,
    /// The estimator and edits that made it, in a few words.
    pub label: String,
}

/// A pinned image: linear mean radiance, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Pin {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major linear radiance.
    pub pixels: Vec<Vec3>,
    /// What rendered it.
    pub info: PinInfo,
}

/// The sidecar of a pinned EXR: `NAME.pin.toml` beside `NAME.exr`.
pub fn sidecar(exr: &Path) -> PathBuf {
    exr.with_extension("pin.toml")
}

impl Pin {
    /// Writes the image to `exr` and its metadata to the sidecar, each whole or not at all.
    pub fn write(&self, exr: &Path) -> Result<(), String> {
        if let Some(dir) = exr.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        }
        write_image(exr, self.width, self.height, &self.pixels, &Display::default()).map_err(|e| e.to_string())?;
        let text = toml::to_string(&self.info).map_err(|e| e.to_string())?;
        replace_file(&sidecar(exr), |tmp| std::fs::write(tmp, &text)).map_err(|e| e.to_string())
    }

    /// Reads a pinned image, or any linear image (.exr, .hdr): the metadata comes from the
    /// sidecar if there is a readable one, else only the file's name is known.
    pub fn read(path: &Path) -> Result<Pin, String> {
        let image = image::open(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?.into_rgb32f();
        let (width, height) = image.dimensions();
        let pixels = image.as_raw().chunks_exact(3).map(Vec3::from_slice).collect();
        let info = std::fs::read_to_string(sidecar(path))
            .ok()
            .and_then(|text| toml::from_str(&text).ok())
            .unwrap_or_else(|| PinInfo {
                label: path.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
                ..PinInfo::default()
            });
        Ok(Pin { width, height, pixels, info })
    }

    /// One line about it: size, samples, time and label.
    pub fn describe(&self) -> String {
        let spp = if self.info.spp > 0 {
            format!(", {} spp, {:.1} s", self.info.spp, self.info.seconds)
        } else {
            String::new()
        };
        format!("{}x{}{spp}: {}", self.width, self.height, self.info.label)
    }
}

/// Where pinned images are kept: one per scene in a folder.
#[derive(Clone, Debug, PartialEq)]
pub struct PinStore {
    /// The folder.
    pub dir: PathBuf,
}

impl PinStore {
    /// The user's cache folder for pins (None where the platform has none).
    pub fn user() -> Option<Self> {
        dirs::cache_dir().map(|d| PinStore { dir: d.join("lucent").join("pins") })
    }

    /// The EXR pinned for `scene` (None: the built-in Cornell box): named after the file
    /// and the first 16 hex digits of SHA-256 of its canonical path.
    pub fn path_for(&self, scene: Option<&Path>) -> PathBuf {
        let name = match scene {
            None => "built-in-cornell-box".to_string(),
            Some(path) => {
                let full = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
                let hash = Sha256::digest(full.to_string_lossy().as_bytes());
                let hex: String = hash.iter().take(8).map(|b| format!("{b:02x}")).collect();
                let stem = path.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
                format!("{stem}-{hex}")
            }
        };
        self.dir.join(format!("{name}.exr"))
    }

    /// Saves `pin` as `scene`'s; returns where.
    pub fn save(&self, scene: Option<&Path>, pin: &Pin) -> Result<PathBuf, String> {
        let path = self.path_for(scene);
        pin.write(&path)?;
        Ok(path)
    }

    /// The image pinned for `scene`, if one was saved.
    pub fn load(&self, scene: Option<&Path>) -> Result<Option<Pin>, String> {
        let path = self.path_for(scene);
        if path.exists() { Pin::read(&path).map(Some) } else { Ok(None) }
    }

    /// Deletes `scene`'s pinned image and its sidecar.
    pub fn forget(&self, scene: Option<&Path>) -> Result<(), String> {
        let path = self.path_for(scene);
        for p in [sidecar(&path), path] {
            match std::fs::remove_file(&p) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(format!("cannot delete {}: {e}", p.display()));
                }
                _ => {}
            }
        }
        Ok(())
    }
}

/// What is shown of the live and pinned images.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CompareMode {
    /// The live image only.
    #[default]
    Live,
    /// Pinned left of the divider, live right of it.
    Split,
    /// The pinned image only.
    Pinned,
    /// Per pixel, how many stops brighter or darker the live luminance is than the pinned.
    Difference,
}

/// How the two images are composed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompareView {
    /// What is shown.
    pub mode: CompareMode,
    /// The divider's position in the split, as a fraction of the width.
    pub split: f32,
    /// Stops of difference shown at full colour in the difference view.
    pub stops: f32,
}

impl Default for CompareView {
    fn default() -> Self {
        Self { mode: CompareMode::Live, split: 0.5, stops: 1.0 }
    }
}

/// Why two images cannot be compared: their sizes differ (None if they match).
pub fn size_mismatch(pin: &Pin, width: u32, height: u32) -> Option<String> {
    (pin.width != width || pin.height != height).then(|| {
        format!(
            "the pinned image is {}x{}, the live one {width}x{height}: fix the resolution to the pinned one to compare",
            pin.width, pin.height
        )
    })
}

/// The difference in stops between luminances `live` and `pinned`: log2(live / pinned),
/// 0 where both are black, infinite where only one is.
pub fn stops_difference(live: f32, pinned: f32) -> f32 {
    if live == pinned { 0.0 } else { (live / pinned).log2() }
}

/// Colour of a difference of `stops` shown at full colour from `range` stops: black for
/// none, towards orange where the live image is brighter, towards blue where it is darker.
pub fn difference_colour(stops: f32, range: f32) -> [u8; 4] {
    let t = if stops.is_nan() { 0.0 } else { (stops / range.max(1e-6)).clamp(-1.0, 1.0) };
    let end = if t >= 0.0 { [255.0, 150.0, 40.0] } else { [60.0, 150.0, 255.0] };
    let [r, g, b] = end.map(|c: f32| (c * t.abs()).round() as u8);
    [r, g, b, 255]
}

/// Composes a `width` wide live image and a pinned image of the same size for display
/// through `display`: in the split, columns left of `split x width` show the pinned image,
/// the others the live one, tonemapped alike; the difference ignores the display (stops
/// are what exposure cannot change).
pub fn compose(live: &[Vec3], pinned: &[Vec3], width: u32, view: &CompareView, display: &Display) -> Vec<[u8; 4]> {
    let tonemap = |c: Vec3| {
        let [r, g, b] = display.to_srgb8(c);
        [r, g, b, 255]
    };
    let divider = (view.split.clamp(0.0, 1.0) * width as f32).round() as usize;
    live.iter()
        .zip(pinned)
        .enumerate()
        .map(|(i, (&l, &p))| match view.mode {
            CompareMode::Live => tonemap(l),
            CompareMode::Pinned => tonemap(p),
            CompareMode::Split => tonemap(if i % (width.max(1) as usize) < divider { p } else { l }),
            CompareMode::Difference => difference_colour(stops_difference(luminance(l), luminance(p)), view.stops),
        })
        .collect()
}

/// The viewer's before/after state: the pin, how it is shown and where it is kept.
#[derive(Clone, Debug, Default)]
pub struct Compare {
    /// The pinned image.
    pin: Option<Pin>,
    /// Bumped whenever the pin changes, so the image on screen is composed again.
    serial: u64,
    /// How the images are composed.
    pub view: CompareView,
    /// Show the pinned image whatever the mode (while Space is held).
    pub flip: bool,
    /// The user moved the divider since the image was pinned; until then it follows the
    /// selected material (`ViewerState::place_divider`).
    pub divider_moved: bool,
    /// Where pins are kept (None: in memory only).
    pub store: Option<PinStore>,
    /// The file the pin is in, if it is on disk.
    pub file: Option<PathBuf>,
}

impl Compare {
    /// The pinned image.
    pub fn pin(&self) -> Option<&Pin> {
        self.pin.as_ref()
    }

    /// Replaces the pin (None: unpinned), read from or saved to `file`.
    pub fn set_pin(&mut self, pin: Option<Pin>, file: Option<PathBuf>) {
        self.pin = pin;
        self.file = file;
        self.serial += 1;
        self.divider_moved = false;
    }

    /// The mode in effect: the pinned image while flipped, the live one without a pin.
    pub fn mode(&self) -> CompareMode {
        match (&self.pin, self.flip) {
            (None, _) => CompareMode::Live,
            (Some(_), true) => CompareMode::Pinned,
            (Some(_), false) => self.view.mode,
        }
    }

    /// What decides the composed image besides the live image and the display.
    pub fn look(&self) -> (CompareView, u64) {
        (CompareView { mode: self.mode(), ..self.view }, self.serial)
    }

    /// The live `width` x `height` image composed with the pin for display; None when only
    /// the live image is shown (no pin, the live mode, or sizes that differ).
    pub fn rgba(&self, live: &[Vec3], width: u32, height: u32, display: &Display) -> Option<Vec<[u8; 4]>> {
        let pin = self.pin.as_ref().filter(|p| size_mismatch(p, width, height).is_none())?;
        let view = self.look().0;
        (view.mode != CompareMode::Live).then(|| compose(live, &pin.pixels, width, &view, display))
    }
}

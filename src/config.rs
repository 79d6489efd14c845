//! Saved views: a camera, render settings and display settings in a small TOML file,
//! written by the viewer and read by both the viewer and `lucent render --view`. The
//! environment map's path is stored relative to the view file, so a view works from any
//! folder and moves with its map.

use crate::film::output::replace_file;
use crate::film::tonemap::Display;
use crate::integrator::Settings;
use crate::scene::{
    camera::Camera,
    environment::{BUILT_IN, EnvSettings},
};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Everything needed to reproduce a view of a scene.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ViewFile {
    /// The camera (the scene's default camera when absent).
    pub camera: Option<Camera>,
    /// Render settings.
    pub settings: Settings,
    /// Exposure and tone curve.
    pub display: Display,
    /// What lights the scene from outside.
    pub environment: EnvSettings,
}

impl ViewFile {
    /// Reads and validates a view file; errors are one line and name the file.
    pub fn load(path: &Path) -> Result<Self, String> {
        let fail = |e: &dyn std::fmt::Display| format!("cannot read view file {}: {e}", path.display());
        let text = std::fs::read_to_string(path).map_err(|e| fail(&e))?;
        let view: ViewFile = toml::from_str(&text).map_err(|e| fail(&crate::params::toml_error(&text, &e)))?;
        let mut view = view;
        if let Some(map) = view.environment.map.as_mut().filter(|m| m.is_relative() && *m != Path::new(BUILT_IN)) {
            let joined = path.parent().unwrap_or(Path::new("")).join(&*map);
            *map = std::fs::canonicalize(&joined).unwrap_or(joined);
        }
        view.settings.validate().map_err(|e| fail(&e))?;
        view.environment.validate().map_err(|e| fail(&e))?;
        if let Some(c) = view.camera
            && !(c.position.is_finite() && c.rotation.is_finite() && c.yfov > 0.0 && c.yfov < std::f32::consts::PI)
        {
            return Err(fail(&"the camera needs a finite position and rotation and 0 < yfov < pi"));
        }
        Ok(view)
    }

    /// Writes the view as TOML (via a temporary file, so a failed write leaves nothing).
    pub fn save(&self, path: &Path) -> Result<(), String> {
        let fail = |e: &dyn std::fmt::Display| format!("cannot write view file {}: {e}", path.display());
        let mut view = self.clone();
        if let Some(map) = view.environment.map.as_mut().filter(|m| *m != Path::new(BUILT_IN)) {
            let absolute = |p: &Path| std::path::absolute(p).map_err(|e| fail(&e));
            let dir = absolute(path)?.parent().map(Path::to_path_buf).unwrap_or_default();
            let map_abs = absolute(map)?;
            *map = pathdiff::diff_paths(&map_abs, &dir).unwrap_or(map_abs);
        }
        let text = toml::to_string_pretty(&view).map_err(|e| fail(&e))?;
        replace_file(path, |tmp| std::fs::write(tmp, &text)).map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::tonemap::Tonemap;
    use crate::integrator::LightSampling;
    use glam::Vec3;

    #[test]
    fn round_trips_through_toml_and_rejects_bad_values() {
        let dir = std::env::temp_dir().join(format!("lucent-view-{}", std::process::id()));
        let maps = dir.join("maps");
        std::fs::create_dir_all(&maps).unwrap();
        std::fs::write(maps.join("sky.hdr"), "").unwrap();
        let view = ViewFile {
            camera: Some(Camera::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, 0.7)),
            settings: Settings { light_sampling: LightSampling::Explicit, max_depth: 12, ..Settings::default() },
            display: Display { exposure: -1.5, tonemap: Tonemap::PbrNeutral },
            environment: EnvSettings {
                map: Some(std::fs::canonicalize(&maps).unwrap().join("sky.hdr")),
                background: Vec3::new(0.1, 0.2, 0.3),
                intensity: 2.0,
                rotation: -45.0,
            },
        };
        std::fs::create_dir_all(dir.join("views")).unwrap();
        let path = dir.join("views/v.toml");
        view.save(&path).unwrap();
        assert!(std::fs::read_to_string(&path).unwrap().contains("map = \"../maps/sky.hdr\""), "relative to the file");
        assert_eq!(ViewFile::load(&path).unwrap(), view);
        let moved = dir.with_extension("moved");
        std::fs::rename(&dir, &moved).unwrap();
        let map = ViewFile::load(&moved.join("views/v.toml")).unwrap().environment.map;
        assert_eq!(map, Some(std::fs::canonicalize(moved.join("maps/sky.hdr")).unwrap()), "moves with its map");
        std::fs::rename(&moved, &dir).unwrap();
        std::fs::write(&path, "[settings]\nwidth = 0\n").unwrap();
        assert!(ViewFile::load(&path).unwrap_err().contains("width: 0 is not in 1..=16384"));
        std::fs::write(&path, "[settings]\nlight_sampling = \"sometimes\"\n").unwrap();
        let err = ViewFile::load(&path).unwrap_err();
        assert!(err.contains("v.toml") && !err.contains('\n'), "{err}");
        assert!(err.contains("line 2, column 18: "), "where it failed: {err}");
        std::fs::write(&path, "[display]\nexposure = 1.0\n  [camera\n").unwrap();
        let err = ViewFile::load(&path).unwrap_err();
        assert!(err.contains("line 3, column ") && !err.contains('\n'), "{err}");
        std::fs::write(&path, "[environment]\nintensity = -1.0\n").unwrap();
        assert!(ViewFile::load(&path).unwrap_err().contains("intensity"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

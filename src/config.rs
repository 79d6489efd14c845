//! Saved views: a camera, render settings and display settings in a small TOML file,
//! written by the viewer and read by both the viewer and `lucent render --view`. The
//! environment map's path is stored relative to the view file, so a view works from any
//! folder and moves with its map. A view also holds the edits made to the scene's
//! materials and lights, each named by its index and name and its parameters by the keys
//! of `scene::edit`'s tables:
//!
//! ```toml
//! [[materials]]
//! index = 3
//! name = "Glass"
//! roughness = 0.2
//! attenuation_color = [0.9, 0.5, 0.5]
//!
//! [[lights]]
//! index = 0
//! name = "Lamp"
//! intensity = 40.0
//! ```

use crate::film::output::replace_file;
use crate::film::tonemap::Display;
use crate::integrator::Settings;
use crate::scene::edit::{self, Kind, LIGHT_PARAMS, MATERIAL_PARAMS, Param, ParamValue};
use crate::scene::{
    camera::Camera,
    environment::{BUILT_IN, EnvSettings},
    light::PunctualLight,
    material::Material,
};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
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
    /// Edits to the scene's materials.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<Edit>,
    /// Edits to the scene's punctual lights.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub lights: Vec<Edit>,
}

/// The edited parameters of one material or light: which one (its index in the scene's
/// list, and its name, which must match), and each parameter's new value by its table key.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Edit {
    /// Index in the scene's materials (or lights).
    pub index: usize,
    /// Its name, which must be the scene's.
    pub name: String,
    /// New values, by the keys of `scene::edit::MATERIAL_PARAMS` (or `LIGHT_PARAMS`).
    #[serde(flatten)]
    pub values: BTreeMap<String, toml::Value>,
}

impl ViewFile {
    /// Reads and validates a view file (every setting and display entry by its table's
    /// range); errors are one line and name the file. A file cannot allow what only the user
    /// may: `allow_expensive` comes back off, for the command line or the viewer to set (the
    /// distribution ray tracer's ray budget is checked once they have).
    pub fn load(path: &Path) -> Result<Self, String> {
        let fail = |e: &dyn std::fmt::Display| format!("cannot read view file {}: {e}", path.display());
        let text = crate::memory::read_text(path).map_err(|e| fail(&e))?;
        let view: ViewFile = toml::from_str(&text).map_err(|e| fail(&crate::params::toml_error(&text, &e)))?;
        let mut view = view;
        if let Some(map) = view.environment.map.as_mut().filter(|m| m.is_relative() && *m != Path::new(BUILT_IN)) {
            let joined = path.parent().unwrap_or(Path::new("")).join(&*map);
            *map = std::fs::canonicalize(&joined).unwrap_or(joined);
        }
        view.settings.allow_expensive = false;
        crate::params::validate(crate::integrator::settings::SETTINGS, &view.settings).map_err(|e| fail(&e))?;
        crate::params::validate(crate::film::tonemap::DISPLAY, &view.display).map_err(|e| fail(&e))?;
        view.environment.validate().map_err(|e| fail(&e))?;
        if let Some(c) = view.camera
            && !(c.position.is_finite()
                && c.rotation.is_finite()
                && c.yfov > 0.0
                && c.yfov < std::f32::consts::PI
                && c.aspect.is_none_or(|a| a.is_finite() && a > 0.0))
        {
            return Err(fail(&"the camera needs a finite position and rotation, 0 < yfov < pi and a positive aspect"));
        }
        // Each edit's values by its table (kind and range); which material or light it
        // names is checked against the scene when the edits are applied.
        for e in &view.materials {
            checked(MATERIAL_PARAMS, e, "material").map_err(|e| fail(&e))?;
        }
        for e in &view.lights {
            checked(LIGHT_PARAMS, e, "light").map_err(|e| fail(&e))?;
        }
        Ok(view)
    }

    /// Records as edits whatever differs between the materials and lights as loaded
    /// (`original`) and as `edited`, replacing the edits held before.
    pub fn record_edits(&mut self, original: (&[Material], &[PunctualLight]), edited: (&[Material], &[PunctualLight])) {
        self.materials = record(MATERIAL_PARAMS, original.0, edited.0, |m| &m.name);
        self.lights = record(LIGHT_PARAMS, original.1, edited.1, |l| &l.name);
    }

    /// Applies the edits to `materials` and `lights`; the error is one line naming the view
    /// file's material or light and what is wrong (no such one, an unknown parameter, a
    /// value out of range).
    pub fn apply_edits(&self, materials: &mut [Material], lights: &mut [PunctualLight]) -> Result<(), String> {
        apply(MATERIAL_PARAMS, &self.materials, materials, "material", |m| &m.name)?;
        apply(LIGHT_PARAMS, &self.lights, lights, "light", |l| &l.name)?;
        for e in &self.lights {
            if let Some(problem) = lights.get(e.index).and_then(edit::light_problem) {
                return Err(format!("view file: light {} {:?}: {problem}", e.index, e.name));
            }
        }
        Ok(())
    }

    /// Whether it edits materials or lights.
    pub fn has_edits(&self) -> bool {
        !(self.materials.is_empty() && self.lights.is_empty())
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

/// The edits that make `original` into `edited`, one per item that differs.
fn record<T>(table: &'static [Param<T>], original: &[T], edited: &[T], name: fn(&T) -> &String) -> Vec<Edit> {
    let mut edits = Vec::new();
    for (index, (o, e)) in original.iter().zip(edited).enumerate() {
        let values: BTreeMap<String, toml::Value> =
            edit::changes(table, o, e).into_iter().map(|(p, v)| (p.key.to_string(), to_toml(v))).collect();
        if !values.is_empty() {
            edits.push(Edit { index, name: name(e).clone(), values });
        }
    }
    edits
}

/// Applies `edits` to `items` in table order (so alphaMode is set before alphaCutoff).
fn apply<T>(
    table: &'static [Param<T>],
    edits: &[Edit],
    items: &mut [T],
    what: &str,
    name: fn(&T) -> &String,
) -> Result<(), String> {
    for e in edits {
        let fail = |reason: String| format!("view file: {what} {} {:?}: {reason}", e.index, e.name);
        let item = match items.get_mut(e.index) {
            Some(item) if *name(item) == e.name => item,
            Some(item) => return Err(fail(format!("the scene's {what} {} is {:?}", e.index, name(item)))),
            None => return Err(fail(format!("the scene has no such {what} (it has {})", items.len()))),
        };
        for (p, value) in checked(table, e, what)? {
            p.try_set(item, value).map_err(fail)?;
        }
    }
    Ok(())
}

/// An edit's values as its table's parameters, in table order, each of its kind and in its
/// range; the error is one line naming the edit.
fn checked<T>(
    table: &'static [Param<T>],
    e: &Edit,
    what: &str,
) -> Result<Vec<(&'static Param<T>, ParamValue)>, String> {
    let fail = |reason: String| format!("view file: {what} {} {:?}: {reason}", e.index, e.name);
    if let Some(key) = e.values.keys().find(|k| edit::find(table, k).is_none()) {
        let keys: Vec<&str> = table.iter().map(|p| p.key).collect();
        return Err(fail(format!("unknown parameter {key:?} (known: {})", keys.join(", "))));
    }
    let mut out = Vec::new();
    for p in table {
        if let Some(value) = e.values.get(p.key) {
            let value = from_toml(p.kind, value).map_err(|err| fail(format!("{}: {err}", p.key)))?;
            p.kind.check(value).map_err(|err| fail(format!("{}: {err}", p.key)))?;
            out.push((p, value));
        }
    }
    Ok(out)
}

/// A number as the shortest decimal that reads back as the same f32.
fn float(x: f32) -> toml::Value {
    let shortest: f64 = x.to_string().parse().unwrap_or(x as f64);
    toml::Value::Float(if shortest as f32 == x { shortest } else { x as f64 })
}

fn to_toml(value: ParamValue) -> toml::Value {
    match value {
        ParamValue::Number(x) => float(x),
        ParamValue::Triple(v) => toml::Value::Array(v.to_array().map(float).to_vec()),
        ParamValue::Switch(b) => toml::Value::Boolean(b),
        ParamValue::Choice(c) => toml::Value::String(c.into()),
    }
}

/// A view file's value as a parameter of `kind` (its range is checked when it is set).
fn from_toml(kind: Kind, value: &toml::Value) -> Result<ParamValue, String> {
    let number = |v: &toml::Value| match v {
        toml::Value::Float(x) => Some(*x as f32),
        toml::Value::Integer(i) => Some(*i as f32),
        _ => None,
    };
    let parsed = match kind {
        Kind::Number { .. } => number(value).map(ParamValue::Number),
        Kind::Colour { .. } | Kind::Position | Kind::Direction => match value.as_array().map(Vec::as_slice) {
            Some([x, y, z]) => {
                number(x).zip(number(y)).zip(number(z)).map(|((x, y), z)| ParamValue::Triple(Vec3::new(x, y, z)))
            }
            _ => None,
        },
        Kind::Switch => value.as_bool().map(ParamValue::Switch),
        Kind::Choice(names) => {
            value.as_str().and_then(|s| names.iter().find(|n| **n == s)).map(|n| ParamValue::Choice(n))
        }
    };
    parsed.ok_or_else(|| format!("{value} is not {}", kind.range()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::tonemap::Tonemap;
    use crate::integrator::LightSampling;
    use glam::Vec3;

    #[test]
    fn round_trips_through_toml_and_rejects_bad_values() {
        let temp = tempfile::Builder::new().prefix("lucent-view-").tempdir().unwrap();
        let dir = temp.path().join("view");
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
            ..ViewFile::default()
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
        std::fs::write(&path, "[display]\nexposure = nan\n").unwrap();
        let err = ViewFile::load(&path).unwrap_err();
        assert!(err.contains("v.toml") && err.contains("exposure"), "{err}");
    }

    #[test]
    fn a_view_file_cannot_allow_what_only_the_user_may() {
        // Distribution ray tracing over its ray budget: the file's `allow_expensive` is
        // dropped, so the settings are refused until the user allows them.
        let dir = tempfile::Builder::new().prefix("lucent-view-expensive-").tempdir().unwrap();
        let path = dir.path().join("v.toml");
        let text =
            "[settings]\nintegrator = \"distribution\"\nbranching = 4096\nmax_depth = 6\nallow_expensive = true\n";
        std::fs::write(&path, text).unwrap();
        let view = ViewFile::load(&path).unwrap();
        assert!(!view.settings.allow_expensive);
        assert!(view.settings.validate().unwrap_err().to_string().contains("allow it explicitly"));
        assert!(Settings { allow_expensive: true, ..view.settings }.validate().is_ok());
    }

    #[test]
    fn material_and_light_edits_round_trip_and_errors_name_them() {
        let dir = tempfile::Builder::new().prefix("lucent-view-edits-").tempdir().unwrap();
        let materials =
            vec![Material::lambert("wall", Vec3::ONE), Material { name: "glass".into(), ..Material::default() }];
        let light = PunctualLight {
            name: "lamp".into(),
            kind: crate::scene::light::PunctualKind::Point,
            position: Vec3::ZERO,
            direction: -Vec3::Z,
            color: Vec3::ONE,
            intensity: 1.0,
            range: None,
            source: None,
        };
        let (mut m, mut l) = (materials.clone(), vec![light.clone()]);
        m[1].roughness = 0.2;
        m[1].alpha_mode = crate::scene::material::AlphaMode::Mask(0.3);
        m[1].volume_factors.thickness = 1.0;
        m[1].volume_factors.attenuation_distance = 0.1;
        m[1].update_volume();
        l[0].intensity = 7.25;
        l[0].position = Vec3::new(0.1, 0.2, 0.3);
        let mut view = ViewFile::default();
        view.record_edits((&materials, std::slice::from_ref(&light)), (&m, &l));
        assert_eq!((view.materials.len(), view.materials[0].index, view.lights.len()), (1, 1, 1));
        let path = dir.path().join("edits.toml");
        view.save(&path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.contains("[[materials]]")
                && text.contains("roughness = 0.2\n")
                && text.contains("alpha_mode = \"MASK\""),
            "{text}"
        );
        let loaded = ViewFile::load(&path).unwrap();
        let (mut m2, mut l2) = (materials.clone(), vec![light.clone()]);
        loaded.apply_edits(&mut m2, &mut l2).unwrap();
        assert_eq!((m2, l2), (m, l), "the edits read back exactly");
        let bad = |toml: &str| {
            let view: ViewFile = toml::from_str(toml).unwrap();
            view.apply_edits(&mut materials.clone(), &mut [light.clone()]).unwrap_err()
        };
        assert!(
            bad("[[materials]]\nindex = 1\nname = \"gold\"\n")
                .contains("material 1 \"gold\": the scene's material 1 is \"glass\"")
        );
        assert!(bad("[[materials]]\nindex = 5\nname = \"gold\"\n").contains("no such material"));
        assert!(
            bad("[[materials]]\nindex = 1\nname = \"glass\"\nroughness = 2.0\n")
                .contains("roughness: 2 is not in 0..=1")
        );
        assert!(
            bad("[[materials]]\nindex = 1\nname = \"glass\"\nbase_color = 0.5\n")
                .contains("base_color: 0.5 is not a colour")
        );
        assert!(bad("[[lights]]\nindex = 0\nname = \"lamp\"\nshine = 1\n").contains("unknown parameter \"shine\""));
    }
}

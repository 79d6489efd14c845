//! The materials sidecar: `SCENE.materials.toml` beside `SCENE.gltf` (or `.glb`) assigns
//! measured BRDFs (MERL .binary files, paths relative to the sidecar) to glTF materials by
//! name:
//!
//! ```toml
//! [measured]
//! "Gold paint" = "brdfs/gold-metallic-paint.binary"
//! ```

use crate::bsdf::measured::MerlTable;
use crate::scene::{SceneDesc, material::Measured};
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Sidecar {
    #[serde(default)]
    measured: BTreeMap<String, PathBuf>,
}

/// Where the sidecar of `scene` would be.
pub fn path_for(scene: &Path) -> PathBuf {
    beside(scene, "materials")
}

/// The sidecar `SCENE.<kind>.toml` beside `scene` (shared by the materials and media sidecars).
pub fn beside(scene: &Path, kind: &str) -> PathBuf {
    let stem = scene.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    scene.with_file_name(format!("{stem}.{kind}.toml"))
}

/// Applies the sidecar of `scene`, if there is one; the error is one line. Names the file
/// does not have are reported as warnings.
pub fn apply(desc: &mut SceneDesc, scene: &Path) -> Result<(), String> {
    let path = path_for(scene);
    if !path.is_file() {
        return Ok(());
    }
    let fail = |e: &dyn std::fmt::Display| format!("materials sidecar {}: {e}", path.display());
    let text = crate::memory::read_text(&path).map_err(|e| fail(&e))?;
    let sidecar: Sidecar = toml::from_str(&text).map_err(|e| fail(&crate::params::toml_error(&text, &e)))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mut tables: HashMap<PathBuf, Arc<MerlTable>> = HashMap::new();
    for (name, file) in sidecar.measured {
        let file = base.join(file);
        let table = match tables.get(&file) {
            Some(t) => Arc::clone(t),
            None => {
                let t = Arc::new(MerlTable::load(&file)?);
                tables.insert(file.clone(), Arc::clone(&t));
                t
            }
        };
        let mut found = false;
        for m in desc.materials.iter_mut().filter(|m| m.name == name) {
            m.measured = Some(Measured { path: file.clone(), table: Arc::clone(&table) });
            found = true;
        }
        if !found {
            desc.warnings.push(format!("{}: no material is named {name:?}", path.display()));
        }
    }
    Ok(())
}

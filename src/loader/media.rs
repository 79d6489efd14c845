//! The media sidecar: `SCENE.media.toml` beside `SCENE.gltf` (or `.glb`) fills the volumes
//! of glTF materials, by name, with density grids read from OpenVDB files (paths relative to
//! the sidecar). Each grid spans the bounds of the meshes that use its material, whose
//! surface should be a closed, index-matched boundary (transmission 1, ior 1):
//!
//! ```toml
//! [grids."Smoke"]
//! file = "smoke.vdb"       # an OpenVDB file
//! grid = "density"         # the float grid in it (default: the first)
//! density = 20.0           # extinction per unit length where the grid's value is 1
//! albedo = [0.9, 0.9, 0.9] # single-scattering albedo
//! g = 0.3                  # Henyey-Greenstein anisotropy
//! ```

use crate::medium::{Volume, grid::DensityGrid, phase::MAX_G};
use crate::scene::SceneDesc;
use glam::Vec3;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Sidecar {
    #[serde(default)]
    grids: BTreeMap<String, GridEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GridEntry {
    file: PathBuf,
    grid: Option<String>,
    density: f32,
    #[serde(default = "white")]
    albedo: [f32; 3],
    #[serde(default)]
    g: f32,
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

/// Where the media sidecar of `scene` would be.
pub fn path_for(scene: &Path) -> PathBuf {
    super::sidecar::beside(scene, "media")
}

/// Applies the media sidecar of `scene`, if there is one. A missing or malformed sidecar or
/// grid is an error (one line); a name no material has, a material that does not transmit,
/// and out-of-range values (clamped) are warnings.
pub fn apply(desc: &mut SceneDesc, scene: &Path) -> Result<(), String> {
    let path = path_for(scene);
    if !path.is_file() {
        return Ok(());
    }
    let fail = |e: &dyn std::fmt::Display| format!("media sidecar {}: {e}", path.display());
    let text = crate::memory::read_text(&path).map_err(|e| fail(&e))?;
    let sidecar: Sidecar = toml::from_str(&text).map_err(|e| fail(&crate::params::toml_error(&text, &e)))?;
    let base = path.parent().unwrap_or(Path::new("."));
    for (name, entry) in sidecar.grids {
        let targets: Vec<usize> = (0..desc.materials.len()).filter(|&i| desc.materials[i].name == name).collect();
        if targets.is_empty() {
            desc.warnings.push(format!("{}: no material is named {name:?}", path.display()));
            continue;
        }
        if !(entry.density.is_finite() && entry.density >= 0.0) {
            return Err(fail(&format!("grid for {name:?}: density {} must be a finite number >= 0", entry.density)));
        }
        let grid = DensityGrid::load_vdb(&base.join(&entry.file), entry.grid.as_deref())?;
        let albedo = Vec3::from(entry.albedo);
        let clamped = albedo.clamp(Vec3::ZERO, Vec3::ONE);
        if clamped != albedo || !albedo.is_finite() {
            desc.warnings.push(format!("{}: albedo {albedo} of {name:?} is outside [0, 1]: clamped", path.display()));
        }
        let g = if entry.g.is_finite() { entry.g } else { 0.0 };
        if g.abs() > MAX_G {
            desc.warnings.push(format!("{}: g {g} of {name:?} is outside (-1, 1): clamped", path.display()));
        }
        let index = desc.grids.len() as u32;
        desc.grids.push(grid);
        for i in targets {
            let m = &mut desc.materials[i];
            if !m.is_transmissive() {
                desc.warnings.push(format!(
                    "{}: material {name:?} does not transmit light, so nothing enters its grid",
                    path.display()
                ));
            }
            m.volume = Some(Volume {
                sigma_t: Vec3::splat(entry.density),
                albedo: if albedo.is_finite() { clamped } else { Vec3::ONE },
                g: g.clamp(-MAX_G, MAX_G),
                grid: Some(index),
            });
        }
    }
    Ok(())
}

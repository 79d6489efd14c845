//! The library's entry point: a scene from a glTF file (or the built-in Cornell box), lit
//! by the environment asked for, ready to render. The command line and the viewer both
//! open scenes here; progress is reported as data, warnings stay in `Scene::warnings`. A
//! scene without light of its own is lit by the built-in sky unless asked to stay dark, as
//! the Khronos glTF Sample Viewer lights every model with an image-based light.

use crate::loader::{builtin, gltf};
use crate::memory::Limits;
use crate::scene::{
    Scene,
    environment::{EnvSettings, Environment},
    instances::Instancing,
};
use std::path::Path;

/// What `open` is doing, for progress displays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Reading the environment map.
    Environment,
    /// Reading and converting the file (buffers, images, meshes, materials).
    Reading,
    /// Building the BVH and the light sampler.
    Building,
}

/// How to open a scene.
#[derive(Clone, Debug, Default)]
pub struct OpenOptions {
    /// What lights the scene from outside.
    pub environment: EnvSettings,
    /// Leave a scene without light of its own dark (see [`Scene::has_own_light`]) instead of
    /// lighting it with the built-in sky, as a black `environment` otherwise does.
    pub keep_dark: bool,
    /// The memory loading and building may take (default: half the machine's); a file that
    /// would need more is refused before it is allocated ("scene too large: ...").
    pub limits: Limits,
    /// The KHR_materials_variants variant to give the meshes' materials (None: the defaults).
    pub variant: Option<String>,
    /// Which meshes placed many times stay instanced.
    pub instancing: Instancing,
}

/// Opens the glTF file at `path` (None: the built-in Cornell box) lit by
/// `options.environment`, calling `progress` as each stage begins. Errors are one line.
pub fn open(path: Option<&Path>, options: &OpenOptions, progress: &mut dyn FnMut(Stage)) -> Result<Scene, String> {
    let environment = if options.environment.is_black() {
        None
    } else {
        progress(Stage::Environment);
        Some(Environment::load(options.environment.clone())?)
    };
    progress(Stage::Reading);
    let mut desc = match path {
        Some(p) => gltf::load_with_limits(p, &options.limits).map_err(|e| e.to_string())?,
        None => builtin::cornell_box(),
    };
    if let Some(variant) = &options.variant {
        desc.select_variant(variant)?;
    }
    desc.apply_instancing(options.instancing, options.limits.memory / crate::loader::limits::TRIANGLE)?;
    progress(Stage::Building);
    let mut scene = Scene::build(desc);
    if environment.is_none() && !options.keep_dark && !scene.has_own_light() {
        scene.warnings.push(format!(
            "{} has no light of its own: the built-in sky lights it (--env none keeps it dark)",
            scene.name
        ));
        return Ok(scene.with_environment(Some(Environment::load(EnvSettings::built_in())?)));
    }
    Ok(if environment.is_some() { scene.with_environment(environment) } else { scene })
}

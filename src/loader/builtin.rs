//! The built-in default scene: the canonical Cornell box, embedded in the binary and read
//! by the same glTF loader as any file, so it is the same box.

use crate::scene::SceneDesc;

/// The Cornell box glTF (geometry, albedos, light radiance and camera), embedded.
const CORNELL_BOX: &[u8] = include_bytes!("../../assets/cornell-box.gltf");

/// The built-in Cornell box scene.
pub fn cornell_box() -> SceneDesc {
    super::gltf::load_slice(CORNELL_BOX, "cornell-box").expect("the embedded Cornell box is valid glTF")
}

/// The glTF file the built-in Cornell box is read from.
pub fn cornell_box_gltf() -> &'static [u8] {
    CORNELL_BOX
}

//! KHR_materials_variants: the file's named material variants and, per primitive, the
//! material each variant gives it; `SceneDesc::select_variant` applies one.

use super::gltf::Warnings;
use gltf::Document;

/// The extension's name, in `extensionsUsed`, at the root and on primitives.
pub(super) const EXTENSION: &str = "KHR_materials_variants";

/// The variants' names, in the file's order (unnamed ones as "variant N").
pub(super) fn names(doc: &Document) -> Vec<String> {
    let root = doc.extension_value(EXTENSION);
    let list = root.and_then(|r| r["variants"].as_array()).map_or(&[][..], Vec::as_slice);
    list.iter()
        .enumerate()
        .map(|(i, v)| v["name"].as_str().map_or_else(|| format!("variant {i}"), str::to_owned))
        .collect()
}

/// (variant, material) for each variant that gives the primitive a material of its own;
/// a mapping naming a missing material is skipped with a warning.
pub(super) fn mappings(prim: &gltf::Primitive, materials: u32, warnings: &mut Warnings) -> Vec<(u32, u32)> {
    let Some(ext) = prim.extension_value(EXTENSION) else { return Vec::new() };
    let mut out = Vec::new();
    for mapping in ext["mappings"].as_array().map_or(&[][..], Vec::as_slice) {
        let Some(material) =
            mapping["material"].as_u64().and_then(|m| u32::try_from(m).ok()).filter(|&m| m < materials)
        else {
            warnings.add("a KHR_materials_variants mapping names no material: skipped");
            continue;
        };
        for v in mapping["variants"].as_array().map_or(&[][..], Vec::as_slice) {
            if let Some(v) = v.as_u64().and_then(|v| u32::try_from(v).ok()) {
                out.push((v, material));
            }
        }
    }
    out
}

//! EXT_mesh_gpu_instancing: a node's mesh placed once per instance, at the node's transform
//! times the instance's translation x rotation x scale, and flattened like the node graph
//! (so memory follows the flattened count, not the unique geometry).

use super::attributes;
use glam::{DMat4, DQuat, DVec3};
use gltf::{Document, Node, Semantic, buffer};

/// The extension's name, in `extensionsUsed` and on nodes.
pub(super) const EXTENSION: &str = "EXT_mesh_gpu_instancing";

/// A node's TRANSLATION, ROTATION and SCALE accessors (each optional); None for a node
/// without the extension.
type Attributes<'a> = [Option<gltf::Accessor<'a>>; 3];

fn accessors<'a>(doc: &'a Document, node: &Node) -> Result<Option<Attributes<'a>>, String> {
    let Some(ext) = node.extension_value(EXTENSION) else { return Ok(None) };
    let get = |key: &str| match ext["attributes"].get(key) {
        None => Ok(None),
        Some(v) => v.as_u64().and_then(|i| doc.accessors().nth(i as usize)).map(Some).ok_or_else(|| {
            format!("invalid glTF: nodes[{}].extensions.{EXTENSION}.attributes.{key} names no accessor", node.index())
        }),
    };
    Ok(Some([get("TRANSLATION")?, get("ROTATION")?, get("SCALE")?]))
}

/// How many instances each node places (1 without the extension), once its instance
/// accessors are checked: in their buffers (`check`), of the types the extension allows
/// (translation and scale VEC3 float, or integers with KHR_mesh_quantization; rotation VEC4
/// float or normalized byte or short), and of one count.
pub(super) fn counts(
    doc: &Document,
    quantized: bool,
    check: impl Fn(&gltf::Accessor) -> Result<(), String>,
) -> Result<Vec<u64>, String> {
    let mut out = Vec::with_capacity(doc.nodes().len());
    for node in doc.nodes() {
        let Some(attributes) = accessors(doc, &node)? else {
            out.push(1);
            continue;
        };
        let mut count = None;
        for (a, rule) in attributes.iter().zip([Semantic::Positions, Semantic::Tangents, Semantic::Positions]) {
            let Some(a) = a else { continue };
            check(a)?;
            let rotation = matches!(rule, Semantic::Tangents);
            if !attributes::allowed(&rule, a, quantized || rotation) {
                return Err(format!(
                    "invalid glTF: accessor {} is {:?} of {:?}, which an instance {} cannot be",
                    a.index(),
                    a.dimensions(),
                    a.data_type(),
                    if rotation { "rotation" } else { "translation or scale" }
                ));
            }
            if count.is_some_and(|c| c != a.count()) {
                return Err(format!("nodes[{}]: instance attributes have different counts", node.index()));
            }
            count = Some(a.count());
        }
        out.push(count.unwrap_or(1) as u64);
    }
    Ok(out)
}

/// The node's instance transforms (None without the extension), read from accessors that
/// `counts` has checked.
pub(super) fn transforms(doc: &Document, node: &Node, buffers: &[buffer::Data]) -> Result<Option<Vec<DMat4>>, String> {
    let Some([t, r, s]) = accessors(doc, node)? else { return Ok(None) };
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| &d.0[..]);
    let unreadable = |a: &gltf::Accessor| format!("accessor {} cannot be read", a.index());
    let vec3 = |a: &Option<gltf::Accessor>| -> Result<Option<Vec<[f32; 3]>>, String> {
        a.as_ref().map(|a| attributes::read::<3>(a, get).ok_or_else(|| unreadable(a))).transpose()
    };
    let (t, s) = (vec3(&t)?, vec3(&s)?);
    let r = r.as_ref().map(|a| attributes::read::<4>(a, get).ok_or_else(|| unreadable(a))).transpose()?;
    let n = [t.as_ref().map(Vec::len), r.as_ref().map(Vec::len), s.as_ref().map(Vec::len)].into_iter().flatten().max();
    let f64s = |v: [f32; 3]| DVec3::new(v[0].into(), v[1].into(), v[2].into());
    Ok(Some(
        (0..n.unwrap_or(1))
            .map(|i| {
                let translation = t.as_ref().map_or(DVec3::ZERO, |t| f64s(t[i]));
                let scale = s.as_ref().map_or(DVec3::ONE, |s| f64s(s[i]));
                let rotation = r.as_ref().map_or(DQuat::IDENTITY, |r| {
                    let q = r[i].map(f64::from);
                    let q = DQuat::from_xyzw(q[0], q[1], q[2], q[3]);
                    if q.length() > 0.0 && q.is_finite() { q.normalize() } else { DQuat::IDENTITY }
                });
                DMat4::from_scale_rotation_translation(scale, rotation, translation)
            })
            .collect(),
    ))
}

//! KHR_draco_mesh_compression: each compressed primitive decoded by draco-core (a pure-Rust
//! Draco decoder) into plain buffer views for its accessors, within the memory limit.

use super::Refusal;
use super::resources::{Tally, append_buffer};
use draco_core::{DataType, DecodeLimits, DecoderBuffer, Mesh, MeshDecoder};
use gltf::buffer;
use gltf::json::accessor::{ComponentType, GenericComponentType};
use gltf::json::validation::{Checked, USize64};
use gltf::json::{self, Index, Root, Value};

/// The extension's name, in `extensionsUsed` and on mesh primitives.
pub(super) const EXTENSION: &str = "KHR_draco_mesh_compression";

fn compressed(p: &json::mesh::Primitive) -> Option<&Value> {
    p.extensions.as_ref().and_then(|e| e.others.get(EXTENSION))
}

/// Whether any primitive is compressed.
pub(super) fn used(json: &Root) -> bool {
    json.meshes.iter().flat_map(|m| &m.primitives).any(|p| compressed(p).is_some())
}

/// Decodes every compressed primitive of `json` and gives each accessor the extension
/// names (its attributes and its indices) a buffer view of the decoded values in its own
/// component type, appended to `buffers` and counted in `tally`.
pub(super) fn decode(json: &mut Root, buffers: &mut Vec<buffer::Data>, tally: &mut Tally) -> Result<(), Refusal> {
    let mut fills: Vec<(usize, Vec<u8>)> = Vec::new();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let Some(ext) = compressed(prim) else { continue };
            let what = format!("meshes[{m}].primitives[{p}].extensions.{EXTENSION}");
            let decoded = decode_primitive(json, prim, ext, buffers, tally)
                .map_err(|e| Refusal::Invalid(format!("{what}: {e}")))?;
            tally.admit(&what, decoded.iter().map(|(_, b)| b.len() as u64).sum())?;
            fills.extend(decoded);
        }
    }
    for (accessor, bytes) in fills {
        let length = USize64(bytes.len() as u64);
        let buffer = append_buffer(json, buffers, bytes);
        json.buffer_views.push(json::buffer::View {
            buffer: Index::new(buffer),
            byte_length: length,
            byte_offset: None,
            byte_stride: None,
            name: None,
            target: None,
            extensions: None,
            extras: Default::default(),
        });
        let a = &mut json.accessors[accessor];
        a.buffer_view = Some(Index::new(json.buffer_views.len() as u32 - 1));
        a.byte_offset = None;
    }
    Ok(())
}

/// One primitive's accessors (index into `json.accessors`) with their decoded bytes.
fn decode_primitive(
    json: &Root,
    prim: &json::mesh::Primitive,
    ext: &Value,
    buffers: &[buffer::Data],
    tally: &Tally,
) -> Result<Vec<(usize, Vec<u8>)>, String> {
    let view = ext["bufferView"].as_u64().and_then(|v| json.buffer_views.get(v as usize));
    let view = view.ok_or("bufferView is missing or out of range")?;
    let start = view.byte_offset.map_or(0, |o| o.0);
    let bytes = buffers
        .get(view.buffer.value())
        .and_then(|b| {
            b.get(usize::try_from(start).ok()?..usize::try_from(start.checked_add(view.byte_length.0)?).ok()?)
        })
        .ok_or("its bufferView reaches past the end of its buffer")?;
    let mut limits = DecodeLimits::default();
    limits.max_decoded_bytes = tally.room();
    let mut mesh = Mesh::new();
    // draco-core is written not to panic on bad streams (its fuzzing says so); should one
    // slip through, the guard refuses the file rather than the program ending.
    crate::guard::decode("draco-core", || {
        MeshDecoder::new().decode(&mut DecoderBuffer::new(bytes).with_limits(limits), &mut mesh)
    })?
    .map_err(|e| format!("the Draco stream does not decode ({e})"))?;
    let accessor = |i: usize| json.accessors.get(i).ok_or_else(|| format!("accessor {i} does not exist"));
    let mut out = Vec::new();
    let names = ext["attributes"].as_object().ok_or("attributes are missing")?;
    for (name, uid) in names {
        let uid = uid.as_u64().and_then(|u| u32::try_from(u).ok()).ok_or(format!("attribute {name}: bad id"))?;
        let index = prim
            .attributes
            .iter()
            .find(|(s, _)| matches!(s, Checked::Valid(s) if s.to_string() == *name))
            .map(|(_, a)| a.value())
            .ok_or(format!("attribute {name} is not one of the primitive's"))?;
        let a = accessor(index)?;
        let att = mesh.attribute_by_unique_id(uid).ok_or(format!("attribute {name}: no Draco attribute {uid}"))?;
        let Checked::Valid(ty) = a.type_ else { return Err(format!("accessor {index} has an invalid type")) };
        let components = ty.multiplicity();
        let float = att.data_type() == DataType::Float32;
        let component = component_type(a)?;
        if a.count.0 != mesh.num_points() as u64
            || att.num_components() as usize != components
            || float != (component == ComponentType::F32)
            || (!float && att.data_type().byte_length() != component.size())
        {
            return Err(format!(
                "attribute {name} decodes to {} points of {} {:?}, which accessor {index} ({} of {component:?} {ty:?}) does not hold",
                mesh.num_points(),
                att.num_components(),
                att.data_type(),
                a.count.0
            ));
        }
        let values = att.read_f32s(mesh.num_points(), components);
        out.push((index, encode(values.into_iter(), component)));
    }
    if let Some(i) = prim.indices {
        let a = accessor(i.value())?;
        let component = component_type(a)?;
        if a.count.0 != 3 * mesh.num_faces() as u64 {
            return Err(format!(
                "{} triangles decoded for accessor {} of {} indices",
                mesh.num_faces(),
                i.value(),
                a.count.0
            ));
        }
        let max = match component {
            ComponentType::U8 => u8::MAX.into(),
            ComponentType::U16 => u16::MAX.into(),
            _ => u32::MAX,
        };
        let corners = mesh.faces().iter().flatten().map(|p| p.0);
        if corners.clone().any(|c| c > max) {
            return Err(format!("an index does not fit accessor {}'s {component:?}", i.value()));
        }
        let bytes = match component {
            ComponentType::U8 => corners.map(|c| c as u8).collect(),
            ComponentType::U16 => corners.flat_map(|c| (c as u16).to_le_bytes()).collect(),
            _ => corners.flat_map(u32::to_le_bytes).collect(),
        };
        out.push((i.value(), bytes));
    }
    Ok(out)
}

fn component_type(a: &json::Accessor) -> Result<ComponentType, String> {
    match a.component_type {
        Checked::Valid(GenericComponentType(c)) => Ok(c),
        Checked::Invalid => Err("an accessor has an invalid componentType".into()),
    }
}

/// Attribute values (floats, or integers of at most 16 bits, held exactly in f32) as
/// little-endian bytes of `component`.
fn encode(values: impl Iterator<Item = f32>, component: ComponentType) -> Vec<u8> {
    let mut out = Vec::new();
    for v in values {
        match component {
            ComponentType::I8 => out.push(v as i8 as u8),
            ComponentType::U8 => out.push(v as u8),
            ComponentType::I16 => out.extend((v as i16).to_le_bytes()),
            ComponentType::U16 => out.extend((v as u16).to_le_bytes()),
            ComponentType::U32 => out.extend((v as u32).to_le_bytes()),
            ComponentType::F32 => out.extend(v.to_le_bytes()),
        }
    }
    out
}

//! Saving edited materials and lights as glTF. The scene's own file is read again and only
//! what was edited is patched into its JSON, so buffers, images, accessors, nodes, extras
//! and extensions Lucent does not know stay as they were (glTF 2.0; a .glb is written as
//! the spec's section 4.4, "Binary glTF Layout", lays it out, with the same BIN chunk).
//! Patched are:
//!
//! - a material's properties that differ from the file, each where
//!   `scene::edit::MATERIAL_PARAMS` says it lives, the extensions it adds listed in
//!   `extensionsUsed`, and those that no longer apply removed (alphaCutoff once the
//!   alphaMode is not MASK); an edited glTF default material (for primitives without one) is
//!   added;
//! - a light's KHR_lights_punctual entry (colour, intensity, cone angles); lights sharing an
//!   entry but edited apart get a copy of it;
//! - the node placing a moved or turned light: its local transform becomes inverse(parent
//!   world) x new world, its scale kept, turned by the shortest rotation to the new direction.
//!   A node that also holds a mesh, camera, skin or children keeps them where they were and
//!   hands the light to a new child node instead.
//!
//! Numbers are written as the shortest decimal that serde_json reads back (as the loader
//! reads it) to the same f32, so a saved file loads to exactly the edited values.

use super::builtin;
use crate::scene::edit::{LIGHT_PARAMS, MATERIAL_PARAMS, Param, ParamValue, Part, changes, light_problem};
use crate::scene::light::{PunctualKind, PunctualLight};
use crate::scene::material::Material;
use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};
use serde_json::{Map, Value, json};
use std::borrow::Cow;
use std::collections::{BTreeSet, HashMap};
use std::path::{Component, Path, PathBuf};

/// A scene's materials and lights as loaded and as edited (the same lists, in the same order).
#[derive(Clone, Copy)]
pub struct Edits<'a> {
    /// As loaded from the file.
    pub original: (&'a [Material], &'a [PunctualLight]),
    /// As edited.
    pub edited: (&'a [Material], &'a [PunctualLight]),
}

/// The glTF file at `source` (None: the built-in Cornell box) with `edits` patched in, as
/// the bytes to write at `out`: a .glb for a .glb, a .gltf for a .gltf, whose relative
/// buffer and image URIs are rewritten to reach the same files from `out`'s folder.
/// Errors are one line.
pub fn patched(source: Option<&Path>, edits: Edits<'_>, out: &Path) -> Result<Vec<u8>, String> {
    let name = source.map_or_else(|| "the built-in Cornell box".to_string(), |p| p.display().to_string());
    let bytes = match source {
        Some(p) => std::fs::read(p).map_err(|e| format!("cannot read {name}: {e}"))?,
        None => builtin::cornell_box_gltf().to_vec(),
    };
    let binary = bytes.starts_with(b"glTF");
    let wanted = if binary { "glb" } else { "gltf" };
    if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case(wanted)) {
        let what = if binary { "binary glTF (it holds its buffer)" } else { "a .gltf" };
        return Err(format!("{} must end in .{wanted}: {name} is {what}", out.display()));
    }
    let invalid = |e: &dyn std::fmt::Display| format!("cannot read {name} as glTF: {e}");
    let glb = if binary { Some(gltf::binary::Glb::from_slice(&bytes).map_err(|e| invalid(&e))?) } else { None };
    let json_bytes = glb.as_ref().map_or(&bytes[..], |g| &g.json[..]);
    let mut doc: Value = serde_json::from_slice(json_bytes).map_err(|e| invalid(&e))?;
    let fail = |e: String| format!("cannot save {name}: {e}");
    let mut used = BTreeSet::new();
    patch_materials(&mut doc, edits, &mut used).map_err(fail)?;
    patch_lights(&mut doc, edits, &mut used).map_err(fail)?;
    list_extensions(&mut doc, &used).map_err(fail)?;
    if let (Some(source), false) = (source, binary) {
        rebase_uris(&mut doc, source, out).map_err(fail)?;
    }
    match glb {
        Some(glb) => {
            let json = serde_json::to_vec(&doc).map_err(|e| e.to_string())?;
            let glb = gltf::binary::Glb { json: Cow::Owned(json), ..glb };
            glb.to_vec().map_err(|e| e.to_string())
        }
        None => serde_json::to_vec_pretty(&doc).map_err(|e| e.to_string()),
    }
}

/// The JSON number that serde_json reads back as `x` (the shortest decimal if it does,
/// otherwise `x` widened exactly).
fn number(x: f32) -> Value {
    let shortest: f64 = x.to_string().parse().unwrap_or(x as f64);
    let text = serde_json::to_string(&shortest).unwrap_or_default();
    let exact = if serde_json::from_str::<f32>(&text).is_ok_and(|y| y == x) { shortest } else { x as f64 };
    json!(exact)
}

fn triple(v: Vec3) -> Value {
    Value::Array(v.to_array().map(number).to_vec())
}

/// The object at `key` in `object`, made if missing.
fn object<'a>(object: &'a mut Map<String, Value>, key: &str) -> Result<&'a mut Map<String, Value>, String> {
    object.entry(key).or_insert_with(|| json!({})).as_object_mut().ok_or_else(|| format!("{key} is not an object"))
}

/// The array at `path` inside `doc`.
fn array<'a>(doc: &'a mut Value, path: &[&str]) -> Result<&'a mut Vec<Value>, String> {
    let mut v = doc;
    for key in path {
        v = v.get_mut(key).ok_or_else(|| format!("the file has no {}", path.join(".")))?;
    }
    v.as_array_mut().ok_or_else(|| format!("{} is not an array", path.join(".")))
}

/// Writes `value` of parameter `p` into `target` (a material or a light entry), noting the
/// extension it lives in. The value is checked against the parameter's range first.
fn write<T>(
    target: &mut Map<String, Value>,
    p: &Param<T>,
    value: ParamValue,
    used: &mut BTreeSet<String>,
) -> Result<(), String> {
    p.kind.check(value).map_err(|e| format!("{}: {e}", p.name()))?;
    if let Some(extension) = p.section.extension() {
        used.insert(extension.to_string());
    }
    let keys: Vec<&str> = p.keys().collect();
    let (last, parents) = keys.split_last().ok_or("a parameter without a path")?;
    let mut object = target;
    for key in parents {
        object = self::object(object, key)?;
    }
    let element = |i: usize, value: Value, object: &mut Map<String, Value>| {
        let mut rgba = match object.get(*last).and_then(Value::as_array) {
            Some(a) if a.len() == 4 => a.clone(),
            _ => vec![json!(1.0); 4],
        };
        rgba[i] = value;
        object.insert(last.to_string(), Value::Array(rgba));
    };
    match (p.part, value) {
        (Part::Rgb, ParamValue::Triple(c)) => (0..3).for_each(|i| element(i, number(c[i]), object)),
        (Part::Alpha, ParamValue::Number(a)) => element(3, number(a), object),
        (_, ParamValue::Number(x)) if x == f32::INFINITY => {
            object.remove(*last);
        }
        (_, ParamValue::Number(x)) => {
            object.insert(last.to_string(), number(x));
        }
        (_, ParamValue::Triple(v)) => {
            object.insert(last.to_string(), triple(v));
        }
        (_, ParamValue::Switch(b)) => {
            object.insert(last.to_string(), json!(b));
        }
        (_, ParamValue::Choice(c)) => {
            object.insert(last.to_string(), json!(c));
        }
    }
    Ok(())
}

/// Removes parameter `p` from `target`, where the file has it.
fn remove<T>(target: &mut Map<String, Value>, p: &Param<T>) {
    let keys: Vec<&str> = p.keys().collect();
    let Some((last, parents)) = keys.split_last() else { return };
    if let Some(object) = parents.iter().try_fold(target, |o, key| o.get_mut(*key)?.as_object_mut()) {
        object.remove(*last);
    }
}

/// Writes into `target` every parameter of `table` that differs between `original` and
/// `edited` and applies to it, and removes those that applied to `original` but no longer
/// do (alphaCutoff once the alphaMode is not MASK). A light's node is not its entry: its
/// place is moved apart.
fn write_changes<T>(
    target: &mut Map<String, Value>,
    table: &'static [Param<T>],
    (original, edited): (&T, &T),
    used: &mut BTreeSet<String>,
) -> Result<(), String> {
    for (p, value) in changes(table, original, edited) {
        if (p.applies)(edited) && p.part != Part::Node {
            write(target, p, value, used)?;
        }
    }
    for p in table.iter().filter(|p| (p.applies)(original) && !(p.applies)(edited) && p.part != Part::Node) {
        remove(target, p);
    }
    Ok(())
}

fn patch_materials(doc: &mut Value, edits: Edits<'_>, used: &mut BTreeSet<String>) -> Result<(), String> {
    let (original, edited) = (edits.original.0, edits.edited.0);
    if original.len() != edited.len() {
        return Err(format!("{} materials were loaded but {} are given", original.len(), edited.len()));
    }
    for (o, e) in original.iter().zip(edited).filter(|(o, e)| o != e) {
        let fail = |err: String| format!("material {:?}: {err}", e.name);
        let index = match e.file_index {
            Some(i) => i as usize,
            None => add_default_material(doc, &e.name).map_err(fail)?,
        };
        let materials = array(doc, &["materials"]).map_err(fail)?;
        let target = materials
            .get_mut(index)
            .and_then(Value::as_object_mut)
            .ok_or_else(|| fail(format!("the file has no material {index}")))?;
        write_changes(target, MATERIAL_PARAMS, (o, e), used).map_err(fail)?;
    }
    Ok(())
}

/// Adds a material named `name` for the primitives that have none (glTF's default
/// material, which the loader adds when they exist) and returns its index.
fn add_default_material(doc: &mut Value, name: &str) -> Result<usize, String> {
    let root = doc.as_object_mut().ok_or("the file is not a JSON object")?;
    let materials = root.entry("materials").or_insert_with(|| json!([]));
    let list = materials.as_array_mut().ok_or("materials is not an array")?;
    let index = list.len();
    list.push(json!({ "name": name }));
    for mesh in root.get_mut("meshes").and_then(Value::as_array_mut).into_iter().flatten() {
        for prim in mesh.get_mut("primitives").and_then(Value::as_array_mut).into_iter().flatten() {
            if let Some(prim) = prim.as_object_mut().filter(|p| !p.contains_key("material")) {
                prim.insert("material".into(), json!(index));
            }
        }
    }
    Ok(index)
}

/// What a light's KHR_lights_punctual entry holds: colour, intensity, kind with its cone.
type Entry = (Vec3, f32, PunctualKind);

fn entry_of(l: &PunctualLight) -> Entry {
    (l.color, l.intensity, l.kind)
}

fn patch_lights(doc: &mut Value, edits: Edits<'_>, used: &mut BTreeSet<String>) -> Result<(), String> {
    let (original, edited) = (edits.original.1, edits.edited.1);
    if original.len() != edited.len() {
        return Err(format!("{} lights were loaded but {} are given", original.len(), edited.len()));
    }
    if original == edited {
        return Ok(());
    }
    let entries_path = ["extensions", "KHR_lights_punctual", "lights"];
    let file_entries = array(doc, &entries_path).map(|a| a.clone()).unwrap_or_default();
    // What each entry holds once patched, with the file's entry it was copied from, and
    // which entry and place each node ends up with.
    let mut holds: HashMap<u32, (Entry, u32)> = HashMap::new();
    let mut nodes: HashMap<u32, (u32, Vec3, Vec3)> = HashMap::new();
    for (o, e) in original.iter().zip(edited) {
        let fail = |err: String| format!("light {:?}: {err}", e.name);
        if let Some(problem) = light_problem(e) {
            return Err(fail(problem));
        }
        let Some(source) = e.source else {
            if o != e {
                return Err(fail("it is not from the file".into()));
            }
            continue;
        };
        let same = |(held, from): &(Entry, u32)| *from == source.light && *held == entry_of(e);
        // At most one entry holds what this light needs: it is shared, not copied again.
        let entry = if let Some((&index, _)) = holds.iter().find(|(_, h)| same(h)) {
            index
        } else if !holds.contains_key(&source.light) {
            holds.insert(source.light, (entry_of(e), source.light));
            let entries = array(doc, &entries_path).map_err(fail)?;
            let target = entries
                .get_mut(source.light as usize)
                .and_then(Value::as_object_mut)
                .ok_or_else(|| fail(format!("the file has no light {}", source.light)))?;
            write_changes(target, LIGHT_PARAMS, (o, e), used).map_err(fail)?;
            source.light
        } else {
            let mut copy = file_entries.get(source.light as usize).cloned().unwrap_or_else(|| json!({}));
            let target = copy.as_object_mut().ok_or_else(|| fail("its entry is not an object".into()))?;
            write_changes(target, LIGHT_PARAMS, (o, e), used).map_err(fail)?;
            let entries = array(doc, &entries_path).map_err(fail)?;
            entries.push(copy);
            let index = entries.len() as u32 - 1;
            holds.insert(index, (entry_of(e), source.light));
            index
        };
        let place = (entry, e.position, e.direction);
        if *nodes.entry(source.node).or_insert(place) != place {
            return Err(fail(format!("node {} places it more than once, so its copies cannot differ", source.node)));
        }
        if entry != source.light {
            name_entry(doc, source.node, entry).map_err(fail)?;
        }
        if (o.position, o.direction) != (e.position, e.direction) {
            move_light(doc, source.node, source.parent, (o, e), entry).map_err(fail)?;
        }
    }
    Ok(())
}

/// Makes node `index` place KHR_lights_punctual light `entry`.
fn name_entry(doc: &mut Value, index: u32, entry: u32) -> Result<(), String> {
    let node = array(doc, &["nodes"])?
        .get_mut(index as usize)
        .and_then(Value::as_object_mut)
        .ok_or_else(|| format!("the file has no node {index}"))?;
    object(object(node, "extensions")?, "KHR_lights_punctual")?.insert("light".into(), json!(entry));
    Ok(())
}

/// The numbers of a node's property `key` as the loader reads them (f32), or `default`.
fn node_numbers(node: &Map<String, Value>, key: &str, default: &[f64]) -> Vec<f64> {
    match node.get(key).and_then(Value::as_array) {
        Some(a) if a.len() == default.len() => {
            a.iter().zip(default).map(|(v, d)| v.as_f64().map_or(*d, |x| x as f32 as f64)).collect()
        }
        _ => default.to_vec(),
    }
}

/// A node's rotation (the identity without one).
fn node_rotation(node: &Map<String, Value>) -> DQuat {
    DQuat::from_slice(&node_numbers(node, "rotation", &[0.0, 0.0, 0.0, 1.0])).normalize()
}

/// A node's local transform as the loader reads it (its matrix, or T x R x S).
fn local_transform(node: &Map<String, Value>) -> DMat4 {
    if node.contains_key("matrix") {
        return DMat4::from_cols_slice(&node_numbers(node, "matrix", &DMat4::IDENTITY.to_cols_array()));
    }
    let t = node_numbers(node, "translation", &[0.0; 3]);
    let s = node_numbers(node, "scale", &[1.0; 3]);
    DMat4::from_scale_rotation_translation(DVec3::from_slice(&s), node_rotation(node), DVec3::from_slice(&t))
}

/// Moves the light that node `index` (whose parent's transform is `parent`) places as
/// `e` says: its translation to the new position, turned by the shortest rotation from the
/// old direction to the new one; only what changed is written (a matrix's translation
/// column alone when only the position changed). A node holding more than the light (a
/// mesh, camera, skin or children) keeps its transform and hands light `entry` to a new
/// child node instead.
fn move_light(
    doc: &mut Value,
    index: u32,
    parent: DMat4,
    (o, e): (&PunctualLight, &PunctualLight),
    entry: u32,
) -> Result<(), String> {
    let nodes = array(doc, &["nodes"])?;
    let child = nodes.len();
    let node = nodes
        .get_mut(index as usize)
        .and_then(Value::as_object_mut)
        .ok_or_else(|| format!("the file has no node {index}"))?;
    let shared = ["mesh", "camera", "skin", "children"].iter().any(|k| node.contains_key(*k));
    let (parent, local) = if shared {
        let local = local_transform(node);
        let extensions = object(node, "extensions")?;
        extensions.remove("KHR_lights_punctual");
        if extensions.is_empty() {
            node.remove("extensions");
        }
        let children = node.entry("children").or_insert_with(|| json!([]));
        children.as_array_mut().ok_or("its node's children are not a list")?.push(json!(child));
        (parent * local, DMat4::IDENTITY)
    } else {
        (parent, local_transform(node))
    };
    if parent.determinant() == 0.0 || !parent.is_finite() {
        return Err("its node's parent has no inverse (a zero scale)".into());
    }
    let to_local = parent.inverse();
    let translation = (e.position != o.position).then(|| to_local.transform_point3(e.position.as_dvec3()));
    let turn = (e.direction != o.direction).then(|| {
        let target = to_local.transform_vector3(e.direction.as_dvec3()).normalize();
        DQuat::from_rotation_arc(local.transform_vector3(-DVec3::Z).normalize(), target)
    });
    if !(translation.is_none_or(DVec3::is_finite) && turn.is_none_or(DQuat::is_finite)) {
        return Err("its new place cannot be written in its node's frame".into());
    }
    let numbers = |v: &[f64]| Value::Array(v.iter().map(|&x| number(x as f32)).collect());
    let mut light_node = Map::new();
    let node = if shared {
        light_node.insert("name".into(), json!(format!("{} (moved)", e.name)));
        light_node.insert("extensions".into(), json!({ "KHR_lights_punctual": { "light": entry } }));
        &mut light_node
    } else {
        array(doc, &["nodes"])?[index as usize].as_object_mut().ok_or("its node is not an object")?
    };
    match (node.get_mut("matrix").and_then(Value::as_array_mut), translation, turn) {
        (Some(matrix), Some(t), None) if matrix.len() == 16 => {
            (0..3).for_each(|i| matrix[12 + i] = number(t[i] as f32));
        }
        (Some(_), ..) => {
            let linear = DMat3::from_quat(turn.unwrap_or_default()) * DMat3::from_mat4(local);
            let t = translation.unwrap_or(local.w_axis.truncate());
            node.insert("matrix".into(), numbers(&DMat4::from_mat3_translation(linear, t).to_cols_array()));
        }
        (None, ..) => {
            if let Some(t) = translation {
                node.insert("translation".into(), numbers(&t.to_array()));
            }
            if let Some(q) = turn {
                node.insert("rotation".into(), numbers(&(q * node_rotation(node)).normalize().to_array()));
            }
        }
    }
    if shared {
        array(doc, &["nodes"])?.push(Value::Object(light_node));
    }
    Ok(())
}

/// Lists each extension in `used` in the file's extensionsUsed.
fn list_extensions(doc: &mut Value, used: &BTreeSet<String>) -> Result<(), String> {
    if used.is_empty() {
        return Ok(());
    }
    let root = doc.as_object_mut().ok_or("the file is not a JSON object")?;
    let list = root.entry("extensionsUsed").or_insert_with(|| json!([]));
    let list = list.as_array_mut().ok_or("extensionsUsed is not a list")?;
    for name in used {
        if !list.iter().any(|v| v.as_str() == Some(name)) {
            list.push(json!(name));
        }
    }
    Ok(())
}

/// Rewrites the relative URIs of buffers and images (percent-encoded paths from `source`'s
/// folder) to reach the same files from `out`'s folder; nothing changes when it is the same.
fn rebase_uris(doc: &mut Value, source: &Path, out: &Path) -> Result<(), String> {
    let folder = |p: &Path| {
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::canonicalize(dir).map_err(|e| format!("{}: {e}", dir.display()))
    };
    let (from, to) = (folder(source)?, folder(out)?);
    if from == to {
        return Ok(());
    }
    for list in ["buffers", "images"] {
        for item in doc.get_mut(list).and_then(Value::as_array_mut).into_iter().flatten() {
            let Some(uri) = item.get("uri").and_then(Value::as_str) else { continue };
            if uri.contains(':') {
                continue;
            }
            let decoded = urlencoding::decode(uri).map_err(|_| format!("{list} URI {uri} is not UTF-8"))?;
            let rebased = relative(&to, &from.join(&*decoded))
                .ok_or_else(|| format!("{} cannot name {} by a relative path", out.display(), decoded))?;
            item["uri"] = json!(rebased);
        }
    }
    Ok(())
}

/// The percent-encoded relative URI of `target` from folder `from` (both absolute).
fn relative(from: &Path, target: &Path) -> Option<String> {
    fn normal(p: &Path) -> Vec<Component<'_>> {
        let mut parts: Vec<Component> = Vec::new();
        for c in p.components() {
            match c {
                Component::ParentDir if matches!(parts.last(), Some(Component::Normal(_))) => {
                    parts.pop();
                }
                Component::CurDir => {}
                c => parts.push(c),
            }
        }
        parts
    }
    let (from, target) = (normal(from), normal(target));
    if from.first() != target.first() {
        return None;
    }
    let common = from.iter().zip(&target).take_while(|(a, b)| a == b).count();
    let mut parts: Vec<String> = vec!["..".into(); from.len() - common];
    for c in &target[common..] {
        parts.push(urlencoding::encode(&c.as_os_str().to_string_lossy()).into_owned());
    }
    Some(parts.join("/"))
}

/// Where the viewer suggests saving `source`: beside it, `NAME.tuned.gltf` (or `.glb`), and
/// a tuned file over itself (`NAME.tuned.gltf` again, not `NAME.tuned.tuned.gltf`); for the
/// built-in scene, `cornell-box.tuned.gltf` in the current folder.
pub fn default_path(source: Option<&Path>) -> PathBuf {
    let Some(source) = source else { return PathBuf::from("cornell-box.tuned.gltf") };
    let stem = source.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let stem = stem.strip_suffix(".tuned").unwrap_or(&stem);
    let binary = std::fs::read(source).is_ok_and(|b| b.starts_with(b"glTF"))
        || source.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    source.with_file_name(format!("{stem}.tuned.{}", if binary { "glb" } else { "gltf" }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_back_as_the_same_f32() {
        for x in [0.2f32, 0.1, 1.0 / 3.0, 17.0, 1e-7, 3.4e38, 12.0 / 17.0, f32::MIN_POSITIVE, 123_456.79] {
            let text = serde_json::to_string(&number(x)).unwrap();
            assert_eq!(serde_json::from_str::<f32>(&text).unwrap(), x, "{text}");
        }
        assert_eq!(serde_json::to_string(&number(0.2)).unwrap(), "0.2", "the shortest decimal");
    }

    #[test]
    fn relative_uris_climb_and_encode() {
        let rel = relative(Path::new("/a/b/out"), Path::new("/a/b/src/x y.bin"));
        assert_eq!(rel.as_deref(), Some("../src/x%20y.bin"));
        assert_eq!(relative(Path::new("/a"), Path::new("/a/c/../d.png")).as_deref(), Some("d.png"));
    }
}

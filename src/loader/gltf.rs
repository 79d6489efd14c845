//! glTF 2.0 loading (.gltf with external or embedded buffers, .glb) with the gltf crate:
//! node transforms flattened into world-space meshes, materials, textures, punctual lights
//! and cameras. Anything not supported yet is reported once as a warning, never dropped silently.
//! Transforms are composed in f64 and everything is stored relative to the centre of the
//! scene's bounds, so a model placed far from the origin keeps its f32 precision.

use super::LoadError;
use crate::scene::{
    MeshDesc, SceneDesc,
    camera::Camera,
    light::{PunctualKind, PunctualLight},
    material::{AlphaMode, Material, TexRef},
    texture::{Image, Texture, Wrap},
};
use glam::{Affine2, DMat3, DMat4, DVec3, Vec2, Vec3, Vec4};
use gltf::json::Value;
use gltf::{Document, Semantic, buffer, image, khr_lights_punctual::Kind, mesh::Mode, texture::WrappingMode};
use std::collections::BTreeSet;
use std::path::Path;

/// Extensions whose every part that matters to shading is honoured.
const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "KHR_xmp",
];

/// Deepest node hierarchy accepted (guards against cyclic or absurd files).
const MAX_NODE_DEPTH: usize = 256;

/// Loads a .gltf or .glb file.
pub fn load(path: &Path) -> Result<SceneDesc, LoadError> {
    let fail = |reason: String| LoadError::File { path: path.to_owned(), reason };
    if !path.is_file() {
        return Err(fail(if path.exists() { "not a file".into() } else { "no such file".into() }));
    }
    let bytes = std::fs::read(path).map_err(|e| fail(e.to_string()))?;
    let (doc, buffers, images) = import(&bytes, path.parent()).map_err(fail)?;
    let name = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let mut desc = convert(&doc, &buffers, images, name).map_err(&fail)?;
    super::sidecar::apply(&mut desc, path).map_err(fail)?;
    Ok(desc)
}

/// Loads glTF from memory (embedded or GLB buffers only).
pub fn load_slice(bytes: &[u8], name: &str) -> Result<SceneDesc, LoadError> {
    let fail = |reason: String| LoadError::File { path: name.into(), reason };
    let (doc, buffers, images) = import(bytes, None).map_err(fail)?;
    convert(&doc, &buffers, images, name.into()).map_err(fail)
}

/// Parses, validates and reads buffers and images (relative to `base`, if given).
fn import(bytes: &[u8], base: Option<&Path>) -> Result<(Document, Vec<buffer::Data>, Vec<image::Data>), String> {
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| describe(&e))?;
    check_position_accessors(&document)?;
    let document = Document::from_json(document.into_json()).map_err(|e| describe(&e))?;
    check_image_sources(&document)?;
    let buffers = gltf::import_buffers(&document, base, blob).map_err(|e| describe(&e))?;
    check_buffer_views(&document, &buffers)?;
    let images = gltf::import_images(&document, base, &buffers).map_err(|e| describe(&e))?;
    Ok((document, buffers, images))
}

/// Rejects a POSITION attribute naming a missing accessor: gltf-json 1.4.1's validation
/// indexes the accessor list with it unchecked and would panic.
fn check_position_accessors(document: &Document) -> Result<(), String> {
    use gltf::json::{mesh::Semantic as JsonSemantic, validation::Checked};
    let json = document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(index) = prim.attributes.get(&Checked::Valid(JsonSemantic::Positions))
                && index.value() >= json.accessors.len()
            {
                return Err(format!(
                    "invalid glTF: meshes[{m}].primitives[{p}].attributes.POSITION: accessor {} does not exist",
                    index.value()
                ));
            }
        }
    }
    Ok(())
}

/// Rejects an image with neither a uri nor a bufferView, or a bufferView without a
/// mimeType (both required by the spec): gltf 1.4.1 does not validate them and unwraps.
fn check_image_sources(document: &Document) -> Result<(), String> {
    for (i, image) in document.as_json().images.iter().enumerate() {
        match (&image.uri, &image.buffer_view, &image.mime_type) {
            (None, None, _) => return Err(format!("invalid glTF: images[{i}] has neither uri nor bufferView")),
            (_, Some(_), None) => return Err(format!("invalid glTF: images[{i}] has a bufferView but no mimeType")),
            _ => {}
        }
    }
    Ok(())
}

/// Rejects a bufferView reaching past the end of its buffer's data: gltf 1.4.1 slices
/// image data with it unchecked and would panic.
fn check_buffer_views(document: &Document, buffers: &[buffer::Data]) -> Result<(), String> {
    for view in document.views() {
        let len = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
        if view.offset().checked_add(view.length()).is_none_or(|end| end > len) {
            return Err(format!("invalid glTF: bufferViews[{}] reaches past the end of its buffer", view.index()));
        }
    }
    Ok(())
}

/// One line for a gltf error (validation errors list only the first).
fn describe(e: &gltf::Error) -> String {
    match e {
        gltf::Error::Validation(errors) => match errors.first() {
            Some((path, err)) if errors.len() > 1 => {
                format!("invalid glTF: {path}: {err} (and {} more)", errors.len() - 1)
            }
            Some((path, err)) => format!("invalid glTF: {path}: {err}"),
            None => "invalid glTF".into(),
        },
        other => other.to_string().replace('\n', " "),
    }
}

/// Collects warnings without repeating one.
#[derive(Default)]
struct Warnings(BTreeSet<String>);

impl Warnings {
    fn add(&mut self, w: impl Into<String>) {
        self.0.insert(w.into());
    }
}

fn convert(
    doc: &Document,
    buffers: &[buffer::Data],
    images: Vec<image::Data>,
    name: String,
) -> Result<SceneDesc, String> {
    let mut warnings = Warnings::default();
    for ext in doc.extensions_used() {
        if !SUPPORTED_EXTENSIONS.contains(&ext) {
            warnings.add(format!("extension {ext} is not supported yet: ignored"));
        }
    }
    let mut desc = SceneDesc { name, ..SceneDesc::default() };
    desc.images = images.into_iter().map(convert_image).collect();
    desc.textures = doc.textures().map(convert_texture).collect();
    let texture_count = desc.textures.len();
    desc.materials = doc.materials().map(|m| convert_material(&m, texture_count, &mut warnings)).collect();
    let default_material = desc.materials.len() as u32;

    let scene = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s,
        None => {
            warnings.add("the file has no scene: nothing to render");
            desc.warnings = warnings.0.into_iter().collect();
            return Ok(desc);
        }
    };
    let mut placed: Vec<(MeshDesc, Vec<DVec3>)> = Vec::new();
    let mut lights: Vec<(PunctualLight, DVec3)> = Vec::new();
    let mut cameras: Vec<(String, Camera, DVec3)> = Vec::new();
    let mut stack: Vec<(gltf::Node, DMat4, usize)> = scene.nodes().map(|n| (n, DMat4::IDENTITY, 0)).collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > MAX_NODE_DEPTH {
            return Err(format!("node hierarchy deeper than {MAX_NODE_DEPTH} (cyclic?)"));
        }
        let world = parent * DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let normal_mapped = prim.material().normal_texture().is_some();
                if let Some((m, p)) =
                    convert_primitive(&prim, buffers, world, default_material, normal_mapped, &mut warnings)?
                {
                    placed.push((MeshDesc { name: mesh.name().unwrap_or("mesh").into(), ..m }, p));
                }
            }
        }
        if let Some(light) = node.light() {
            lights.push(convert_light(&light, world));
        }
        if let Some(camera) = node.camera() {
            match camera.projection() {
                gltf::camera::Projection::Perspective(p) => {
                    let (_, rotation, position) = world.to_scale_rotation_translation();
                    let cam = Camera { position: Vec3::ZERO, rotation: rotation.as_quat().normalize(), yfov: p.yfov() };
                    cameras.push((camera.name().unwrap_or("camera").into(), cam, position));
                }
                gltf::camera::Projection::Orthographic(_) => {
                    warnings.add("orthographic cameras are not supported yet: ignored");
                }
            }
        }
        stack.extend(node.children().map(|c| (c, world, depth + 1)));
    }
    let bounds = placed
        .iter()
        .flat_map(|(_, p)| p)
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    let centre = if bounds.0.is_finite() && bounds.1.is_finite() { 0.5 * (bounds.0 + bounds.1) } else { DVec3::ZERO };
    let relative = |p: DVec3| (p - centre).as_vec3();
    desc.meshes = placed
        .into_iter()
        .map(|(mesh, p)| MeshDesc { positions: p.into_iter().map(relative).collect(), ..mesh })
        .collect();
    desc.lights = lights.into_iter().map(|(l, p)| PunctualLight { position: relative(p), ..l }).collect();
    desc.cameras = cameras.into_iter().map(|(n, c, p)| (n, Camera { position: relative(p), ..c })).collect();
    if desc.meshes.iter().any(|m| m.material == default_material) {
        desc.materials.push(Material { name: "glTF default".into(), ..Material::default() });
    }
    desc.warnings = warnings.0.into_iter().collect();
    Ok(desc)
}

fn convert_image(data: image::Data) -> Image {
    use image::Format as F;
    let (w, h) = (data.width, data.height);
    let px = &data.pixels;
    let n = (w * h) as usize;
    let u16_at = |i: usize| (u16::from_le_bytes([px[2 * i], px[2 * i + 1]]) >> 8) as u8;
    let f32_at = |i: usize| {
        let v = f32::from_le_bytes([px[4 * i], px[4 * i + 1], px[4 * i + 2], px[4 * i + 3]]);
        (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
    };
    let texels = (0..n)
        .map(|i| match data.format {
            F::R8 => [px[i], px[i], px[i], 255],
            F::R8G8 => [px[2 * i], px[2 * i + 1], 0, 255],
            F::R8G8B8 => [px[3 * i], px[3 * i + 1], px[3 * i + 2], 255],
            F::R8G8B8A8 => [px[4 * i], px[4 * i + 1], px[4 * i + 2], px[4 * i + 3]],
            F::R16 => {
                let v = u16_at(i);
                [v, v, v, 255]
            }
            F::R16G16 => [u16_at(2 * i), u16_at(2 * i + 1), 0, 255],
            F::R16G16B16 => [u16_at(3 * i), u16_at(3 * i + 1), u16_at(3 * i + 2), 255],
            F::R16G16B16A16 => [u16_at(4 * i), u16_at(4 * i + 1), u16_at(4 * i + 2), u16_at(4 * i + 3)],
            F::R32G32B32FLOAT => [f32_at(3 * i), f32_at(3 * i + 1), f32_at(3 * i + 2), 255],
            F::R32G32B32A32FLOAT => [f32_at(4 * i), f32_at(4 * i + 1), f32_at(4 * i + 2), f32_at(4 * i + 3)],
        })
        .collect();
    Image { width: w, height: h, texels }
}

fn convert_texture(t: gltf::Texture) -> Texture {
    let wrap = |m: WrappingMode| match m {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    };
    let s = t.sampler();
    Texture {
        image: t.source().index() as u32,
        wrap: [wrap(s.wrap_s()), wrap(s.wrap_t())],
        nearest: s.mag_filter() == Some(gltf::texture::MagFilter::Nearest),
    }
}

/// KHR_texture_transform as an affine map: translation x rotation x scale, rotating
/// counter-clockwise in UV space (so that offset (0, 1), rotation pi/2, scale 0.5 picks the
/// lower-left quadrant turned clockwise, as the extension's example says).
fn uv_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> Affine2 {
    let (s, c) = rotation.sin_cos();
    let rotate = Affine2::from_cols(Vec2::new(c, -s), Vec2::new(s, c), Vec2::ZERO);
    Affine2::from_translation(Vec2::from(offset)) * rotate * Affine2::from_scale(Vec2::from(scale))
}

/// A texture slot given as raw JSON (textureInfo: index, texCoord, KHR_texture_transform).
fn texture_json(info: Option<&Value>, texture_count: usize, warnings: &mut Warnings) -> Option<TexRef> {
    let info = info?;
    let index = info.get("index")?.as_u64()?;
    if index as usize >= texture_count {
        warnings.add(format!("texture index {index} is out of range: slot ignored"));
        return None;
    }
    let mut set = info.get("texCoord").and_then(Value::as_u64).unwrap_or(0);
    let mut transform = Affine2::IDENTITY;
    if let Some(t) = info.get("extensions").and_then(|e| e.get("KHR_texture_transform")) {
        let pair = |key: &str, default: [f32; 2]| {
            t.get(key)
                .and_then(Value::as_array)
                .map_or(default, |a| [0, 1].map(|i| a.get(i).and_then(Value::as_f64).map_or(default[i], |v| v as f32)))
        };
        let rotation = t.get("rotation").and_then(Value::as_f64).unwrap_or(0.0) as f32;
        transform = uv_transform(pair("offset", [0.0, 0.0]), rotation, pair("scale", [1.0, 1.0]));
        set = t.get("texCoord").and_then(Value::as_u64).unwrap_or(set);
    }
    if set > 1 {
        warnings.add("textures on TEXCOORD sets above 1 are not supported: read from set 1");
    }
    Some(TexRef { texture: index as u32, set: set.min(1) as u8, transform })
}

/// A texture slot the gltf crate parsed.
fn texture_ref(info: Option<gltf::texture::Info>, warnings: &mut Warnings) -> Option<TexRef> {
    let info = info?;
    let mut set = info.tex_coord();
    let mut transform = Affine2::IDENTITY;
    if let Some(t) = info.texture_transform() {
        transform = uv_transform(t.offset(), t.rotation(), t.scale());
        set = t.tex_coord().unwrap_or(set);
    }
    if set > 1 {
        warnings.add("textures on TEXCOORD sets above 1 are not supported: read from set 1");
    }
    Some(TexRef { texture: info.texture().index() as u32, set: set.min(1) as u8, transform })
}

fn factor(v: &Value, key: &str, default: f32) -> f32 {
    v.get(key).and_then(Value::as_f64).map_or(default, |f| f as f32)
}

fn convert_material(m: &gltf::Material, texture_count: usize, warnings: &mut Warnings) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, a] = pbr.base_color_factor();
    if m.occlusion_texture().is_some() {
        warnings.add("occlusion textures are ignored (a path tracer computes occlusion)");
    }
    let mut mat = Material {
        name: m.name().map_or_else(|| format!("material {}", m.index().unwrap_or(0)), str::to_owned),
        base_color: Vec3::new(r, g, b),
        alpha: a,
        alpha_mode: match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5)),
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        },
        double_sided: m.double_sided(),
        base_color_tex: texture_ref(pbr.base_color_texture(), warnings),
        metallic: pbr.metallic_factor(),
        roughness: pbr.roughness_factor(),
        metallic_roughness_tex: texture_ref(pbr.metallic_roughness_texture(), warnings),
        emissive: Vec3::from(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0),
        emissive_tex: texture_ref(m.emissive_texture(), warnings),
        ior: m.ior().unwrap_or(1.5),
        ..Material::default()
    };
    if let Some(n) = m.normal_texture() {
        let json = serde_json_value(&n);
        mat.normal_tex = texture_json(Some(&json), texture_count, warnings);
        mat.normal_scale = n.scale();
    }
    if let Some(s) = m.specular() {
        mat.specular = s.specular_factor();
        mat.specular_tex = texture_ref(s.specular_texture(), warnings);
        mat.specular_color = Vec3::from(s.specular_color_factor());
        mat.specular_color_tex = texture_ref(s.specular_color_texture(), warnings);
    }
    if let Some(t) = m.transmission() {
        mat.transmission = t.transmission_factor();
        mat.transmission_tex = texture_ref(t.transmission_texture(), warnings);
    }
    if let Some(v) = m.volume().filter(|v| v.thickness_factor() > 0.0) {
        // Beer-Lambert: attenuationColor is what remains after attenuationDistance.
        let distance = v.attenuation_distance();
        let color = Vec3::from(v.attenuation_color()).clamp(Vec3::splat(1e-6), Vec3::ONE);
        let sigma = if distance.is_finite() && distance > 0.0 { -color.map(f32::ln) / distance } else { Vec3::ZERO };
        mat.volume = Some(sigma);
    }
    if let Some(c) = m.extension_value("KHR_materials_clearcoat") {
        mat.clearcoat = factor(c, "clearcoatFactor", 0.0);
        mat.clearcoat_tex = texture_json(c.get("clearcoatTexture"), texture_count, warnings);
        mat.clearcoat_roughness = factor(c, "clearcoatRoughnessFactor", 0.0);
        mat.clearcoat_roughness_tex = texture_json(c.get("clearcoatRoughnessTexture"), texture_count, warnings);
        if c.get("clearcoatNormalTexture").is_some() {
            warnings.add("clearcoat normal textures are not supported: the clearcoat uses the base normal");
        }
    }
    if let Some(sh) = m.extension_value("KHR_materials_sheen") {
        let color = sh.get("sheenColorFactor").and_then(Value::as_array).map_or(Vec3::ZERO, |a| {
            Vec3::from_array([0, 1, 2].map(|i| a.get(i).and_then(Value::as_f64).unwrap_or(0.0) as f32))
        });
        mat.sheen_color = color;
        mat.sheen_color_tex = texture_json(sh.get("sheenColorTexture"), texture_count, warnings);
        mat.sheen_roughness = factor(sh, "sheenRoughnessFactor", 0.0);
        mat.sheen_roughness_tex = texture_json(sh.get("sheenRoughnessTexture"), texture_count, warnings);
    }
    sanitise(&mut mat);
    mat
}

/// The normal texture's textureInfo as JSON (the gltf crate has no KHR_texture_transform
/// accessor for it).
fn serde_json_value(n: &gltf::material::NormalTexture) -> Value {
    let mut info = serde_json::json!({ "index": n.texture().index(), "texCoord": n.tex_coord() });
    if let Some(t) = n.extension_value("KHR_texture_transform") {
        info["extensions"] = serde_json::json!({ "KHR_texture_transform": t.clone() });
    }
    info
}

/// Clamps factors into their ranges; NaN (from hostile JSON) becomes the default.
fn sanitise(m: &mut Material) {
    let unit = |v: f32, default: f32| if v.is_nan() { default } else { v.clamp(0.0, 1.0) };
    m.metallic = unit(m.metallic, 1.0);
    m.roughness = unit(m.roughness, 1.0);
    m.alpha = unit(m.alpha, 1.0);
    m.specular = unit(m.specular, 1.0);
    m.transmission = unit(m.transmission, 0.0);
    m.clearcoat = unit(m.clearcoat, 0.0);
    m.clearcoat_roughness = unit(m.clearcoat_roughness, 0.0);
    m.sheen_roughness = unit(m.sheen_roughness, 0.0);
    m.sheen_color = m.sheen_color.clamp(Vec3::ZERO, Vec3::ONE);
    if !(m.ior.is_finite() && m.ior >= 1.0) {
        m.ior = 1.5;
    }
}

/// Checks that an accessor's bytes lie inside its buffer, so reading cannot go out of range.
fn check_accessor(a: &gltf::Accessor, buffers: &[buffer::Data]) -> Result<(), String> {
    let check_view = |view: &gltf::buffer::View, offset: usize, count: usize, size: usize| {
        let stride = view.stride().unwrap_or(size);
        if stride < size {
            return Err(format!(
                "accessor {}: byteStride {stride} is smaller than its elements ({size} bytes)",
                a.index()
            ));
        }
        let needed = if count == 0 { 0 } else { offset + stride * (count - 1) + size };
        let buffer_len = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
        if needed > view.length() || view.offset() + view.length() > buffer_len {
            return Err(format!("accessor {} reaches past the end of its buffer", a.index()));
        }
        Ok(())
    };
    if let Some(view) = a.view() {
        check_view(&view, a.offset(), a.count(), a.size())?;
    }
    if let Some(sparse) = a.sparse() {
        let (idx, val) = (sparse.indices(), sparse.values());
        check_view(&idx.view(), idx.offset(), sparse.count(), idx.index_type().size())?;
        check_view(&val.view(), val.offset(), sparse.count(), a.size())?;
    }
    Ok(())
}

/// Rejects an attribute (or, for `Weights(u32::MAX)`, the indices) whose accessor type is
/// not one the spec allows for it: gltf 1.4.1 reads it as the allowed type regardless and
/// asserts on the length.
fn check_attribute_type(semantic: &Semantic, a: &gltf::Accessor) -> Result<(), String> {
    use gltf::accessor::{DataType as T, Dimensions as D};
    let (dims, ty) = (a.dimensions(), a.data_type());
    let ok = match semantic {
        Semantic::Positions | Semantic::Normals => dims == D::Vec3 && ty == T::F32,
        Semantic::TexCoords(_) => dims == D::Vec2 && matches!(ty, T::F32 | T::U8 | T::U16),
        Semantic::Colors(_) => matches!(dims, D::Vec3 | D::Vec4) && matches!(ty, T::F32 | T::U8 | T::U16),
        Semantic::Tangents => dims == D::Vec4 && ty == T::F32,
        Semantic::Weights(u32::MAX) => dims == D::Scalar && matches!(ty, T::U8 | T::U16 | T::U32),
        _ => true,
    };
    if ok {
        return Ok(());
    }
    let what = if matches!(semantic, Semantic::Weights(u32::MAX)) { "indices".into() } else { semantic.to_string() };
    Err(format!("invalid glTF: accessor {} is {dims:?} of {ty:?}, which {what} cannot be", a.index()))
}

fn convert_primitive(
    prim: &gltf::Primitive,
    buffers: &[buffer::Data],
    world: DMat4,
    default_material: u32,
    normal_mapped: bool,
    warnings: &mut Warnings,
) -> Result<Option<(MeshDesc, Vec<DVec3>)>, String> {
    let mode = prim.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        warnings.add(format!("primitives of mode {mode:?} are not rendered"));
        return Ok(None);
    }
    for (semantic, accessor) in prim.attributes() {
        check_accessor(&accessor, buffers)?;
        check_attribute_type(&semantic, &accessor)?;
    }
    if let Some(i) = prim.indices() {
        check_accessor(&i, buffers)?;
        check_attribute_type(&Semantic::Weights(u32::MAX), &i)?;
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let Some(positions) = reader.read_positions() else {
        warnings.add("a primitive without POSITION was skipped");
        return Ok(None);
    };
    let positions: Vec<DVec3> = positions.map(|p| world.transform_point3(Vec3::from(p).as_dvec3())).collect();
    let n = positions.len();
    let normal_matrix = DMat3::from_mat4(world).inverse().transpose();
    let normals = if prim.get(&Semantic::Normals).is_some() {
        reader.read_normals().map(|it| {
            it.map(|v| (normal_matrix * Vec3::from(v).as_dvec3()).normalize_or_zero().as_vec3()).collect::<Vec<_>>()
        })
    } else {
        None
    };
    let uvs = reader.read_tex_coords(0).map(|t| t.into_f32().map(Vec2::from).collect::<Vec<_>>());
    let uvs1 = reader.read_tex_coords(1).map(|t| t.into_f32().map(Vec2::from).collect::<Vec<_>>());
    let colors = reader.read_colors(0).map(|c| c.into_rgba_f32().map(Vec4::from).collect::<Vec<_>>());
    let linear = DMat3::from_mat4(world);
    let handedness = world.determinant().signum() as f32;
    let tangents = reader.read_tangents().filter(|_| normal_mapped).map(|t| {
        t.map(|v| {
            let xyz = (linear * Vec3::new(v[0], v[1], v[2]).as_dvec3()).normalize_or_zero().as_vec3();
            xyz.extend(v[3] * handedness)
        })
        .collect::<Vec<_>>()
    });
    let raw: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..n as u32).collect(),
    };
    if let Some(bad) = raw.iter().find(|&&i| i as usize >= n) {
        return Err(format!("index {bad} is out of range for a primitive with {n} vertices"));
    }
    let counts_differ = |len: Option<usize>| len.is_some_and(|l| l != n);
    if counts_differ(normals.as_ref().map(Vec::len))
        || counts_differ(uvs.as_ref().map(Vec::len))
        || counts_differ(uvs1.as_ref().map(Vec::len))
        || counts_differ(colors.as_ref().map(Vec::len))
        || counts_differ(tangents.as_ref().map(Vec::len))
    {
        return Err("vertex attributes of one primitive have different counts".into());
    }
    let mut indices = triangulate(mode, &raw);
    if world.determinant() < 0.0 {
        indices.chunks_exact_mut(3).for_each(|t| t.swap(1, 2));
    }
    let material = prim.material().index().map_or(default_material, |i| i as u32);
    let mesh = MeshDesc {
        name: String::new(),
        positions: Vec::new(),
        normals,
        uvs,
        uvs1,
        colors,
        tangents,
        indices,
        material,
    };
    if normal_mapped && mesh.tangents.is_none() {
        if mesh.uvs.is_none() {
            warnings.add("a normal-mapped primitive has no TEXCOORD_0: normal map ignored");
            return Ok(Some((mesh, positions)));
        }
        let (mesh, positions) = super::tangents::generate(mesh, positions);
        return Ok(Some((mesh, positions)));
    }
    Ok(Some((mesh, positions)))
}

/// Triangle list from a list, strip or fan, keeping counter-clockwise front faces.
fn triangulate(mode: Mode, idx: &[u32]) -> Vec<u32> {
    match mode {
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .flat_map(|i| if i % 2 == 0 { [idx[i], idx[i + 1], idx[i + 2]] } else { [idx[i + 1], idx[i], idx[i + 2]] })
            .collect(),
        Mode::TriangleFan => (1..idx.len().saturating_sub(1)).flat_map(|i| [idx[0], idx[i], idx[i + 1]]).collect(),
        _ => idx[..idx.len() / 3 * 3].to_vec(),
    }
}

/// A KHR_lights_punctual light placed by its node. Photometric intensities are used 1:1
/// as radiometric ones: 1 cd is radiant intensity 1 W/sr and 1 lx is irradiance 1 W/m^2,
/// on the same scale as emissive radiance (as the Khronos sample viewer does); `range` is ignored.
fn convert_light(light: &gltf::khr_lights_punctual::Light, world: DMat4) -> (PunctualLight, DVec3) {
    let kind = match light.kind() {
        Kind::Directional => PunctualKind::Directional,
        Kind::Point => PunctualKind::Point,
        Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            PunctualKind::Spot { cos_inner: inner_cone_angle.cos(), cos_outer: outer_cone_angle.cos() }
        }
    };
    let light = PunctualLight {
        name: light.name().unwrap_or("light").into(),
        kind,
        position: Vec3::ZERO,
        direction: world.transform_vector3(-DVec3::Z).normalize_or(-DVec3::Z).as_vec3(),
        intensity: Vec3::from(light.color()) * light.intensity(),
    };
    (light, world.transform_point3(DVec3::ZERO))
}

//! glTF 2.0 loading (.gltf with external or embedded buffers, .glb) with the gltf crate:
//! node transforms flattened into world-space meshes (a primitive placed more than once is
//! kept in its own space with its placements), materials, textures, punctual lights and
//! cameras. Anything not supported yet is reported once as a warning, never dropped silently.
//! Transforms are composed in f64 and everything is stored relative to the centre of the
//! scene's bounds, so a model placed far from the origin keeps its f32 precision.
//!
//! Before anything large is allocated, what the scene will take is estimated from the
//! file's counts (accessors, images' headers, how often the node hierarchy places each
//! mesh) and checked against `Limits`: a small file cannot make the loader allocate far
//! beyond what it and its images need.

use super::limits::{self, Attributes, Limits, PrimitiveShape, format_bytes};
use super::resources::{self, Encoded, Tally};
use super::{LoadError, Refusal, attributes, draco, graph, instancing, meshopt, variants};
use crate::scene::{
    MeshDesc, SceneDesc,
    camera::Camera,
    edit::{MATERIAL_PARAMS, Section},
    light::{Cone, LightSource, PunctualKind, PunctualLight},
    material::{Material, TexRef},
    texture::{Image, Texels, Texture, Wrap},
};
use glam::{Affine2, Affine3A, DMat3, DMat4, DVec3, Vec2, Vec3, Vec4};
use gltf::json::Value;
use gltf::{Document, Semantic, buffer, khr_lights_punctual::Kind, mesh::Mode, texture::WrappingMode};
use image::DynamicImage;
use std::collections::{BTreeSet, HashMap, HashSet};
use std::path::Path;

/// Extensions besides the material extensions of `MATERIAL_PARAMS`' sections whose every
/// part that matters to shading is honoured.
const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "KHR_xmp",
    attributes::QUANTIZATION,
    meshopt::EXTENSION,
    draco::EXTENSION,
    instancing::EXTENSION,
    variants::EXTENSION,
    UNLIT,
    WEBP,
    BASISU,
];

/// Whether extension `name` is honoured: one of `SUPPORTED_EXTENSIONS`, or the extension of
/// a section of material parameters.
fn supported(name: &str) -> bool {
    SUPPORTED_EXTENSIONS.contains(&name) || Section::MATERIAL.iter().any(|s| s.extension() == Some(name))
}

/// Materials that show their base colour unlit.
const UNLIT: &str = "KHR_materials_unlit";

/// WebP textures, decoded by the image crate.
const WEBP: &str = "EXT_texture_webp";

/// KTX2 textures in Basis Universal, transcoded by the `basisu` crate.
const BASISU: &str = "KHR_texture_basisu";

/// Loads a .gltf or .glb file within the machine's default `Limits`.
pub fn load(path: &Path) -> Result<SceneDesc, LoadError> {
    load_with_limits(path, &Limits::default())
}

/// Loads a .gltf or .glb file, refusing (`LoadError::TooLarge`) one whose load and build would exceed `limits`.
pub fn load_with_limits(path: &Path, limits: &Limits) -> Result<SceneDesc, LoadError> {
    let fail = |reason: String| LoadError::File { path: path.to_owned(), reason };
    if !path.is_file() {
        return Err(fail(if path.exists() { "not a file".into() } else { "no such file".into() }));
    }
    let size = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?.len();
    if size > limits.memory {
        let reason =
            format!("the file is {}, over the memory limit of {}", format_bytes(size), format_bytes(limits.memory));
        return Err(LoadError::TooLarge { path: path.to_owned(), reason });
    }
    let bytes = std::fs::read(path).map_err(|e| fail(e.to_string()))?;
    let (doc, buffers, images) = import(&bytes, path.parent(), limits).map_err(|r| r.at(path))?;
    let name = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let mut desc = convert(&doc, &buffers, images, name).map_err(&fail)?;
    super::sidecar::apply(&mut desc, path).map_err(fail)?;
    super::media::apply(&mut desc, path).map_err(fail)?;
    Ok(desc)
}

/// Loads glTF from memory (embedded or GLB buffers only) within the machine's default `Limits`.
pub fn load_slice(bytes: &[u8], name: &str) -> Result<SceneDesc, LoadError> {
    load_slice_with_limits(bytes, name, &Limits::default())
}

/// Loads glTF from memory (embedded or GLB buffers only) within `limits`, naming it `name` in errors.
pub fn load_slice_with_limits(bytes: &[u8], name: &str, limits: &Limits) -> Result<SceneDesc, LoadError> {
    let (doc, buffers, images) = import(bytes, None, limits).map_err(|r| r.at(Path::new(name)))?;
    convert(&doc, &buffers, images, name.into()).map_err(|reason| LoadError::File { path: name.into(), reason })
}

/// Bytes that loading and building the file would take at the peak (what `load_with_limits` checks).
///
/// Worked out without decoding images or converting geometry; a figure over the limit is
/// returned, not refused, while invalid files and files too large to read are refused as
/// `load_with_limits` refuses them.
pub fn estimate(path: &Path, limits: &Limits) -> Result<u64, LoadError> {
    let bytes = std::fs::read(path).map_err(|e| LoadError::File { path: path.to_owned(), reason: e.to_string() })?;
    let mut read = read(&bytes, path.parent(), limits).map_err(|r| r.at(path))?;
    let encoded = resources::image_headers(&read.document, path.parent(), &read.buffers, &mut read.tally)
        .map_err(|r| r.at(path))?;
    read.estimate.add_images(&encoded.iter().flatten().collect::<Vec<_>>());
    Ok(read.estimate.total)
}

/// Parses and validates, reads buffers and image headers (relative to `base`, if given),
/// checks what the scene will take against `limits`, then decodes the images.
fn import(
    bytes: &[u8],
    base: Option<&Path>,
    limits: &Limits,
) -> Result<(Document, Vec<buffer::Data>, Vec<Image>), Refusal> {
    let mut read = read(bytes, base, limits)?;
    let encoded = resources::image_headers(&read.document, base, &read.buffers, &mut read.tally)?;
    read.estimate.add_images(&encoded.iter().flatten().collect::<Vec<_>>());
    read.estimate.check(limits.memory)?;
    let mut images = Vec::with_capacity(encoded.len());
    for image in encoded {
        images.push(match image {
            Some(image) => convert_image(resources::decode(image, limits.memory)?),
            None => Image { width: 1, height: 1, texels: Texels::Bytes(vec![[0; 4]]) },
        });
    }
    Ok((read.document, read.buffers, images))
}

/// A parsed and checked file with its buffers, before its images are read.
struct Read {
    document: Document,
    buffers: Vec<buffer::Data>,
    /// What the file, its parsed JSON and its buffers hold, counted against the limit.
    tally: Tally,
    /// The estimate, without the images yet.
    estimate: Estimate,
}

/// Parses and validates `bytes`, checks the node hierarchy, reads the buffers and checks
/// every placed primitive's accessors, each step refusing what would not fit in `limits`.
fn read(bytes: &[u8], base: Option<&Path>, limits: &Limits) -> Result<Read, Refusal> {
    let parsed = limits::parsed_json(json_text(bytes));
    let mut tally = Tally { used: (bytes.len() as u64).saturating_add(parsed), limit: limits.memory };
    if tally.used > limits.memory {
        return Err(Refusal::TooLarge(format!(
            "the file is {} and its JSON takes about {} once parsed, over the memory limit of {}",
            format_bytes(bytes.len() as u64),
            format_bytes(parsed),
            format_bytes(limits.memory)
        )));
    }
    let gltf::Gltf { document, blob } = parse(bytes)?;
    check_position_accessors(&document)?;
    let json = required_checked(document.into_json())?;
    // Buffers are read before validation: compressed meshes and views (EXT_meshopt_compression,
    // KHR_draco_mesh_compression) are decoded into plain views first, which is what the
    // accessors of a Draco primitive, without a bufferView of their own, need to validate.
    // Reading buffers touches only the buffers' own entries.
    tally.used = tally.used.saturating_add(blob.as_ref().map_or(0, |b| b.len() as u64));
    let unchecked = Document::from_json_without_validation(json);
    let mut buffers = resources::buffers(&unchecked, base, blob, &mut tally)?;
    let mut json = unchecked.into_json();
    if meshopt::used(&json) {
        meshopt::decode(&mut json, &mut buffers, &mut tally)?;
    }
    if draco::used(&json) {
        draco::decode(&mut json, &mut buffers, &mut tally)?;
    }
    let document = Document::from_json(json).map_err(|e| describe(&e))?;
    check_image_sources(&document)?;
    let roots: Vec<usize> = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .map_or_else(Vec::new, |s| s.nodes().map(|n| n.index()).collect());
    let placements = graph::placements(&document, &roots)?;
    let quantized = document.extensions_used().any(|e| e == attributes::QUANTIZATION);
    let instances = instancing::counts(&document, quantized, |a| check_accessor(a, &buffers))?;
    let mesh_placements: Vec<u64> = placements.iter().zip(&instances).map(|(p, i)| p.saturating_mul(*i)).collect();
    let total = mesh_placements.iter().fold(0u64, |a, &p| a.saturating_add(p));
    if total > graph::MAX_NODE_PLACEMENTS {
        return Err(Refusal::TooLarge(format!(
            "the nodes and their instances (EXT_mesh_gpu_instancing) place meshes {total} times, over the limit of {}",
            graph::MAX_NODE_PLACEMENTS
        )));
    }
    check_buffer_views(&document, &buffers)?;
    let placed = check_primitives(&document, &buffers, &mesh_placements)?;
    let triangles = placed.iter().fold(0u64, |a, p| a.saturating_add(p.copies.saturating_mul(p.shape.triangles)));
    if triangles > u32::MAX as u64 {
        return Err(Refusal::TooLarge(format!(
            "the scene places {triangles} triangles, over the {} one scene can number",
            u32::MAX
        )));
    }
    for p in &placed {
        let updates = p.copies.saturating_mul(p.shape.vertices).saturating_mul(p.morph_deltas);
        if updates > MAX_MORPH_UPDATES {
            return Err(Refusal::TooLarge(format!(
                "{}: its {} morph target attributes over {} vertices and {} copies ask for {updates} vertex updates, over the limit of {MAX_MORPH_UPDATES}",
                p.name, p.morph_deltas, p.shape.vertices, p.copies
            )));
        }
    }
    let estimate = Estimate::new(&document, tally.used, bytes.len() as u64, &placed, &placements);
    Ok(Read { document, buffers, tally, estimate })
}

/// Refuses a file that requires an extension Lucent does not support, naming it; the
/// document is returned with its extensionsRequired emptied, so that gltf-json's validation
/// (which knows only its own short list) checks the rest, and with each texture showing its
/// KHR_texture_basisu image, or else its EXT_texture_webp image, where it has one (as those
/// extensions ask; the texture's `source` is then a fallback, or absent).
fn required_checked(mut json: gltf::json::Root) -> Result<gltf::json::Root, String> {
    if let Some(ext) = json.extensions_required.iter().find(|e| !supported(e)) {
        return Err(format!("the file requires the glTF extension {ext}, which Lucent does not support"));
    }
    json.extensions_required.clear();
    for texture in &mut json.textures {
        let others = texture.extensions.as_ref().map(|e| &e.others);
        let source = |ext: &str| others.and_then(|o| o.get(ext)).and_then(|w| w["source"].as_u64());
        if let Some(source) = source(BASISU).or(source(WEBP)).and_then(|s| u32::try_from(s).ok()) {
            texture.source = gltf::json::Index::new(source);
        }
    }
    Ok(json)
}

/// The JSON text of a .gltf, or of a GLB's first chunk (the whole input if it is neither).
fn json_text(bytes: &[u8]) -> &[u8] {
    let chunk = bytes.get(12..16).map(|l| u32::from_le_bytes([l[0], l[1], l[2], l[3]]) as usize);
    match chunk {
        Some(len) if bytes.starts_with(b"glTF") => bytes.get(20..).map_or(&[][..], |rest| &rest[..len.min(rest.len())]),
        _ => bytes,
    }
}

/// The gltf crate's parse, with "not a glTF or GLB file" for input that is neither a GLB
/// (magic "glTF") nor a JSON object, or is JSON but not glTF.
fn parse(bytes: &[u8]) -> Result<gltf::Gltf, Refusal> {
    let text = bytes.strip_prefix("\u{feff}".as_bytes()).unwrap_or(bytes);
    let json_object = text.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{');
    if !bytes.starts_with(b"glTF") && !json_object {
        let what = if bytes.is_empty() { "the file is empty" } else { "neither JSON nor binary glTF" };
        return Err(Refusal::Invalid(format!("not a glTF or GLB file ({what})")));
    }
    gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| match e {
        gltf::Error::Deserialize(e) if serde_json::from_slice::<serde::de::IgnoredAny>(bytes).is_ok() => {
            Refusal::Invalid(format!("not a glTF or GLB file (JSON, but {e})"))
        }
        gltf::Error::Deserialize(e) => Refusal::Invalid(format!("invalid JSON: {e}")),
        e => Refusal::Invalid(describe(&e)),
    })
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

/// Most vertex attributes morph targets may update while the scene is flattened (each
/// target's deltas for every vertex of every copy; about 9 s of reading sparse deltas on
/// this machine, at 33 ns an update): a 300 kB file
/// of sparse accessors without data could otherwise ask for 2e10.
const MAX_MORPH_UPDATES: u64 = 1 << 28;

/// A primitive the flattening will convert, with how many copies the hierarchy places.
struct Placed {
    /// "meshes[m].primitives[p]", for messages.
    name: String,
    /// Copies placed.
    copies: u64,
    /// What one copy takes.
    shape: PrimitiveShape,
    /// The largest sparse accessor it reads, if any: index, count and type.
    sparse: Option<(usize, u64, gltf::accessor::Dimensions)>,
    /// Whether its copies are stored once and placed as instances: it is placed more than
    /// once and has no morph targets (copies at other weights are other geometry).
    instanced: bool,
    /// Whether its material emits light (each placed triangle is then a light).
    emits: bool,
    /// Morph target attributes (positions, normals, tangents) its targets hold.
    morph_deltas: u64,
}

/// Checks the accessors of every primitive that the scene places (inside their buffers,
/// of types the spec allows, one count for all vertex attributes) and says what each
/// will take; `placements` is how often each node's mesh is placed.
fn check_primitives(doc: &Document, buffers: &[buffer::Data], placements: &[u64]) -> Result<Vec<Placed>, String> {
    let tangent_materials: Vec<bool> =
        materials(doc, &mut Warnings::default()).iter().map(Material::needs_tangents).collect();
    let mut copies = vec![0u64; doc.meshes().len()];
    for node in doc.nodes() {
        if let Some(m) = node.mesh() {
            copies[m.index()] = copies[m.index()].saturating_add(placements[node.index()]);
        }
    }
    let quantized = doc.extensions_used().any(|e| e == attributes::QUANTIZATION);
    let mut placed = Vec::new();
    for mesh in doc.meshes().filter(|m| copies[m.index()] > 0) {
        for prim in mesh.primitives() {
            let name_bytes = mesh.name().map_or(4, str::len) as u64;
            let tangent_space = prim.material().index().is_some_and(|i| tangent_materials[i]);
            if let Some((shape, sparse)) = primitive_shape(&prim, name_bytes, buffers, (quantized, tangent_space))? {
                let name = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
                let copies = copies[mesh.index()];
                let instanced = copies > 1 && prim.morph_targets().len() == 0;
                let emits = prim.material().emissive_factor().iter().any(|&e| e != 0.0);
                let morph_deltas = prim
                    .morph_targets()
                    .map(|t| [t.positions(), t.normals(), t.tangents()].iter().flatten().count() as u64)
                    .sum();
                placed.push(Placed { name, copies, shape, sparse, instanced, emits, morph_deltas });
            }
        }
    }
    Ok(placed)
}

/// A sparse accessor read by a primitive: index, count, type.
type Sparse = (usize, u64, gltf::accessor::Dimensions);

/// What converting one copy of a primitive (of a mesh whose name has `name` bytes) takes,
/// once its accessors are checked (`quantized`: with KHR_mesh_quantization; `tangent_space`:
/// its material needs tangents); None for a primitive that is skipped (not triangles, or
/// without POSITION).
fn primitive_shape(
    prim: &gltf::Primitive,
    name: u64,
    buffers: &[buffer::Data],
    (quantized, tangent_space): (bool, bool),
) -> Result<Option<(PrimitiveShape, Option<Sparse>)>, String> {
    let mode = prim.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        return Ok(None);
    }
    for (semantic, accessor) in prim.attributes() {
        check_accessor(&accessor, buffers)?;
        check_attribute_type(&semantic, &accessor, quantized)?;
    }
    let indices = prim.indices();
    if let Some(i) = &indices {
        check_accessor(i, buffers)?;
        check_attribute_type(&Semantic::Weights(u32::MAX), i, quantized)?;
    }
    let Some(positions) = prim.get(&Semantic::Positions) else { return Ok(None) };
    let normals = prim.get(&Semantic::Normals);
    let uvs = prim.get(&Semantic::TexCoords(0));
    let uvs1 = prim.get(&Semantic::TexCoords(1));
    let colors = prim.get(&Semantic::Colors(0));
    let tangents = prim.get(&Semantic::Tangents).filter(|_| tangent_space);
    let read: Vec<&gltf::Accessor> =
        [Some(&positions), normals.as_ref(), uvs.as_ref(), uvs1.as_ref(), colors.as_ref(), tangents.as_ref()]
            .into_iter()
            .flatten()
            .collect();
    let vertices = positions.count();
    if read.iter().any(|a| a.count() != vertices) {
        return Err("vertex attributes of one primitive have different counts".into());
    }
    for target in prim.morph_targets() {
        for a in [target.positions(), target.normals(), target.tangents()].into_iter().flatten() {
            check_accessor(&a, buffers)?;
            // Deltas are VEC3 of floats or, quantized, of integers, as positions are.
            check_attribute_type(&Semantic::Positions, &a, quantized)?;
            if a.count() != vertices {
                return Err(format!(
                    "morph target accessor {} has {} elements for {vertices} vertices",
                    a.index(),
                    a.count()
                ));
            }
        }
    }
    let index_count = indices.as_ref().map_or(vertices, |i| i.count()) as u64;
    let triangles = if mode == Mode::Triangles { index_count / 3 } else { index_count.saturating_sub(2) };
    let generates_tangents = tangent_space && tangents.is_none() && uvs.is_some();
    let attributes = Attributes {
        normals: normals.is_some(),
        uvs: uvs.is_some(),
        uvs1: uvs1.is_some(),
        colors: colors.is_some(),
        tangents: tangents.is_some() || generates_tangents,
    };
    let shape = PrimitiveShape {
        vertices: vertices as u64,
        indices: index_count,
        triangles,
        attributes,
        generates_tangents,
        name,
    };
    let sparse = read
        .into_iter()
        .chain(indices.as_ref())
        .filter(|a| a.sparse().is_some())
        .max_by_key(|a| a.count())
        .map(|a| (a.index(), a.count() as u64, a.dimensions()));
    Ok(Some((shape, sparse)))
}

/// An accessor type as glTF spells it.
fn type_name(d: gltf::accessor::Dimensions) -> &'static str {
    use gltf::accessor::Dimensions as D;
    match d {
        D::Scalar => "SCALAR",
        D::Vec2 => "VEC2",
        D::Vec3 => "VEC3",
        D::Vec4 => "VEC4",
        D::Mat2 => "MAT2",
        D::Mat3 => "MAT3",
        D::Mat4 => "MAT4",
    }
}

/// What loading a scene takes at its peak, worked out from counts before the large
/// allocations: the largest of decoding the images, flattening the hierarchy and building
/// the scene, each with what is alive at the time (see `limits` for the per-item costs).
struct Estimate {
    /// What the bytes go to, for the message: a description and its bytes.
    parts: Vec<(String, u64)>,
    /// The file, its parsed JSON and its buffers, held until the scene description is made.
    read: u64,
    /// The file alone (held by the caller of `load_slice` throughout).
    file: u64,
    /// Flattening, beyond `read` and the textures: the placed copies, the largest
    /// conversion's temporaries, and the lights and cameras.
    flattening: u64,
    /// Building, beyond the file and the textures: the scene description and the built scene.
    building: u64,
    /// Bytes at the peak, once the images are added.
    total: u64,
}

impl Estimate {
    /// `read` is what the file, its parsed JSON and its buffers hold, `file` the file alone;
    /// `placements` counts each node's copies.
    fn new(doc: &Document, read: u64, file: u64, placed: &[Placed], placements: &[u64]) -> Self {
        let mut parts = vec![("the file, its parsed JSON and its buffers".to_owned(), read)];
        let any_extra =
            placed.iter().any(|p| p.shape.attributes.uvs1 || p.shape.attributes.colors || p.shape.attributes.tangents);
        let emissive = doc.materials().any(|m| m.emissive_factor().iter().any(|&e| e != 0.0));
        let per_triangle = limits::TRIANGLE + if any_extra { limits::TRIANGLE_EXTRA } else { 0 };
        let (mut converting, mut transient, mut described) = (0u64, 0u64, 0u64);
        for p in placed {
            let stored = if p.instanced { 1 } else { p.copies };
            let instances = if p.instanced { p.copies } else { 0 };
            let triangles = p.copies.saturating_mul(p.shape.triangles);
            // The light sampler holds each placed triangle's probability, and a candidate for
            // each that emits.
            let light = match (emissive, p.emits) {
                (_, true) => limits::EMISSIVE_TRIANGLE,
                (true, false) => limits::TRIANGLE_PMF,
                (false, false) => 0,
            };
            let scene = stored
                .saturating_mul(p.shape.described().saturating_add(p.shape.triangles.saturating_mul(per_triangle)))
                .saturating_add(instances.saturating_mul(limits::INSTANCE))
                .saturating_add(triangles.saturating_mul(light));
            converting = converting
                .saturating_add(stored.saturating_mul(p.shape.converting()))
                .saturating_add(instances.saturating_mul(limits::PLACEMENT));
            transient = transient.max(p.shape.transient());
            described = described.saturating_add(scene);
            let vertices = p.copies.saturating_mul(p.shape.vertices);
            let mut what = match p.copies {
                1 => format!("{}: {vertices} vertices and {triangles} triangles", p.name),
                n if p.instanced => {
                    format!("{} is placed {n} times: {} triangles stored once", p.name, p.shape.triangles)
                }
                n => format!("{} is placed {n} times: {vertices} vertices and {triangles} triangles in all", p.name),
            };
            if let Some((a, count, dims)) = p.sparse {
                what += &format!(
                    ", read from accessors[{a}] (sparse), which expands to {count} {} elements",
                    type_name(dims)
                );
            }
            parts.push((what, scene));
        }
        let payload = doc
            .nodes()
            .map(|n| {
                let names = n
                    .light()
                    .map(|l| l.name().map_or(5, str::len))
                    .into_iter()
                    .chain(n.camera().map(|c| c.name().map_or(6, str::len)));
                let bytes: u64 = names.map(|len| limits::NODE_PAYLOAD + len as u64).sum();
                placements[n.index()].saturating_mul(bytes)
            })
            .fold(0u64, u64::saturating_add);
        parts.push(("the lights and cameras the nodes place".to_owned(), payload));
        let materials = (doc.materials().len() as u64 + 1) * limits::MATERIAL;
        let flattening = converting.saturating_add(transient).saturating_add(payload);
        let building = described.saturating_add(payload).saturating_add(materials);
        Self { parts, read, file, flattening, building, total: 0 }
    }

    /// Adds the images (their encoded bytes, decoding one at a time, and the textures kept)
    /// and works out the total.
    fn add_images(&mut self, images: &[&Encoded]) {
        let texel_bytes = |i: &Encoded| {
            let texel = if i.deep { 2 * limits::TEXEL } else { limits::TEXEL };
            (i.width as u64).saturating_mul(i.height as u64).saturating_mul(texel)
        };
        let textures = images.iter().map(|i| texel_bytes(i)).fold(0u64, u64::saturating_add);
        let encoded = images.iter().map(|i| i.held()).fold(0u64, u64::saturating_add);
        let decoded = images.iter().map(|i| limits::decoding(i.decoded)).max().unwrap_or(0);
        for i in images {
            let what = format!("{} is {}x{}, decoding to {}", i.name, i.width, i.height, format_bytes(i.decoded));
            self.parts.push((what, i.decoded.saturating_add(texel_bytes(i))));
        }
        let sum = |xs: &[u64]| xs.iter().fold(0u64, |a, &x| a.saturating_add(x));
        let decoding = sum(&[self.read, encoded, textures, decoded]);
        let flattening = sum(&[self.read, textures, self.flattening]);
        let building = sum(&[self.file, textures, self.building]);
        self.total = decoding.max(flattening).max(building).saturating_add(limits::OVERHEAD);
    }

    /// Refuses the scene if its peak is over `limit`, naming the largest part.
    fn check(&self, limit: u64) -> Result<(), Refusal> {
        if self.total <= limit {
            return Ok(());
        }
        let (what, bytes) = self.parts.iter().max_by_key(|(_, b)| *b).expect("the file is always a part");
        let (part, total) = (format_bytes(*bytes), format_bytes(self.total));
        let all = if part == total { String::new() } else { format!("; the scene needs about {total} in all") };
        Err(Refusal::TooLarge(format!("{what}: about {part}{all}, over the memory limit of {}", format_bytes(limit))))
    }
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
pub(super) struct Warnings(BTreeSet<String>);

impl Warnings {
    pub(super) fn add(&mut self, w: impl Into<String>) {
        self.0.insert(w.into());
    }
}

fn convert(doc: &Document, buffers: &[buffer::Data], images: Vec<Image>, name: String) -> Result<SceneDesc, String> {
    let mut warnings = Warnings::default();
    for ext in doc.extensions_used() {
        if !supported(ext) {
            warnings.add(format!("extension {ext} is not supported yet: ignored"));
        }
    }
    let mut desc = SceneDesc { name, variants: variants::names(doc), ..SceneDesc::default() };
    desc.images = images;
    desc.textures = doc.textures().map(convert_texture).collect();
    desc.materials = materials(doc, &mut warnings);
    let default_material = desc.materials.len() as u32;

    let scene = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s,
        None => {
            warnings.add("the file has no scene: nothing to render");
            desc.warnings = warnings.0.into_iter().collect();
            return Ok(desc);
        }
    };
    let mut lights: Vec<(PunctualLight, DVec3)> = Vec::new();
    let mut cameras: Vec<(String, Camera, DVec3)> = Vec::new();
    let geometry = primitive_geometry(doc);
    // Each primitive placed, with its node and world transform, in the order of the walk.
    let mut placements: Vec<(gltf::Node, gltf::Mesh, gltf::Primitive, DMat4)> = Vec::new();
    // How often each piece of geometry (at the node's morph weights) is placed.
    let mut copies: HashMap<(usize, Vec<u32>), usize> = HashMap::new();
    let mut seen = HashSet::new();
    let mut coincident = 0u64;
    // import has checked that the hierarchy has no cycle and flattens to few enough copies.
    let mut stack: Vec<(gltf::Node, DMat4)> = scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        let world = parent * DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        if let Some(mesh) = node.mesh() {
            // EXT_mesh_gpu_instancing places the mesh once per instance, under the node.
            let instances = instancing::transforms(doc, &node, buffers)?;
            let worlds = instances.map_or_else(|| vec![world], |t| t.into_iter().map(|t| world * t).collect());
            for world in worlds {
                for prim in mesh.primitives() {
                    // A copy of geometry already placed with the same transform only doubles
                    // triangles exactly: it is placed once. (Many coincident triangles also
                    // defeat obvhs's PLOC builder, which breaks ties towards the farthest
                    // neighbour: n equal boxes take O(n^2) time and an n-deep tree.)
                    let bits = world.to_cols_array().map(f64::to_bits);
                    let weight_bits = morph_key(&node, &mesh, &prim);
                    let id = geometry[mesh.index()][prim.index()];
                    if !seen.insert((id, bits, weight_bits.clone())) {
                        coincident += 1;
                        continue;
                    }
                    *copies.entry((id, weight_bits)).or_insert(0) += 1;
                    placements.push((node.clone(), mesh.clone(), prim, world));
                }
            }
        }
        if let Some(light) = node.light() {
            lights.push(convert_light(&light, &node, parent));
        }
        if let Some(camera) = node.camera() {
            match camera.projection() {
                gltf::camera::Projection::Perspective(p) => {
                    let (_, rotation, position) = world.to_scale_rotation_translation();
                    let cam = Camera {
                        position: Vec3::ZERO,
                        rotation: rotation.as_quat().normalize(),
                        yfov: p.yfov(),
                        aspect: p.aspect_ratio().filter(|a| a.is_finite() && *a > 0.0),
                    };
                    cameras.push((camera.name().unwrap_or("camera").into(), cam, position));
                }
                gltf::camera::Projection::Orthographic(_) => {
                    warnings.add("orthographic cameras are not supported yet: ignored");
                }
            }
        }
        stack.extend(node.children().map(|c| (c, world)));
    }
    if coincident > 0 {
        warnings.add(format!(
            "{coincident} placed primitives repeat geometry already placed with the same transform: placed once"
        ));
    }
    // Geometry placed once is converted to world space; geometry placed more often is
    // converted once, in its own space, and placed by its transforms.
    let mut placed: Vec<(MeshDesc, Vec<DVec3>, Vec<DMat4>)> = Vec::new();
    let mut shared: HashMap<(usize, Vec<u32>), Option<usize>> = HashMap::new();
    for (node, mesh, prim, world) in placements {
        let key = (geometry[mesh.index()][prim.index()], morph_key(&node, &mesh, &prim));
        let many = copies[&key] > 1;
        if many && let Some(&known) = shared.get(&key) {
            if let Some(i) = known {
                placed[i].2.push(world);
            }
            continue;
        }
        let tangent_space = prim.material().index().is_some_and(|i| desc.materials[i].needs_tangents());
        let weights = node.weights().or(mesh.weights()).unwrap_or_default();
        if prim.morph_targets().len() > 0 {
            warnings.add("morph targets are applied at the node's or mesh's weights (animation is not supported)");
        }
        if node.skin().is_some() {
            warnings.add("skinned meshes are shown in their bind pose, placed by their node (skins and animation are not supported)");
        }
        let space = if many { DMat4::IDENTITY } else { world };
        let converted =
            convert_primitive(&prim, buffers, space, default_material, tangent_space, weights, &mut warnings)?;
        let index = converted.map(|(m, p)| {
            let instances = if many { vec![world] } else { Vec::new() };
            placed.push((MeshDesc { name: mesh.name().unwrap_or("mesh").into(), ..m }, p, instances));
            placed.len() - 1
        });
        if many {
            shared.insert(key, index);
        }
    }
    let bounds = placed.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |b, (_, p, instances)| {
        let (lo, hi) = p.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        if instances.is_empty() {
            return (b.0.min(lo), b.1.max(hi));
        }
        instances
            .iter()
            .flat_map(|t| corners(lo, hi).map(|c| t.transform_point3(c)))
            .fold(b, |(a, b), v| (a.min(v), b.max(v)))
    });
    let centre = if bounds.0.is_finite() && bounds.1.is_finite() { 0.5 * (bounds.0 + bounds.1) } else { DVec3::ZERO };
    let relative = |p: DVec3| (p - centre).as_vec3();
    let centred = DMat4::from_translation(-centre);
    desc.meshes = placed
        .into_iter()
        .map(|(mesh, p, instances)| {
            if instances.is_empty() {
                return MeshDesc { positions: p.into_iter().map(relative).collect(), ..mesh };
            }
            let positions = p.into_iter().map(|v| v.as_vec3()).collect();
            let instances = instances.into_iter().map(|t| Affine3A::from_mat4((centred * t).as_mat4())).collect();
            MeshDesc { positions, instances, ..mesh }
        })
        .collect();
    let centre_light = |(l, p): (PunctualLight, DVec3)| PunctualLight {
        position: relative(p),
        source: l.source.map(|s| LightSource { parent: centred * s.parent, ..s }),
        ..l
    };
    desc.lights = lights.into_iter().map(centre_light).collect();
    desc.cameras = cameras.into_iter().map(|(n, c, p)| (n, Camera { position: relative(p), ..c })).collect();
    if desc.meshes.iter().any(|m| m.material == default_material) {
        desc.materials.push(Material { name: "glTF default".into(), ..Material::default() });
    }
    desc.warnings = warnings.0.into_iter().collect();
    Ok(desc)
}

/// The morph weights `node` places `prim` of `mesh` at, as bits: copies at other weights are other geometry.
fn morph_key(node: &gltf::Node, mesh: &gltf::Mesh, prim: &gltf::Primitive) -> Vec<u32> {
    if prim.morph_targets().len() == 0 {
        return Vec::new();
    }
    node.weights().or(mesh.weights()).unwrap_or_default().iter().map(|w| w.to_bits()).collect()
}

/// The eight corners of the box [lo, hi].
fn corners(lo: DVec3, hi: DVec3) -> [DVec3; 8] {
    std::array::from_fn(|k| DVec3::select(glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0), hi, lo))
}

/// For each mesh's primitives, an id shared by primitives that read the same accessors
/// with the same mode and material (and so place the same triangles).
fn primitive_geometry(doc: &Document) -> Vec<Vec<usize>> {
    let mut ids = HashMap::new();
    doc.meshes()
        .map(|m| {
            m.primitives()
                .map(|p| {
                    let mut attributes: Vec<(String, usize)> =
                        p.attributes().map(|(s, a)| (s.to_string(), a.index())).collect();
                    attributes.sort();
                    let key = (p.mode().as_gl_enum(), p.material().index(), p.indices().map(|a| a.index()), attributes);
                    let next = ids.len();
                    *ids.entry(key).or_insert(next)
                })
                .collect()
        })
        .collect()
}

/// A decoded image as RGBA8 texels: 16-bit channels keep their high byte, float channels
/// are clamped to [0, 1], grey is replicated, and grey-alpha fills red and green.
fn convert_image(image: DynamicImage) -> Image {
    let (width, height) = (image.width(), image.height());
    let unit = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    let words = |texels: Vec<[u16; 4]>| Texels::Words(texels);
    let texels = match image {
        DynamicImage::ImageLuma8(b) => Texels::Bytes(b.pixels().map(|p| [p[0], p[0], p[0], 255]).collect()),
        DynamicImage::ImageLumaA8(b) => Texels::Bytes(b.pixels().map(|p| [p[0], p[1], 0, 255]).collect()),
        DynamicImage::ImageRgb8(b) => Texels::Bytes(b.pixels().map(|p| [p[0], p[1], p[2], 255]).collect()),
        DynamicImage::ImageLuma16(b) => words(b.pixels().map(|p| [p[0], p[0], p[0], u16::MAX]).collect()),
        DynamicImage::ImageLumaA16(b) => words(b.pixels().map(|p| [p[0], p[1], 0, u16::MAX]).collect()),
        DynamicImage::ImageRgb16(b) => words(b.pixels().map(|p| [p[0], p[1], p[2], u16::MAX]).collect()),
        DynamicImage::ImageRgba16(b) => words(b.pixels().map(|p| p.0).collect()),
        DynamicImage::ImageRgb32F(b) => {
            Texels::Bytes(b.pixels().map(|p| [unit(p[0]), unit(p[1]), unit(p[2]), 255]).collect())
        }
        DynamicImage::ImageRgba32F(b) => Texels::Bytes(b.pixels().map(|p| p.0.map(unit)).collect()),
        other => Texels::Bytes(other.into_rgba8().pixels().map(|p| p.0).collect()),
    };
    Image { width, height, texels }
}

fn convert_texture(t: gltf::Texture) -> Texture {
    let wrap = |m: WrappingMode| match m {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    };
    let s = t.sampler();
    let image = t.source();
    let uri_name = match image.source() {
        gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => uri.rsplit('/').next(),
        _ => None,
    };
    let name = t.name().or(image.name()).or(uri_name).map_or_else(|| format!("texture {}", t.index()), str::to_owned);
    Texture {
        name,
        image: image.index() as u32,
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

/// The file's materials, each read through `MATERIAL_PARAMS` from its JSON (the gltf crate's
/// parsed material serialised again: numbers as the crate read them, a property the file
/// leaves out either absent or at glTF's default, an infinite number null).
fn materials(doc: &Document, warnings: &mut Warnings) -> Vec<Material> {
    let texture_count = doc.textures().len();
    let json = &doc.as_json().materials;
    doc.materials()
        .zip(json)
        .map(|(m, json)| {
            let json = serde_json::to_value(json).unwrap_or(Value::Null);
            convert_material(&m, &json, texture_count, warnings)
        })
        .collect()
}

/// Material `m`, whose JSON is `json`: each parameter of `MATERIAL_PARAMS` that applies
/// (in table order, so alphaCutoff after alphaMode) and its texture read at its path, a
/// value outside its range or of another kind replaced as `Kind::repair` says, with a
/// warning naming the material; what the file leaves out keeps glTF's default. Read apart:
/// KHR_materials_unlit, which is the extension's presence.
fn convert_material(m: &gltf::Material, json: &Value, texture_count: usize, warnings: &mut Warnings) -> Material {
    if m.occlusion_texture().is_some() {
        warnings.add("occlusion textures are ignored (a path tracer computes occlusion)");
    }
    let mut mat = Material {
        name: m.name().map_or_else(|| format!("material {}", m.index().unwrap_or(0)), str::to_owned),
        file_index: m.index().map(|i| i as u32),
        ..Material::default()
    };
    for p in MATERIAL_PARAMS {
        if let Some(slot) = &p.texture {
            (slot.set)(&mut mat, texture_json(p.texture_info(json), texture_count, warnings));
        }
        if !(p.applies)(&mat) {
            continue;
        }
        let value = match p.read(json) {
            Some(Ok(value)) if p.kind.check(value).is_ok() => value,
            Some(Ok(value)) => {
                let used = p.kind.repair(value, p.default_value());
                let why = p.kind.violation(value);
                warnings.add(format!("material {:?}: {} {value} {why}: {used} used", mat.name, p.name()));
                used
            }
            Some(Err(other)) => {
                let (used, range) = (p.default_value(), p.kind.range());
                warnings.add(format!("material {:?}: {} {other} is not {range}: {used} used", mat.name, p.name()));
                used
            }
            None => match p.gltf_default {
                Some(value) => value,
                None => continue,
            },
        };
        (p.set)(&mut mat, value);
    }
    mat.unlit = m.extension_value(UNLIT).is_some();
    if mat.dispersion > 0.0 && mat.volume.is_none() {
        warnings.add(format!(
            "material {:?}: dispersion needs KHR_materials_volume (a thin wall does not bend light): ignored",
            mat.name
        ));
    }
    mat
}

/// Checks that an accessor has at least one element (glTF 2.0, 5.1: count >= 1, and so for
/// sparse.count) and that its bytes, and its sparse indices' and values', lie inside their
/// buffer views and buffers, so that reading cannot go out of range. Sizes are compared in
/// u128, so no count or offset in the file can overflow them.
fn check_accessor(a: &gltf::Accessor, buffers: &[buffer::Data]) -> Result<(), String> {
    let check_view = |view: &gltf::buffer::View, offset: usize, count: usize, size: usize| {
        let stride = view.stride().unwrap_or(size);
        if stride < size {
            return Err(format!(
                "accessor {}: byteStride {stride} is smaller than its elements ({size} bytes)",
                a.index()
            ));
        }
        let needed = offset as u128 + stride as u128 * (count as u128 - 1) + size as u128;
        let buffer_len = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
        if needed > view.length() as u128 || view.offset() as u128 + view.length() as u128 > buffer_len as u128 {
            return Err(format!("accessor {} reaches past the end of its buffer", a.index()));
        }
        Ok(())
    };
    if a.count() == 0 {
        return Err(format!("invalid glTF: accessors[{}].count is 0 (at least 1 is required)", a.index()));
    }
    if let Some(view) = a.view() {
        check_view(&view, a.offset(), a.count(), a.size())?;
    }
    if let Some(sparse) = a.sparse() {
        if sparse.count() == 0 {
            return Err(format!("invalid glTF: accessors[{}].sparse.count is 0 (at least 1 is required)", a.index()));
        }
        let (idx, val) = (sparse.indices(), sparse.values());
        check_view(&idx.view(), idx.offset(), sparse.count(), idx.index_type().size())?;
        check_view(&val.view(), val.offset(), sparse.count(), a.size())?;
    }
    Ok(())
}

/// Rejects an attribute (or, for `Weights(u32::MAX)`, the indices) whose accessor type is
/// not one the spec (with KHR_mesh_quantization when `quantized`) allows for it.
fn check_attribute_type(semantic: &Semantic, a: &gltf::Accessor, quantized: bool) -> Result<(), String> {
    if attributes::allowed(semantic, a, quantized) {
        return Ok(());
    }
    let (dims, ty) = (a.dimensions(), a.data_type());
    let norm = if a.normalized() { "normalized " } else { "" };
    let what = if matches!(semantic, Semantic::Weights(u32::MAX)) { "indices".into() } else { semantic.to_string() };
    Err(format!("invalid glTF: accessor {} is {dims:?} of {norm}{ty:?}, which {what} cannot be", a.index()))
}

fn convert_primitive(
    prim: &gltf::Primitive,
    buffers: &[buffer::Data],
    world: DMat4,
    default_material: u32,
    tangent_space: bool,
    weights: &[f32],
    warnings: &mut Warnings,
) -> Result<Option<(MeshDesc, Vec<DVec3>)>, String> {
    let mode = prim.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        warnings.add(format!("primitives of mode {mode:?} are not rendered"));
        return Ok(None);
    }
    // check_primitives has checked the accessors and that the attributes' counts agree.
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| &d.0[..]);
    let reader = prim.reader(get);
    let read = |semantic: Semantic| prim.get(&semantic);
    let unreadable = |a: &gltf::Accessor| format!("accessor {} cannot be read", a.index());
    let Some(position_accessor) = read(Semantic::Positions) else {
        warnings.add("a primitive without POSITION was skipped");
        return Ok(None);
    };
    let mut positions = attributes::read::<3>(&position_accessor, get).ok_or_else(|| unreadable(&position_accessor))?;
    attributes::morph(&mut positions, prim.morph_targets().map(|t| t.positions()), weights, get)?;
    let positions: Vec<DVec3> =
        positions.into_iter().map(|p| world.transform_point3(Vec3::from(p).as_dvec3())).collect();
    let n = positions.len();
    let normal_matrix = DMat3::from_mat4(world).inverse().transpose();
    let normals = match read(Semantic::Normals) {
        Some(a) => Some({
            let mut normals = attributes::read::<3>(&a, get).ok_or_else(|| unreadable(&a))?;
            attributes::morph(&mut normals, prim.morph_targets().map(|t| t.normals()), weights, get)?;
            normals
                .into_iter()
                .map(|v| (normal_matrix * Vec3::from(v).as_dvec3()).normalize_or_zero().as_vec3())
                .collect::<Vec<_>>()
        }),
        None => None,
    };
    let uv = |set: u32| -> Result<Option<Vec<Vec2>>, String> {
        read(Semantic::TexCoords(set))
            .map(|a| attributes::read::<2>(&a, get).ok_or_else(|| unreadable(&a)))
            .transpose()
            .map(|v| v.map(|v| v.into_iter().map(Vec2::from).collect()))
    };
    let (uvs, uvs1) = (uv(0)?, uv(1)?);
    let colors = reader.read_colors(0).map(|c| c.into_rgba_f32().map(Vec4::from).collect::<Vec<_>>());
    let linear = DMat3::from_mat4(world);
    let handedness = world.determinant().signum() as f32;
    let tangents = match read(Semantic::Tangents).filter(|_| tangent_space) {
        Some(a) => Some({
            let tangents = attributes::read::<4>(&a, get).ok_or_else(|| unreadable(&a))?;
            let mut xyz: Vec<[f32; 3]> = tangents.iter().map(|t| [t[0], t[1], t[2]]).collect();
            attributes::morph(&mut xyz, prim.morph_targets().map(|t| t.tangents()), weights, get)?;
            xyz.into_iter()
                .zip(tangents)
                .map(|(v, t)| {
                    let xyz = (linear * Vec3::from(v).as_dvec3()).normalize_or_zero().as_vec3();
                    xyz.extend(t[3] * handedness)
                })
                .collect::<Vec<_>>()
        }),
        None => None,
    };
    let raw: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..n as u32).collect(),
    };
    if let Some(bad) = raw.iter().find(|&&i| i as usize >= n) {
        return Err(format!("index {bad} is out of range for a primitive with {n} vertices"));
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
        variants: variants::mappings(prim, default_material, warnings),
        instances: Vec::new(),
    };
    if tangent_space && mesh.tangents.is_none() {
        if mesh.uvs.is_none() {
            warnings.add(
                "a primitive that needs tangents (normal map, anisotropy, clearcoat normal map) has neither \
                 TANGENT nor TEXCOORD_0: normal maps ignored, anisotropy along an arbitrary direction",
            );
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

/// A KHR_lights_punctual light placed by `node`, whose parent's world transform is
/// `parent`. Photometric intensities are used 1:1 as radiometric ones: 1 cd is radiant
/// intensity 1 W/sr and 1 lx is irradiance 1 W/m^2, on the same scale as emissive radiance
/// (as the Khronos sample viewer does); `range` is ignored. The light's position and its
/// source's parent transform are in the file's world space until the scene is centred.
fn convert_light(light: &gltf::khr_lights_punctual::Light, node: &gltf::Node, parent: DMat4) -> (PunctualLight, DVec3) {
    let world = parent * DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
    let kind = match light.kind() {
        Kind::Directional => PunctualKind::Directional,
        Kind::Point => PunctualKind::Point,
        Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            PunctualKind::Spot(Cone::new(inner_cone_angle, outer_cone_angle))
        }
    };
    // A range of 0, negative or not finite is no range; a directional light has none.
    let range = light.range().filter(|r| *r > 0.0 && r.is_finite() && !matches!(kind, PunctualKind::Directional));
    let light = PunctualLight {
        name: light.name().unwrap_or("light").into(),
        kind,
        position: Vec3::ZERO,
        direction: world.transform_vector3(-DVec3::Z).normalize_or(-DVec3::Z).as_vec3(),
        color: Vec3::from(light.color()),
        intensity: light.intensity(),
        range,
        source: Some(LightSource { light: light.index() as u32, node: node.index() as u32, parent }),
    };
    (light, world.transform_point3(DVec3::ZERO))
}

//! How much memory loading may take, and what a scene will cost before it is allocated:
//! the bytes per vertex, triangle, texel and material of the loader's and the renderer's
//! own structures, all in this one place, so that a file is refused with one line
//! ("scene too large: ...") instead of growing without bound.
//!
//! The struct sizes are `size_of` the structures themselves; what the gltf crate, obvhs and
//! the image decoders allocate was measured with a counting global allocator, over the
//! shared sample models and synthetic meshes of 1e4 to 1.1e6 triangles. tests/bad_input.rs
//! replays that measurement: every estimate must stay above what loading and building
//! really took at the peak, and within 2x of it.

pub use crate::memory::{Limits, format_bytes};
use crate::scene::{
    MeshDesc,
    geometry::{TriAttrs, TriExtra},
    light::PunctualLight,
    material::Material,
};
use glam::{DVec3, Vec2, Vec3, Vec4};
use std::mem::size_of;

const fn bytes_of<T>() -> u64 {
    size_of::<T>() as u64
}

/// A triangle in the built scene: its positions and `TriAttrs` as `Scene::build` pushes
/// them (twice, for the slack of a vector grown by doubling), their copy in BVH order,
/// its padded box (an obvhs `Aabb` of two `Vec3A`) and obvhs's CWBVH build over the boxes.
/// Measured over 1e4 to 1.1e6 triangles: `Geometry::build` peaks at 336 bytes per triangle
/// beyond its inputs (the 112-byte copy, the 32-byte box, 192 for the build).
pub(crate) const TRIANGLE: u64 = 3 * (bytes_of::<[Vec3; 3]>() + bytes_of::<TriAttrs>()) + 32 + 192;

/// The `TriExtra` of a triangle (pushed, with slack, and copied as in `TRIANGLE`), when any
/// mesh has a second UV set, vertex colours or tangents.
pub(crate) const TRIANGLE_EXTRA: u64 = 3 * bytes_of::<TriExtra>();

/// An emissive triangle in the light sampler: its `TriangleLight` (12 bytes) pushed with
/// slack, its candidate (`Light`, power) (24), its weight, the alias table's pmf, bins and
/// build lists (scaled weights and the small and large index lists), its `Light` in the
/// sampler (16) and its choice probability and area. Counted for every triangle when any
/// material emits.
pub(crate) const EMISSIVE_TRIANGLE: u64 = 2 * 12 + 24 + 8 + (4 + 8 + 8 + 2 * 8) + 16 + 8;

/// A placed triangle's probability in the light sampler (an f32 per placed triangle), held
/// when any material emits.
pub(crate) const TRIANGLE_PMF: u64 = 4;

/// A placement of an instanced mesh while the file is converted: its entry in the list of
/// placed primitives (node, mesh, primitive and f64 transform) and in the set of placed
/// (geometry, transform) pairs, each with the slack of growing by doubling, and its f64
/// transform kept for the mesh.
pub(crate) const PLACEMENT: u64 = 2 * (3 * 32 + 128) + 2 * (8 + 128 + 24) + 2 * 128;

/// A placement of an instanced mesh in the built scene: its f32 transform in the scene
/// description, the (mesh, transform) list `Scene::build` gathers, the `Instance` (two
/// transforms and a normal matrix) before and after ordering, its padded box and obvhs's
/// build over it (as for a triangle), each list with the slack of growing by doubling.
pub(crate) const INSTANCE: u64 = 2 * 48 + 2 * 64 + 2 * 160 + 32 + 192;

/// A texel of a decoded texture as the renderer keeps it (RGBA8; twice that for 16-bit images).
pub(crate) const TEXEL: u64 = 4;

/// A decoder's own state beyond the image it decodes into, as a fraction (1/8) of that
/// image plus a constant. Measured at 2048x2048: PNG 0.3 MB, JPEG 0.9 MB.
pub(crate) fn decoding(image_bytes: u64) -> u64 {
    image_bytes.saturating_add(image_bytes / 8).saturating_add(1 << 20)
}

/// A material (the names and measured tables behind it are small or counted elsewhere).
pub(crate) const MATERIAL: u64 = bytes_of::<Material>();

/// A punctual light or camera placed by a node, while flattening and in the scene (its
/// name is counted apart).
pub(crate) const NODE_PAYLOAD: u64 = 2 * (bytes_of::<PunctualLight>() + bytes_of::<DVec3>()) + 64;

/// A placed primitive before its arrays and name: its `MeshDesc` and f64 positions' vector
/// header (twice: the list of them grows by doubling), and its entry in the set of placed
/// (geometry, transform) pairs (a usize and 16 f64 bits, with the hash table's slack).
pub(crate) const PRIMITIVE: u64 = 2 * (bytes_of::<MeshDesc>() + bytes_of::<Vec<DVec3>>()) + 2 * (8 + 128 + 16);

/// Vertex attributes a primitive brings, for costing it.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Attributes {
    /// NORMAL.
    pub normals: bool,
    /// TEXCOORD_0.
    pub uvs: bool,
    /// TEXCOORD_1.
    pub uvs1: bool,
    /// COLOR_0.
    pub colors: bool,
    /// Tangents, read or generated.
    pub tangents: bool,
}

impl Attributes {
    /// Bytes per vertex of the attributes other than the position.
    fn per_vertex(self) -> u64 {
        let v3 = bytes_of::<Vec3>();
        let (v2, v4) = (bytes_of::<Vec2>(), bytes_of::<Vec4>());
        [(self.normals, v3), (self.uvs, v2), (self.uvs1, v2), (self.colors, v4), (self.tangents, v4)]
            .iter()
            .filter(|(present, _)| *present)
            .map(|(_, b)| b)
            .sum()
    }
}

/// One primitive as the loader will convert it, in counts.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PrimitiveShape {
    /// Vertices read (POSITION's count).
    pub vertices: u64,
    /// Indices read (the indices accessor's count, or `vertices`).
    pub indices: u64,
    /// Triangles after triangulating strips and fans.
    pub triangles: u64,
    /// Attributes kept per vertex.
    pub attributes: Attributes,
    /// Whether MikkTSpace tangents are generated, unwelding the mesh to one vertex per corner.
    pub generates_tangents: bool,
    /// Bytes of its mesh's name, which every copy holds.
    pub name: u64,
}

impl PrimitiveShape {
    /// Vertices the converted mesh keeps (one per corner after tangent generation).
    fn kept_vertices(&self) -> u64 {
        if self.generates_tangents { 3 * self.triangles } else { self.vertices }
    }

    /// Bytes one placed copy holds while the file is converted: f64 world positions, the
    /// other attributes and the triangle list.
    pub(crate) fn converting(&self) -> u64 {
        let per_vertex = bytes_of::<DVec3>() + self.attributes.per_vertex();
        PRIMITIVE + self.name + self.kept_vertices() * per_vertex + 12 * self.triangles
    }

    /// Bytes one placed copy holds in the scene description (f32 positions), which lives
    /// until the scene is built.
    pub(crate) fn described(&self) -> u64 {
        let per_vertex = bytes_of::<Vec3>() + self.attributes.per_vertex();
        PRIMITIVE + self.name + self.kept_vertices() * per_vertex + 12 * self.triangles
    }

    /// Bytes converting one copy takes beyond what it keeps: the raw index list and, with
    /// tangent generation, the welded mesh it started from and MikkTSpace's per-corner
    /// inputs (corner index, f32 position, face and picked normals).
    pub(crate) fn transient(&self) -> u64 {
        let raw = 4 * self.indices;
        if !self.generates_tangents {
            return raw;
        }
        let welded = self.vertices * (bytes_of::<DVec3>() + self.attributes.per_vertex()) + 12 * self.triangles;
        raw + welded + 3 * self.triangles * (8 + 12 + 2 * 12)
    }
}

/// Small allocations not counted one by one: names, warnings, the gltf crate's wrappers,
/// image decoders' state, the hierarchy walk's stack.
pub(crate) const OVERHEAD: u64 = 1 << 20;

/// Parsing glTF JSON, per byte of text (strings are kept), per object (a gltf-json struct
/// such as `Node` or `Accessor`, up to a few hundred bytes, or a map) and per other value
/// (an array element or map entry). Measured: the shared models' .gltf JSON parses to 1.4
/// to 3.4 bytes per byte of text; 100,000 empty nodes ("{},") to 325 bytes each, and
/// 100,000 nodes each with an unknown extension holding 13 numbers to 2,100 bytes each.
const JSON_BYTE: u64 = 2;
const JSON_OBJECT: u64 = 512;
const JSON_VALUE: u64 = 64;

/// A bound on what parsing the JSON text `json` takes, from its length and its counts of
/// objects ('{') and other values (',' and '['), counted without parsing (braces and
/// commas inside strings count too, which only raises the bound).
pub(crate) fn parsed_json(json: &[u8]) -> u64 {
    let (mut objects, mut values) = (0u64, 0u64);
    for &b in json {
        match b {
            b'{' => objects += 1,
            b',' | b'[' => values += 1,
            _ => {}
        }
    }
    JSON_BYTE * json.len() as u64 + JSON_OBJECT * objects + JSON_VALUE * values
}

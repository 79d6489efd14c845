//! OpenVDB files checked before vdb-rs reads them, so that a hostile file is refused in one
//! line instead of making the reader allocate what its fields declare or panic: the walk
//! follows the archive layout (OpenVDB's io::Archive and io::Compression: header, grid
//! descriptors, each grid's metadata, transform, tree topology and leaf buffers) and checks
//! every length against the bytes left, every count against what the node holds, the
//! version against the oldest vdb-rs reads (222, OpenVDB 3) and grid names for repeats. It
//! also totals what the reader will hold for the grid, for the memory budget.
//!
//! A linear transform vdb-rs does not parse (AffineMap, UnitaryMap, ScaleMap,
//! TranslationMap) is replaced in the copy it reads by a unit UniformScaleMap, and the
//! file positions after it moved by the difference: the renderer ignores the grid's
//! transform (the grid is fitted to the meshes that hold it), so the grid reads the same.

use std::collections::HashSet;

/// OpenVDB's magic number, the first eight bytes of every file (little-endian int64).
const MAGIC: u64 = 0x5644_4220;

/// The oldest file version read: per-grid compression flags and node metadata bytes
/// (OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION).
const OLDEST_VERSION: u32 = 222;

/// io::Compression flags: zlib, active-mask compression, Blosc.
const ZIP: u32 = 0x1;
const ACTIVE_MASK: u32 = 0x2;
const BLOSC: u32 = 0x4;

/// Bytes of a UniformScaleMap's values (five Vec3d: scale, voxel size, inverse scale, its
/// square and inverse twice the scale).
const UNIFORM_SCALE_VALUES: usize = 5 * 24;

/// What the grid read holds in vdb-rs per node beyond the file: values as f32 and masks.
const ROOT_HELD: u64 = 32768 * 4 + 3 * 4096 + 256;
const INTERNAL_HELD: u64 = 4096 * 4 + 3 * 512 + 128;
const LEAF_HELD: u64 = 512 * 4 + 2 * 64 + 96;

/// A file checked and prepared for vdb-rs: its bytes (transforms replaced) and what
/// reading the chosen grid holds.
pub struct Prepared {
    /// The bytes vdb-rs is given.
    pub bytes: Vec<u8>,
    /// The grid to read.
    pub grid: String,
    /// Bytes vdb-rs holds once the grid is read.
    pub held: u64,
}

/// A reading position over the file's bytes; every read is checked against the end.
struct Walk<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Walk<'a> {
    fn take(&mut self, n: u64, what: &str) -> Result<&'a [u8], String> {
        let end = usize::try_from(n).ok().and_then(|n| self.at.checked_add(n)).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(format!("{what} ({n} bytes at byte {}) runs past the end of the file", self.at));
        };
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], String> {
        Ok(self.take(N as u64, what)?.try_into().expect("N bytes"))
    }

    fn u32(&mut self, what: &str) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    fn u64(&mut self, what: &str) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    fn string(&mut self, what: &str) -> Result<String, String> {
        let n = self.u32(what)?;
        Ok(String::from_utf8_lossy(self.take(n.into(), what)?).into_owned())
    }

    fn seek(&mut self, pos: u64, what: &str) -> Result<(), String> {
        match usize::try_from(pos).ok().filter(|&p| p <= self.bytes.len()) {
            Some(p) => {
                self.at = p;
                Ok(())
            }
            None => Err(format!("{what} ({pos}) lies past the end of the file")),
        }
    }
}

/// A grid's descriptor: its name, type and where its parts lie.
struct Descriptor {
    name: String,
    kind: String,
    grid_pos: u64,
    block_pos: u64,
    /// Where in the file its three position fields lie.
    fields: usize,
}

/// Reads metadata as vdb-rs does (known types by their size, others by the declared
/// length); returns whether it marks the grid as saved in half floats.
fn metadata(w: &mut Walk) -> Result<bool, String> {
    let count = w.u32("metadata count")?;
    let mut half = false;
    for _ in 0..count {
        let name = w.string("metadata name")?;
        let kind = w.string("metadata type")?;
        let len = w.u32("metadata length")?;
        let size = match kind.as_str() {
            "bool" => 1,
            "int32" | "float" => 4,
            "int64" => 8,
            "vec3i" => 12,
            _ => len.into(),
        };
        let value = w.take(size, "a metadata value")?;
        if name == "is_saved_as_half_float" && kind == "bool" {
            half = value[0] != 0;
        }
    }
    Ok(half)
}

/// Bytes of a transform's values after its name, for the maps OpenVDB writes linearly.
fn map_values(name: &str) -> Option<usize> {
    match name {
        "UniformScaleMap" | "ScaleMap" => Some(UNIFORM_SCALE_VALUES),
        "UniformScaleTranslateMap" | "ScaleTranslateMap" => Some(6 * 24),
        "AffineMap" | "UnitaryMap" => Some(16 * 8),
        "TranslationMap" => Some(24),
        _ => None,
    }
}

/// A node's compressed values (io::readCompressedValues) with `values` entries and the
/// active ones marked in `mask`, each an f32.
fn values(w: &mut Walk, compression: u32, values: u64, mask: &[u8]) -> Result<(), String> {
    let size = 4;
    let meta = w.array::<1>("node metadata")?[0];
    if meta > 6 {
        return Err(format!("node metadata {meta} at byte {} is not one OpenVDB writes", w.at - 1));
    }
    let inactive = match meta {
        2 | 4 => 1,
        5 => 2,
        _ => 0,
    };
    w.take(inactive * size, "inactive values")?;
    if matches!(meta, 3..=5) {
        w.take(values / 8, "a selection mask")?;
    }
    let count = if compression & ACTIVE_MASK != 0 && meta != 6 {
        mask.iter().map(|b| u64::from(b.count_ones())).sum()
    } else {
        values
    };
    let expected = count * size;
    if compression & (BLOSC | ZIP) == 0 {
        w.take(expected, "node values")?;
        return Ok(());
    }
    let n = i64::from_le_bytes(w.array("a compressed length")?);
    if n <= 0 {
        let raw = n.unsigned_abs();
        if raw != expected {
            return Err(format!("{raw} raw bytes where the node holds {expected}"));
        }
        w.take(raw, "node values")?;
        return Ok(());
    }
    let data = w.take(n.unsigned_abs(), "compressed node values")?;
    if compression & BLOSC != 0 && count > 0 {
        // A Blosc frame's header gives its decompressed size in bytes 4 to 8.
        let decompressed = data.get(4..8).map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")));
        if decompressed.is_none_or(|d| u64::from(d) > expected) {
            return Err(format!("a Blosc block at byte {} decompresses to more than its node holds", w.at));
        }
    }
    Ok(())
}

/// A node's child and value masks of `2^(3 log2)` bits and its values.
fn node<'a>(w: &mut Walk<'a>, compression: u32, log2: u32) -> Result<&'a [u8], String> {
    let bits = 1u64 << (3 * log2);
    let children = w.take(bits / 8, "a child mask")?;
    let mask = w.take(bits / 8, "a value mask")?;
    values(w, compression, bits, mask)?;
    Ok(children)
}

fn ones(mask: &[u8]) -> usize {
    mask.iter().map(|b| b.count_ones() as usize).sum()
}

/// The tree of the grid at `d` (topology, then leaf buffers from `block_pos`); returns
/// what vdb-rs holds once it is read.
fn tree(w: &mut Walk, d: &Descriptor, compression: u32) -> Result<u64, String> {
    if w.u32("buffer count")? != 1 {
        return Err("a tree with more than one buffer per node is not read".into());
    }
    w.u32("background")?;
    let (tiles, roots) = (w.u32("tile count")?, w.u32("root count")?);
    w.take(u64::from(tiles) * 17, "root tiles")?;
    let mut leaves = Vec::new();
    let mut held = 0u64;
    for _ in 0..roots {
        w.take(12, "a root's origin")?;
        let children = node(w, compression, 5)?;
        held += ROOT_HELD;
        for _ in 0..ones(children) {
            let children = node(w, compression, 4)?;
            held += INTERNAL_HELD;
            leaves.push(ones(children));
            w.take(64 * ones(children) as u64, "leaf masks")?;
        }
    }
    w.seek(d.block_pos, "the grid's block position")?;
    for _ in 0..leaves.iter().sum::<usize>() {
        let mask = w.take(64, "a leaf's value mask")?;
        values(w, compression, 512, mask)?;
        held += LEAF_HELD;
    }
    Ok(held)
}

/// Checks `bytes` as an OpenVDB file and prepares it for vdb-rs to read `grid` (the first
/// grid by name if None). The error is one line.
pub fn prepare(bytes: Vec<u8>, grid: Option<&str>) -> Result<Prepared, String> {
    let mut w = Walk { bytes: &bytes, at: 0 };
    if w.u64("the magic number")? != MAGIC {
        return Err("not an OpenVDB file".into());
    }
    let version = w.u32("the file version")?;
    if version < OLDEST_VERSION {
        return Err(format!(
            "file version {version} (before OpenVDB 3) is not read: save it again with OpenVDB 3 or later"
        ));
    }
    w.take(8, "the library version")?;
    if w.array::<1>("the grid offsets flag")?[0] != 1 {
        return Err("a file without grid offsets is not read".into());
    }
    w.take(36, "the file's UUID")?;
    metadata(&mut w)?;
    let count = w.u32("grid count")?;
    let mut grids = Vec::new();
    let mut names = HashSet::new();
    for _ in 0..count {
        let name = w.string("a grid name")?;
        let kind = w.string("a grid type")?;
        w.string("an instance parent")?;
        let fields = w.at;
        let [grid_pos, block_pos, end_pos] = [0; 3].map(|_| w.u64("grid positions"));
        let (grid_pos, block_pos, end_pos) = (grid_pos?, block_pos?, end_pos?);
        if !names.insert(name.clone()) {
            return Err(format!("two grids are named \"{name}\""));
        }
        w.seek(grid_pos, "a grid position")?;
        let compression = w.u32("grid compression")?;
        if compression & !(ZIP | ACTIVE_MASK | BLOSC) != 0 {
            return Err(format!("grid \"{name}\" has unknown compression flags {compression:#x}"));
        }
        metadata(&mut w)?;
        grids.push(Descriptor { name, kind, grid_pos, block_pos, fields });
        w.seek(end_pos, "a grid's end position")?;
    }
    let mut sorted: Vec<&str> = grids.iter().map(|d| d.name.as_str()).collect();
    sorted.sort_unstable();
    let chosen = match grid {
        Some(g) => grids
            .iter()
            .find(|d| d.name == g)
            .ok_or_else(|| format!("it has no grid \"{g}\" (it has {})", sorted.join(", ")))?,
        None => {
            let first = sorted.first().ok_or("it holds no grid")?;
            grids.iter().find(|d| d.name == *first).expect("a listed grid")
        }
    };
    if !chosen.kind.contains("float") {
        return Err(format!("grid \"{}\" holds {}, not float densities", chosen.name, chosen.kind));
    }
    w.seek(chosen.grid_pos, "a grid position")?;
    let compression = w.u32("grid compression")?;
    if metadata(&mut w)? {
        return Err(format!(
            "grid \"{}\" is saved as half floats, which vdb-rs misreads: save it with full floats",
            chosen.name
        ));
    }
    let map_at = w.at;
    let map = w.string("the transform's name")?;
    let Some(map_len) = map_values(&map) else {
        return Err(format!("grid \"{}\" has a {map} transform, which is not read", chosen.name));
    };
    w.take(map_len as u64, "the transform")?;
    let map_end = w.at;
    let held = tree(&mut w, chosen, compression)?;
    let name = chosen.name.clone();
    if matches!(map.as_str(), "UniformScaleMap" | "UniformScaleTranslateMap" | "ScaleTranslateMap") {
        return Ok(Prepared { bytes, grid: name, held });
    }
    let fields: Vec<usize> = grids.iter().map(|d| d.fields).collect();
    Ok(Prepared { bytes: replace_map(&bytes, map_at..map_end, &fields), grid: name, held })
}

/// The file with the transform record at `record` replaced by a unit UniformScaleMap and
/// every grid position (three u64 at each of `fields`) after it moved to match.
fn replace_map(bytes: &[u8], record: std::ops::Range<usize>, fields: &[usize]) -> Vec<u8> {
    let name = b"UniformScaleMap";
    let mut map = Vec::with_capacity(4 + name.len() + UNIFORM_SCALE_VALUES);
    map.extend((name.len() as u32).to_le_bytes());
    map.extend(name);
    for _ in 0..15 {
        map.extend(1.0f64.to_le_bytes());
    }
    let shift = |pos: u64| {
        if pos >= record.end as u64 { pos - record.len() as u64 + map.len() as u64 } else { pos }
    };
    let mut out = Vec::with_capacity(bytes.len() - record.len() + map.len());
    out.extend(&bytes[..record.start]);
    out.extend(&map);
    out.extend(&bytes[record.end..]);
    for &at in fields {
        let at = shift(at as u64) as usize;
        for k in 0..3 {
            let field = &mut out[at + 8 * k..at + 8 * k + 8];
            let pos = u64::from_le_bytes((&*field).try_into().expect("8 bytes"));
            field.copy_from_slice(&shift(pos).to_le_bytes());
        }
    }
    out
}

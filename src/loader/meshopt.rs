//! EXT_meshopt_compression: compressed buffer views decoded by meshoptimizer's decoders
//! (the meshopt crate) into plain ones before anything reads them, within the memory limit.

use super::Refusal;
use super::resources::{Tally, append_buffer};
use gltf::buffer;
use gltf::json::{self, Index, Root, Value, validation::USize64};
use meshopt::encoding as codec;

/// The extension's name, in `extensionsUsed` and on buffers and buffer views.
pub(super) const EXTENSION: &str = "EXT_meshopt_compression";

/// Whether buffer `index` is a fallback that the decoded views replace, so it is not read.
pub(super) fn is_fallback(json: &Root, index: usize) -> bool {
    json.buffers
        .get(index)
        .and_then(|b| b.extensions.as_ref())
        .and_then(|e| e.others.get(EXTENSION))
        .is_some_and(|e| e["fallback"] == true)
}

/// Whether any buffer view is compressed.
pub(super) fn used(json: &Root) -> bool {
    json.buffer_views.iter().any(|v| compressed(v).is_some())
}

fn compressed(view: &json::buffer::View) -> Option<&Value> {
    view.extensions.as_ref().and_then(|e| e.others.get(EXTENSION))
}

/// Decodes every compressed view of `json` from its source buffer into a buffer of its own
/// (appended to `buffers`, counted in `tally`), and points the view at it.
pub(super) fn decode(json: &mut Root, buffers: &mut Vec<buffer::Data>, tally: &mut Tally) -> Result<(), Refusal> {
    for i in 0..json.buffer_views.len() {
        let Some(ext) = compressed(&json.buffer_views[i]) else { continue };
        let what = format!("bufferViews[{i}].extensions.{EXTENSION}");
        let field = |key: &str| ext[key].as_u64().ok_or_else(|| format!("invalid glTF: {what}.{key} is missing"));
        let (source, length, stride, count) =
            (field("buffer")?, field("byteLength")?, field("byteStride")?, field("count")?);
        let offset = ext["byteOffset"].as_u64().unwrap_or(0);
        let mode = ext["mode"].as_str().unwrap_or("").to_owned();
        let filter = ext["filter"].as_str().unwrap_or("NONE").to_owned();
        let source = usize::try_from(source).ok().filter(|&b| b < buffers.len() && !is_fallback(json, b));
        let data = source
            .and_then(|b| {
                buffers[b].get(usize::try_from(offset).ok()?..usize::try_from(offset.checked_add(length)?).ok()?)
            })
            .ok_or_else(|| format!("invalid glTF: {what} names bytes outside a readable buffer"))?;
        let decoded = count.checked_mul(stride).filter(|&n| n <= json.buffer_views[i].byte_length.0 && count > 0);
        let Some(decoded) = decoded else {
            return Err(Refusal::Invalid(format!(
                "invalid glTF: {what}: {count} elements of {stride} bytes do not fit the view's byteLength"
            )));
        };
        if decoded > most_decoded(&mode, stride, data.len() as u64) {
            return Err(Refusal::Invalid(format!(
                "invalid glTF: {what}: {count} elements of {stride} bytes cannot come from {} compressed bytes",
                data.len()
            )));
        }
        // Counted before decoding: every mode and filter decodes count x stride bytes.
        tally.admit(&what, decoded)?;
        let bytes = crate::guard::decode("the meshopt decoder", || {
            decode_view(&mode, &filter, stride as usize, count as usize, data)
        })
        .and_then(|r| r)
        .map_err(|e| Refusal::Invalid(format!("{what} (mode {mode}, filter {filter}): {e}")))?;
        let length = USize64(bytes.len() as u64);
        let buffer = append_buffer(json, buffers, bytes);
        let view = &mut json.buffer_views[i];
        view.buffer = Index::new(buffer);
        view.byte_offset = Some(USize64(0));
        view.byte_length = length;
        view.extensions = None;
    }
    Ok(())
}

/// The most bytes `compressed` bytes of a stream in `mode` can decode to, from the least
/// each format spends per element (meshoptimizer's bitstreams): an attribute stream at
/// least 2 control bits per byte channel of a block of up to 256 elements (version 1; version
/// 0 spends 2 header bits per 16 values), so one compressed byte per 1024 decoded; a
/// triangle at least its code byte, an index at least one byte of its varint.
fn most_decoded(mode: &str, stride: u64, compressed: u64) -> u64 {
    match mode {
        "ATTRIBUTES" => compressed.saturating_mul(1024),
        "TRIANGLES" => compressed.saturating_mul(3 * stride),
        _ => compressed.saturating_mul(stride),
    }
}

/// One compressed stream decoded as the extension's mode and filter say.
fn decode_view(mode: &str, filter: &str, stride: usize, count: usize, data: &[u8]) -> Result<Vec<u8>, String> {
    match (mode, filter, stride) {
        ("ATTRIBUTES", "NONE", _) => vertices(data, count, stride),
        ("ATTRIBUTES", "EXPONENTIAL", _) => {
            let mut words: Vec<[u32; 1]> = vertices(data, count, stride)?
                .chunks_exact(4)
                .map(|w| [u32::from_le_bytes([w[0], w[1], w[2], w[3]])])
                .collect();
            // Each 32-bit component decodes on its own, whatever the stride.
            codec::decode_filter_exp(&mut words);
            Ok(words.iter().flat_map(|w| w[0].to_le_bytes()).collect())
        }
        ("ATTRIBUTES", "OCTAHEDRAL", 4) => {
            let mut v = codec::decode_vertex_buffer::<[i8; 4]>(data, count).map_err(|e| e.to_string())?;
            codec::decode_filter_oct(&mut v);
            Ok(v.iter().flatten().map(|&c| c as u8).collect())
        }
        ("ATTRIBUTES", "OCTAHEDRAL", 8) => {
            let mut v = codec::decode_vertex_buffer::<[i16; 4]>(data, count).map_err(|e| e.to_string())?;
            codec::decode_filter_oct(&mut v);
            Ok(v.iter().flatten().flat_map(|c| c.to_le_bytes()).collect())
        }
        ("ATTRIBUTES", "QUATERNION", 8) => {
            let mut v = codec::decode_vertex_buffer::<[i16; 4]>(data, count).map_err(|e| e.to_string())?;
            codec::decode_filter_quat(&mut v);
            Ok(v.iter().flatten().flat_map(|c| c.to_le_bytes()).collect())
        }
        ("TRIANGLES", "NONE", 2) => indices(codec::decode_index_buffer::<u16>(data, count)),
        ("TRIANGLES", "NONE", 4) => indices(codec::decode_index_buffer::<u32>(data, count)),
        ("INDICES", "NONE", 2) => indices(codec::decode_index_sequence::<u16>(data, count)),
        ("INDICES", "NONE", 4) => indices(codec::decode_index_sequence::<u32>(data, count)),
        _ => Err(format!("byteStride {stride} is not one this mode and filter allow")),
    }
}

/// Decoded indices as little-endian bytes.
fn indices<T: Copy + Into<u32>>(decoded: meshopt::Result<Vec<T>>) -> Result<Vec<u8>, String> {
    let v = decoded.map_err(|e| e.to_string())?;
    let size = std::mem::size_of::<T>();
    Ok(v.iter().flat_map(|&i| i.into().to_le_bytes().into_iter().take(size)).collect())
}

/// One vertex of `N` bytes: the element meshoptimizer's vertex decoder is given, whose size
/// is the stream's stride.
#[derive(Clone, Copy)]
struct Vertex<const N: usize>([u8; N]);

impl<const N: usize> Default for Vertex<N> {
    fn default() -> Self {
        Self([0; N])
    }
}

fn vertices_of<const N: usize>(data: &[u8], count: usize) -> Result<Vec<u8>, String> {
    let v = codec::decode_vertex_buffer::<Vertex<N>>(data, count).map_err(|e| e.to_string())?;
    Ok(v.into_iter().flat_map(|v| v.0).collect())
}

/// An attribute stream of `count` vertices of `stride` bytes (a multiple of 4, at most 256).
fn vertices(data: &[u8], count: usize, stride: usize) -> Result<Vec<u8>, String> {
    macro_rules! by_stride {
        ($($n:literal)*) => {
            match stride {
                $($n => vertices_of::<$n>(data, count),)*
                _ => Err(format!("byteStride {stride} is not a multiple of 4 from 4 to 256")),
            }
        };
    }
    by_stride!(4 8 12 16 20 24 28 32 36 40 44 48 52 56 60 64 68 72 76 80 84 88 92 96 100 104 108 112 116
        120 124 128 132 136 140 144 148 152 156 160 164 168 172 176 180 184 188 192 196 200 204 208 212 216 220
        224 228 232 236 240 244 248 252 256)
}

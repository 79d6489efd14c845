//! The buffers and images a glTF file names (a GLB's BIN chunk, data URIs, files beside
//! it), read with their sizes known before anything large is allocated, and errors that
//! say which one failed and why. Files are read only if they are regular files that fit
//! in the memory limit: a URI naming /dev/zero or a 20 GB file is refused, not read.

use super::Refusal;
use super::limits::format_bytes;
use gltf::{Document, buffer};
use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader};
use std::borrow::Cow;
use std::io::{Cursor, Read};
use std::path::{Path, PathBuf};

/// Memory counted so far against a limit.
pub struct Tally {
    /// Bytes counted.
    pub used: u64,
    /// The limit.
    pub limit: u64,
}

impl Tally {
    /// Room left under the limit.
    pub fn room(&self) -> u64 {
        self.limit.saturating_sub(self.used)
    }

    /// Counts `bytes` that `what` decodes to, or refuses them if they do not fit.
    pub fn admit(&mut self, what: &str, bytes: u64) -> Result<(), Refusal> {
        if bytes > self.room() {
            return Err(Refusal::TooLarge(format!(
                "{what} decodes to {}, over the memory limit of {}",
                format_bytes(bytes),
                format_bytes(self.limit)
            )));
        }
        self.used = self.used.saturating_add(bytes);
        Ok(())
    }
}

/// Appends decoded `bytes` to the document as a buffer of its own (without a URI) and to
/// `buffers` as its data; returns the buffer's index.
pub fn append_buffer(json: &mut gltf::json::Root, buffers: &mut Vec<buffer::Data>, bytes: Vec<u8>) -> u32 {
    json.buffers.push(gltf::json::Buffer {
        byte_length: gltf::json::validation::USize64(bytes.len() as u64),
        name: None,
        uri: None,
        extensions: None,
        extras: Default::default(),
    });
    buffers.push(buffer::Data(bytes));
    json.buffers.len() as u32 - 1
}

/// A URI as messages show it (data URIs are long).
fn shown(uri: &str) -> String {
    if uri.starts_with("data:") { "a data URI".into() } else { uri.into() }
}

/// One line for an I/O error.
fn io_reason(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".into(),
        _ => e.to_string(),
    }
}

/// The bytes of a data URI, a `file:` URI or a path relative to `base` (percent-decoded,
/// as glTF URIs are); files must be regular and fit in the room left under the limit.
/// `what` names the resource in errors ("buffer 0").
fn read_uri(what: &str, uri: &str, base: Option<&Path>, tally: &Tally) -> Result<Vec<u8>, Refusal> {
    let fail = |reason: String| Refusal::Resource(what.into(), shown(uri), reason);
    if uri.starts_with("data:") {
        // Decoded in memory from the file's own text, so no larger than it.
        return buffer::Data::from_source(buffer::Source::Uri(uri), None)
            .map(|d| d.0)
            .map_err(|e| fail(e.to_string().replace('\n', " ")));
    }
    let path = match uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")) {
        Some(rest) => PathBuf::from(rest),
        None if uri.contains(':') => return Err(fail("unsupported URI scheme".into())),
        None => {
            let decoded = urlencoding::decode(uri).map_err(|_| fail("percent-decodes to invalid UTF-8".into()))?;
            base.ok_or_else(|| fail("a file loaded from memory cannot name other files".into()))?.join(&*decoded)
        }
    };
    let size = crate::memory::regular_file_size(&path, u64::MAX).map_err(fail)?;
    if size > tally.room() {
        return Err(Refusal::TooLarge(format!(
            "{what} ({uri}) is {}, so loading needs at least {}, over the memory limit of {}",
            format_bytes(size),
            format_bytes(tally.used.saturating_add(size)),
            format_bytes(tally.limit)
        )));
    }
    let mut data = Vec::with_capacity(size as usize);
    std::fs::File::open(&path).and_then(|f| f.take(size).read_to_end(&mut data)).map_err(|e| fail(io_reason(&e)))?;
    Ok(data)
}

/// Reads every buffer of the document, counting each in `tally`: the GLB's BIN chunk
/// (`blob`), data URIs and files (relative to `base`). Each must hold at least its
/// byteLength (glTF 2.0, 5.10). An EXT_meshopt_compression fallback buffer is left empty.
pub fn buffers(
    doc: &Document,
    base: Option<&Path>,
    mut blob: Option<Vec<u8>>,
    tally: &mut Tally,
) -> Result<Vec<buffer::Data>, Refusal> {
    let mut out = Vec::new();
    for b in doc.buffers() {
        if super::meshopt::is_fallback(doc.as_json(), b.index()) {
            out.push(buffer::Data(Vec::new()));
            continue;
        }
        let what = format!("buffer {}", b.index());
        let (mut data, name) = match b.source() {
            buffer::Source::Bin => match blob.take() {
                Some(d) => (d, "the GLB's BIN chunk".to_owned()),
                None => return Err(Refusal::Invalid(format!("{what}: the file has no GLB BIN chunk for it"))),
            },
            buffer::Source::Uri(uri) => (read_uri(&what, uri, base, tally)?, shown(uri)),
        };
        if data.len() < b.length() {
            return Err(Refusal::Invalid(format!(
                "{what} ({name}) has {} bytes, fewer than its byteLength of {}",
                data.len(),
                b.length()
            )));
        }
        data.resize(data.len().next_multiple_of(4), 0);
        tally.used = tally.used.saturating_add(data.len() as u64);
        out.push(buffer::Data(data));
    }
    Ok(out)
}

/// An image's encoded bytes and what its header says decoding will produce.
pub struct Encoded<'a> {
    /// "image 2 (tex.png)", for messages.
    pub name: String,
    bytes: Cow<'a, [u8]>,
    /// None: a KTX2 (Basis Universal) texture.
    format: Option<ImageFormat>,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Bytes of the decoded image (width x height x channels x bytes per channel).
    pub decoded: u64,
    /// Whether its channels have 16 bits, kept as 16-bit texels.
    pub deep: bool,
}

impl Encoded<'_> {
    /// Bytes held for the encoded data itself (none when it is a slice of a buffer).
    pub fn held(&self) -> u64 {
        match &self.bytes {
            Cow::Owned(b) => b.len() as u64,
            Cow::Borrowed(_) => 0,
        }
    }
}

/// Reads the encoded bytes (counted in `tally`) and the PNG, JPEG, WebP or KTX2 header of every
/// image a texture shows, without decoding: the header gives the size the decoder will
/// allocate. None for an image no texture shows (a KTX2 beside its fallback, say): unread.
pub fn image_headers<'a>(
    doc: &Document,
    base: Option<&Path>,
    buffers: &'a [buffer::Data],
    tally: &mut Tally,
) -> Result<Vec<Option<Encoded<'a>>>, Refusal> {
    let shown_images: std::collections::HashSet<usize> = doc.textures().map(|t| t.source().index()).collect();
    let mut out = Vec::new();
    for image in doc.images() {
        if !shown_images.contains(&image.index()) {
            out.push(None);
            continue;
        }
        let what = format!("image {}", image.index());
        let (bytes, name): (Cow<[u8]>, String) = match image.source() {
            gltf::image::Source::View { view, .. } => {
                // check_buffer_views has checked that the view lies inside its buffer.
                let data = &buffers[view.buffer().index()][view.offset()..view.offset() + view.length()];
                (Cow::Borrowed(data), format!("{what} (bufferView {})", view.index()))
            }
            gltf::image::Source::Uri { uri, .. } => {
                let data = read_uri(&what, uri, base, tally)?;
                tally.used = tally.used.saturating_add(data.len() as u64);
                (Cow::Owned(data), format!("{what} ({})", shown(uri)))
            }
        };
        let header = |e: &dyn std::fmt::Display| Refusal::Invalid(format!("{name}: {e}"));
        if bytes.starts_with(KTX2_MAGIC) {
            let (width, height) = ktx2_base_level(&bytes).map_err(|e| header(&e))?;
            crate::guard::decode("the Basis Universal transcoder", || basisu::Transcoder::new(&bytes).map(drop))
                .map_err(|e| header(&e))?
                .map_err(|e| header(&format!("not a Basis Universal KTX2 ({e:?})")))?;
            let decoded = u64::from(width) * u64::from(height) * 4;
            out.push(Some(Encoded { name, bytes, format: None, width, height, decoded, deep: false }));
            continue;
        }
        let mut reader = ImageReader::new(Cursor::new(&*bytes)).with_guessed_format().map_err(|e| header(&e))?;
        let format = match reader.format() {
            Some(f @ (ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::WebP)) => f,
            _ => return Err(header(&"not a PNG, JPEG (glTF 2.0, 3.9.3), WebP or KTX2 image")),
        };
        reader.no_limits();
        let decoder = reader.into_decoder().map_err(|e| header(&e.to_string().replace('\n', " ")))?;
        let (width, height) = decoder.dimensions();
        let decoded = decoder.total_bytes();
        let color = decoder.color_type();
        let deep = color.bytes_per_pixel() / color.channel_count() == 2;
        drop(decoder);
        let format = Some(format);
        out.push(Some(Encoded { name, bytes, format, width, height, decoded, deep }));
    }
    Ok(out)
}

/// Decodes an image whose header was read, allowing the decoder `max_alloc` bytes.
pub fn decode(image: Encoded, max_alloc: u64) -> Result<DynamicImage, Refusal> {
    let Some(format) = image.format else { return transcode(&image) };
    let mut reader = ImageReader::with_format(Cursor::new(&*image.bytes), format);
    let mut limits = image::Limits::no_limits();
    limits.max_alloc = Some(max_alloc);
    reader.limits(limits);
    let decoder = format!("the {format:?} decoder");
    crate::guard::decode(&decoder, || reader.decode())
        .map_err(|e| Refusal::Invalid(format!("{}: {e}", image.name)))?
        .map_err(|e| Refusal::Invalid(format!("{}: {}", image.name, e.to_string().replace('\n', " "))))
}

/// The identifier that opens every KTX2 file (KTX 2.0 specification, 3.1).
const KTX2_MAGIC: &[u8] = b"\xabKTX 20\xbb\r\n\x1a\n";

/// Most bytes a texel of a Basis Universal level takes once inflated: a UASTC 4x4 block
/// is 16 bytes, one per texel (ETC1S slices are smaller).
const KTX2_LEVEL_BYTES_PER_TEXEL: u64 = 1;

/// A KTX2 file's base size, from its header and level index (KTX 2.0 specification, 3.1
/// and 3.9), after checking what the transcoder will allocate from them: the base level
/// (index 0) lies inside the file, and its inflated length (Zstandard supercompression
/// inflates the whole level to the declared `uncompressedByteLength`) is no more than its
/// texels could need (one byte per texel of every layer, face and slice, rounded up to
/// whole 4x4 blocks).
fn ktx2_base_level(bytes: &[u8]) -> Result<(u32, u32), String> {
    let u32_at = |o: usize| bytes.get(o..o + 4).map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")));
    let u64_at = |o: usize| bytes.get(o..o + 8).map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")));
    let short = || "the KTX2 header is cut short".to_string();
    let [width, height, depth, layers, faces] = [20, 24, 28, 32, 36].map(u32_at);
    let (width, height) = (width.ok_or_else(short)?, height.ok_or_else(short)?);
    let (depth, layers, faces) = (depth.ok_or_else(short)?, layers.ok_or_else(short)?, faces.ok_or_else(short)?);
    let (offset, length, inflated) = (u64_at(80).ok_or_else(short)?, u64_at(88).ok_or_else(short)?, u64_at(96));
    let inflated = inflated.ok_or_else(short)?;
    if offset.checked_add(length).is_none_or(|end| end > bytes.len() as u64) {
        return Err(format!("KTX2 level 0 ({length} bytes at {offset}) lies outside the file's {} bytes", bytes.len()));
    }
    let blocks = |n: u32| u64::from(n).div_ceil(4) * 4;
    let texels = [blocks(width), blocks(height), u64::from(depth.max(1)), u64::from(layers.max(1)), u64::from(faces)]
        .into_iter()
        .try_fold(1u64, u64::checked_mul);
    let most = texels.and_then(|t| t.checked_mul(KTX2_LEVEL_BYTES_PER_TEXEL)).unwrap_or(u64::MAX);
    if inflated > most {
        return Err(format!(
            "KTX2 level 0 declares {} once inflated, more than its {width}x{height} texels need ({})",
            format_bytes(inflated),
            format_bytes(most)
        ));
    }
    Ok((width, height))
}

/// A KHR_texture_basisu image's base level transcoded to RGBA8 by the pure-Rust Basis
/// Universal transcoder (the `basisu` crate), its size already counted from the header.
fn transcode(image: &Encoded) -> Result<DynamicImage, Refusal> {
    let fail = |e: basisu::Error| Refusal::Invalid(format!("{}: the KTX2 does not transcode ({e:?})", image.name));
    let texels = crate::guard::decode("the Basis Universal transcoder", || {
        let texture = basisu::Transcoder::new(&image.bytes)?;
        texture.transcode(0, basisu::TargetFormat::Rgba32, basisu::DecodeFlags::NONE)
    })
    .map_err(|e| Refusal::Invalid(format!("{}: {e}", image.name)))?
    .map_err(fail)?;
    image::RgbaImage::from_raw(image.width, image.height, texels)
        .map(DynamicImage::ImageRgba8)
        .ok_or_else(|| Refusal::Invalid(format!("{}: the KTX2 transcodes to the wrong size", image.name)))
}

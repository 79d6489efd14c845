//! A piece of a render: the film's sums for a range of sample indices, with a header
//! naming what was rendered, so that `lucent merge` can check and add pieces made on other
//! machines. A text header line (JSON) precedes the row-major pixel sums, little-endian:
//! three i128 fixed-point sums, three f64 sums of squares and a u64 count per pixel.
//! Written to a temporary file and renamed, so a piece is whole or absent.

use super::accum::{Film, PixelSums};
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Read, Write};
use std::path::Path;

/// Bytes per pixel in a piece file.
const PIXEL_BYTES: usize = 3 * 16 + 3 * 8 + 8;

/// What a piece holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Format version.
    pub format: u32,
    /// Content hash of the scene's files (hex).
    pub scene: String,
    /// The render settings, sample range aside (TOML).
    pub settings: String,
    /// The camera (its position, orientation and field of view).
    pub camera: String,
    /// How the merged image is displayed (PNG output).
    pub display: super::tonemap::Display,
    /// First sample index of every pixel.
    pub first: u32,
    /// Samples per pixel in the piece.
    pub count: u32,
    /// Film width.
    pub width: u32,
    /// Film height.
    pub height: u32,
    /// Samples dropped for being NaN or infinite.
    pub rejected: u64,
}

/// The format version this build writes and reads.
pub const FORMAT: u32 = 1;

/// Writes `film` as a piece described by `header` to `path`, atomically.
pub fn write(path: &Path, header: &Header, film: &Film) -> Result<(), super::output::OutputError> {
    super::output::replace_file(path, |tmp| -> std::io::Result<()> {
        let mut out = std::io::BufWriter::new(std::fs::File::create(tmp)?);
        let line = serde_json::to_string(header).map_err(std::io::Error::other)?;
        writeln!(out, "{line}")?;
        for p in film.row_major() {
            for s in p.sum {
                out.write_all(&s.to_le_bytes())?;
            }
            for q in p.sum_sq.to_array() {
                out.write_all(&q.to_le_bytes())?;
            }
            out.write_all(&p.count.to_le_bytes())?;
        }
        out.into_inner().map_err(|e| e.into_error())?.sync_all()
    })
}

/// Reads a piece: its header and film. A short, long or malformed file is an error.
pub fn read(path: &Path) -> Result<(Header, Film), String> {
    let fail = |e: &dyn std::fmt::Display| format!("piece {}: {e}", path.display());
    let file = std::fs::File::open(path).map_err(|e| fail(&e))?;
    let size = file.metadata().map_err(|e| fail(&e))?.len();
    let mut reader = std::io::BufReader::new(file);
    let mut line = String::new();
    reader.by_ref().take(64 * 1024).read_line(&mut line).map_err(|e| fail(&e))?;
    let header: Header = serde_json::from_str(line.trim_end()).map_err(|e| fail(&format!("bad header: {e}")))?;
    if header.format != FORMAT {
        return Err(fail(&format!("format {} (this build reads {FORMAT})", header.format)));
    }
    let pixels = header.width as u64 * header.height as u64;
    if pixels.checked_mul(PIXEL_BYTES as u64).and_then(|b| b.checked_add(line.len() as u64)) != Some(size) {
        return Err(fail(&format!("{size} bytes do not hold {}x{} pixels", header.width, header.height)));
    }
    let mut data = vec![0u8; pixels as usize * PIXEL_BYTES];
    reader.read_exact(&mut data).map_err(|e| fail(&e))?;
    let sums: Vec<PixelSums> = data
        .chunks_exact(PIXEL_BYTES)
        .map(|b| {
            let int = |i: usize| i128::from_le_bytes(b[16 * i..16 * i + 16].try_into().unwrap());
            let float = |i: usize| f64::from_le_bytes(b[48 + 8 * i..56 + 8 * i].try_into().unwrap());
            PixelSums {
                sum: [int(0), int(1), int(2)],
                sum_sq: glam::DVec3::new(float(0), float(1), float(2)),
                count: u64::from_le_bytes(b[72..80].try_into().unwrap()),
            }
        })
        .collect();
    Ok((header.clone(), Film::from_row_major(header.width, header.height, &sums, header.rejected)))
}

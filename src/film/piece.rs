//! A piece of a render: the film's sums for a range of sample indices over a window of the
//! frame, with a header naming what was rendered, so that `lucent merge` can check and add
//! pieces made on other machines. A text header line (JSON) precedes the window's
//! row-major pixel sums, little-endian: three i128 fixed-point sums, three f64 sums of
//! squares and a u64 count per pixel.
//! Written to a temporary file and renamed, so a piece is whole or absent.

use super::accum::{Film, PixelSums};
use super::window::Window;
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

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
    /// Frame width.
    pub width: u32,
    /// Frame height.
    pub height: u32,
    /// The frame's pixels the piece holds.
    pub window: Window,
    /// Samples dropped for being NaN or infinite.
    pub rejected: u64,
}

/// The format version this build writes and reads.
pub const FORMAT: u32 = 2;

/// Writes `film` as a piece described by `header` to `path`, atomically.
pub fn write(path: &Path, header: &Header, film: &Film) -> Result<(), super::output::OutputError> {
    super::output::replace_file(path, |tmp| -> std::io::Result<()> {
        let mut out = std::io::BufWriter::new(std::fs::File::create(tmp)?);
        let line = serde_json::to_string(header).map_err(std::io::Error::other)?;
        writeln!(out, "{line}")?;
        for p in film.row_segments().flatten() {
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

/// A piece file whose header has been read and checked against the file's size.
#[derive(Clone, Debug)]
pub struct Piece {
    /// What the piece holds.
    pub header: Header,
    /// Where it is.
    pub path: PathBuf,
    /// Offset of the first pixel's sums.
    data: u64,
}

impl Piece {
    /// Reads a piece's header. A file whose size does not match it is an error.
    pub fn open(path: &Path) -> Result<Self, String> {
        let fail = |e: &dyn std::fmt::Display| format!("piece {}: {e}", path.display());
        // A FIFO would block the read forever: regular files only.
        let size = crate::memory::regular_file_size(path, u64::MAX).map_err(|e| fail(&e))?;
        let file = std::fs::File::open(path).map_err(|e| fail(&e))?;
        let mut line = String::new();
        std::io::BufReader::new(file).take(64 * 1024).read_line(&mut line).map_err(|e| fail(&e))?;
        let header: Header = serde_json::from_str(line.trim_end()).map_err(|e| fail(&format!("bad header: {e}")))?;
        if header.format != FORMAT {
            return Err(fail(&format!("format {} (this build reads {FORMAT})", header.format)));
        }
        let max = crate::params::MAX_SIDE;
        if u64::from(header.width) > max || u64::from(header.height) > max {
            return Err(fail(&format!(
                "a {}x{} frame is larger than any render ({max} a side)",
                header.width, header.height
            )));
        }
        if header.first.checked_add(header.count).is_none() {
            return Err(fail(&format!(
                "samples {}..{}+{} run past the last sample number",
                header.first, header.first, header.count
            )));
        }
        header
            .window
            .check(header.width, header.height)
            .map_err(|e| fail(&format!("window {}: {e}", header.window)))?;
        let expected =
            header.window.area().checked_mul(PIXEL_BYTES as u64).and_then(|b| b.checked_add(line.len() as u64));
        if expected != Some(size) {
            return Err(fail(&format!("{size} bytes do not hold the {} window's pixels", header.window)));
        }
        Ok(Self { header, path: path.to_path_buf(), data: line.len() as u64 })
    }

    /// Adds the piece's sums over `cell` (a window inside the piece's) to `sums`, row-major
    /// over `cell`; reads only those rows.
    pub fn add_to(&self, cell: &Window, sums: &mut [PixelSums]) -> Result<(), String> {
        let fail = |e: &dyn std::fmt::Display| format!("piece {}: {e}", self.path.display());
        let w = self.header.window;
        debug_assert!(w.contains(cell) && sums.len() as u64 == cell.area());
        let mut file = std::fs::File::open(&self.path).map_err(|e| fail(&e))?;
        let mut row = vec![0u8; cell.width() as usize * PIXEL_BYTES];
        for (y, out) in (cell.y0..cell.y1).zip(sums.chunks_exact_mut(cell.width() as usize)) {
            let pixel = (y - w.y0) as u64 * w.width() as u64 + (cell.x0 - w.x0) as u64;
            file.seek(SeekFrom::Start(self.data + pixel * PIXEL_BYTES as u64)).map_err(|e| fail(&e))?;
            file.read_exact(&mut row).map_err(|e| fail(&e))?;
            for (b, px) in row.chunks_exact(PIXEL_BYTES).zip(out.iter_mut()) {
                px.merge(&decode(b));
            }
        }
        Ok(())
    }
}

/// One pixel's sums from its `PIXEL_BYTES` bytes.
fn decode(b: &[u8]) -> PixelSums {
    let int = |i: usize| i128::from_le_bytes(b[16 * i..16 * i + 16].try_into().expect("16 bytes"));
    let float = |i: usize| f64::from_le_bytes(b[48 + 8 * i..56 + 8 * i].try_into().expect("8 bytes"));
    PixelSums {
        sum: [int(0), int(1), int(2)],
        sum_sq: glam::DVec3::new(float(0), float(1), float(2)),
        count: u64::from_le_bytes(b[72..80].try_into().expect("8 bytes")),
    }
}

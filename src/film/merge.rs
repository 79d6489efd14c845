//! Merging the pieces of one render (sample ranges of windows of the frame). The windows'
//! edges cut the frame into cells; the pieces covering a cell must hold disjoint sample
//! ranges, and for a complete merge cover 0..N with the same N in every cell. A cell's sums
//! are the exact fixed-point sum of its pieces', so the image is bit-identical to the one a
//! single process renders. The merge holds the frame's mean image and one cell's sums,
//! never the whole frame's sums.

use super::accum::PixelSums;
use super::piece::{Header, Piece};
use super::tonemap::Display;
use super::window::Window;
use crate::memory::{Limits, format_bytes};
use glam::Vec3;
use std::path::{Path, PathBuf};

/// The merged image of a set of pieces.
#[derive(Clone, Debug)]
pub struct Merged {
    /// Frame width.
    pub width: u32,
    /// Frame height.
    pub height: u32,
    /// Row-major mean radiance per pixel (zero where no piece has arrived).
    pub mean: Vec<Vec3>,
    /// How the image is displayed (from the pieces' header).
    pub display: Display,
    /// Pieces merged.
    pub pieces: usize,
    /// Fewest and most samples per pixel over the frame.
    pub spp: (u32, u32),
    /// Samples the pieces dropped for being NaN or infinite.
    pub rejected: u64,
}

/// The `.part` files in `dir`, by name.
pub fn pieces_in(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "part") && p.is_file())
        .collect();
    paths.sort();
    Ok(paths)
}

/// What differs between the renders two pieces belong to (None: the same render). Pieces
/// share everything but their sample range, window and drops.
fn difference(a: &Header, b: &Header) -> Option<String> {
    if a.scene != b.scene {
        return Some("the scene's files differ".into());
    }
    if a.camera != b.camera {
        return Some("the camera differs".into());
    }
    if (a.width, a.height) != (b.width, b.height) {
        return Some(format!("the frame is {}x{} against {}x{}", a.width, a.height, b.width, b.height));
    }
    if a.settings != b.settings {
        let line = |s: &str, other: &str| s.lines().find(|l| !other.lines().any(|o| o == *l)).map(str::to_string);
        let (x, y) = (line(&a.settings, &b.settings), line(&b.settings, &a.settings));
        return Some(format!(
            "settings differ ({} against {})",
            x.unwrap_or_else(|| "-".into()),
            y.unwrap_or_else(|| "-".into())
        ));
    }
    None
}

/// Opens every piece and checks that they are pieces of one render.
pub fn open_all(paths: &[PathBuf]) -> Result<Vec<Piece>, String> {
    let mut pieces: Vec<Piece> = Vec::with_capacity(paths.len());
    for path in paths {
        let piece = Piece::open(path)?;
        if let Some(first) = pieces.first()
            && let Some(why) = difference(&first.header, &piece.header)
        {
            return Err(format!(
                "{} is a piece of another render than {}: {why}",
                path.display(),
                first.path.display()
            ));
        }
        pieces.push(piece);
    }
    Ok(pieces)
}

/// Most (cell, piece) pairs a merge examines (about a second's work): a grid of 100x100
/// windows takes 1e8, one of 1000x1000 would take 1e12 and is refused.
const MAX_CELL_CHECKS: usize = 1 << 30;

/// A rectangle of the frame that the same pieces cover, and those pieces by first sample.
struct Cell {
    window: Window,
    pieces: Vec<usize>,
    /// Samples per pixel its pieces hold.
    spp: u32,
}

/// Cuts the frame along every piece's window edges; refuses pieces whose sample ranges
/// overlap in a cell.
fn cells(pieces: &[Piece], width: u32, height: u32) -> Result<Vec<Cell>, String> {
    let edges = |f: fn(&Window) -> [u32; 2], end: u32| {
        let mut e: Vec<u32> = pieces.iter().flat_map(|p| f(&p.header.window)).chain([0, end]).collect();
        e.sort_unstable();
        e.dedup();
        e
    };
    let (xs, ys) = (edges(|w| [w.x0, w.x1], width), edges(|w| [w.y0, w.y1], height));
    let count = (xs.len() - 1) * (ys.len() - 1);
    if count.saturating_mul(pieces.len()) > MAX_CELL_CHECKS {
        return Err(format!(
            "{} pieces cut the frame into {count} cells, too many to check: use bands or a grid of windows",
            pieces.len()
        ));
    }
    let mut cells = Vec::with_capacity(count);
    for y in ys.windows(2) {
        for x in xs.windows(2) {
            let window = Window { x0: x[0], y0: y[0], x1: x[1], y1: y[1] };
            let mut inside: Vec<usize> =
                (0..pieces.len()).filter(|&i| pieces[i].header.window.contains(&window)).collect();
            inside.sort_by_key(|&i| pieces[i].header.first);
            for pair in inside.windows(2) {
                let (a, b) = (&pieces[pair[0]].header, &pieces[pair[1]].header);
                if b.first < a.first + a.count {
                    return Err(format!(
                        "{} and {} both hold samples {}..{} of pixels {window}",
                        pieces[pair[0]].path.display(),
                        pieces[pair[1]].path.display(),
                        b.first,
                        (a.first + a.count).min(b.first + b.count)
                    ));
                }
            }
            let spp = inside.iter().map(|&i| pieces[i].header.count).sum();
            cells.push(Cell { window, pieces: inside, spp });
        }
    }
    Ok(cells)
}

/// Checks that every cell holds samples 0..N, one N for all (`spp` if given); names the
/// first missing range.
fn check_complete(pieces: &[Piece], cells: &[Cell], spp: Option<u32>) -> Result<u32, String> {
    let end = |c: &Cell| c.pieces.iter().map(|&i| pieces[i].header.first + pieces[i].header.count).max();
    let total = spp.unwrap_or_else(|| cells.iter().filter_map(end).max().unwrap_or(0));
    for cell in cells {
        let mut next = 0;
        for &i in &cell.pieces {
            let h = &pieces[i].header;
            if h.first > next {
                return Err(format!("samples {next}..{} of pixels {} are missing", h.first, cell.window));
            }
            next = h.first + h.count;
        }
        if next < total {
            return Err(format!("samples {next}..{total} of pixels {} are missing", cell.window));
        }
        if next > total {
            return Err(format!("pixels {} hold samples 0..{next}, more than --spp {total}", cell.window));
        }
    }
    Ok(total)
}

/// Merges pieces of one render. `complete`: every pixel must hold samples 0..N (N = `spp`
/// if given), else each pixel shows the mean of what has arrived.
pub fn merge(paths: &[PathBuf], complete: bool, spp: Option<u32>) -> Result<Merged, String> {
    let pieces = open_all(paths)?;
    let Some(first) = pieces.first() else {
        return Err("no pieces to merge".into());
    };
    let (width, height) = (first.header.width, first.header.height);
    let cells = cells(&pieces, width, height)?;
    // The mean image and its encoded copy, and the largest cell's sums.
    let largest = cells.iter().filter(|c| !c.pieces.is_empty()).map(|c| c.window.area()).max().unwrap_or(0);
    let bytes = (width as u64 * height as u64)
        .checked_mul(24)
        .and_then(|b| b.checked_add(largest.checked_mul(std::mem::size_of::<PixelSums>() as u64)?));
    let limit = Limits::from_machine().memory;
    if bytes.is_none_or(|b| b > limit) {
        return Err(format!(
            "merging a {width}x{height} frame needs about {}, over the memory limit of {}",
            bytes.map_or("more than 18 EB".into(), format_bytes),
            format_bytes(limit)
        ));
    }
    if complete {
        check_complete(&pieces, &cells, spp)?;
    }
    let mut mean = vec![Vec3::ZERO; width as usize * height as usize];
    for cell in cells.iter().filter(|c| !c.pieces.is_empty()) {
        let mut sums = vec![PixelSums::default(); cell.window.area() as usize];
        for &i in &cell.pieces {
            pieces[i].add_to(&cell.window, &mut sums)?;
        }
        for (y, row) in (cell.window.y0..cell.window.y1).zip(sums.chunks_exact(cell.window.width() as usize)) {
            let start = y as usize * width as usize + cell.window.x0 as usize;
            for (out, px) in mean[start..start + row.len()].iter_mut().zip(row) {
                *out = px.mean().as_vec3();
            }
        }
    }
    let counts = cells.iter().map(|c| c.spp);
    Ok(Merged {
        width,
        height,
        mean,
        display: first.header.display,
        pieces: pieces.len(),
        spp: (counts.clone().min().unwrap_or(0), counts.max().unwrap_or(0)),
        rejected: pieces.iter().map(|p| p.header.rejected).sum(),
    })
}

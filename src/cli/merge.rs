//! `lucent merge`: adds pieces of one render (sample ranges of every pixel, written by
//! `lucent render --samples A..B --out NAME.part`) into its image. Film sums are exact
//! fixed point, so the merge is bit-identical to the render made in one process. Pieces of
//! another scene, camera, settings or seed, overlapping ranges and missing ranges are
//! refused in one line.

use super::args::MergeArgs;
use crate::film::output::{check_writable, write_image};
use crate::film::piece::{self, Header};
use sha2::{Digest, Sha256};
use std::path::Path;

/// Content hash of a scene: its file and the sidecars beside it that change it, or the
/// built-in scene's name and version.
pub fn scene_hash(path: Option<&Path>) -> Result<String, String> {
    let mut hash = Sha256::new();
    match path {
        None => hash.update(format!("built-in Cornell box, lucent {}", env!("CARGO_PKG_VERSION"))),
        Some(p) => {
            hash.update(std::fs::read(p).map_err(|e| format!("{}: {e}", p.display()))?);
            for sidecar in [crate::loader::sidecar::path_for(p), crate::loader::media::path_for(p)] {
                if let Ok(bytes) = std::fs::read(&sidecar) {
                    hash.update(bytes);
                }
            }
        }
    }
    Ok(hash.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// Parses `A..B` (A < B).
pub fn sample_range(text: &str) -> Result<(u32, u32), String> {
    let bad = || format!("--samples {text}: expected A..B with A < B, sample indices");
    let (a, b) = text.split_once("..").ok_or_else(bad)?;
    let (a, b): (u32, u32) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
    if a < b { Ok((a, b)) } else { Err(bad()) }
}

/// What two pieces of one render share: everything but their sample range and drops.
fn same_render(a: &Header, b: &Header) -> bool {
    let key = |h: &Header| (h.format, h.scene.clone(), h.settings.clone(), h.camera.clone(), h.width, h.height);
    key(a) == key(b)
}

/// Runs `lucent merge`.
pub fn run(args: &MergeArgs) -> Result<(), String> {
    check_writable(&args.out).map_err(|e| e.to_string())?;
    let mut pieces = Vec::new();
    for path in &args.pieces {
        let (header, film) = piece::read(path)?;
        if let Some((first, _, _)) = pieces.first()
            && !same_render(first, &header)
        {
            return Err(format!(
                "{} is a piece of another render than {} (scene, camera, settings, seed or size differ)",
                path.display(),
                args.pieces[0].display()
            ));
        }
        pieces.push((header, film, path.clone()));
    }
    pieces.sort_by_key(|(h, _, _)| h.first);
    let mut next = 0u32;
    for (h, _, path) in &pieces {
        if h.first < next {
            return Err(format!(
                "{} (samples {}..{}) overlaps another piece below {next}",
                path.display(),
                h.first,
                h.first + h.count
            ));
        }
        if h.first > next {
            return Err(format!("samples {next}..{} are missing", h.first));
        }
        next = h.first + h.count;
    }
    if let Some(total) = args.spp {
        if next < total {
            return Err(format!("samples {next}..{total} are missing"));
        }
        if next > total {
            return Err(format!("the pieces hold samples 0..{next}, more than --spp {total}"));
        }
    }
    let (header, mut film, _) = pieces.remove(0);
    for (_, other, _) in &pieces {
        film.merge(other);
    }
    write_image(&args.out, film.width, film.height, &film.mean_image(), &header.display).map_err(|e| e.to_string())?;
    println!("merged {} pieces, samples 0..{next}; wrote {}", pieces.len() + 1, args.out.display());
    Ok(())
}

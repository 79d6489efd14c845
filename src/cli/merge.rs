//! `lucent merge`: adds pieces of one render (sample ranges and windows, written by
//! `lucent render --samples A..B --region X0,Y0,X1,Y1 --out NAME.part`) into its image
//! (`film::merge`, bit-identical to the render made in one process). Pieces of another
//! scene, camera, settings or seed, overlapping ranges and missing ones are refused in one
//! line.

use super::args::MergeArgs;
use crate::film::merge;
use crate::film::output::{check_writable, write_image};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// Content hash of a scene: its file and the sidecars beside it that change it, or the
/// built-in scene's name and version.
pub fn scene_hash(path: Option<&Path>) -> Result<String, String> {
    let mut hash = Sha256::new();
    match path {
        None => hash.update(format!("built-in Cornell box, lucent {}", env!("CARGO_PKG_VERSION"))),
        Some(p) => {
            hash.update(std::fs::read(p).map_err(|e| format!("{}: {e}", p.display()))?);
            for sidecar in [crate::loader::sidecar::path_for(p), crate::loader::media::path_for(p)] {
                if let Ok(bytes) = crate::memory::read_text(&sidecar) {
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

/// The piece files named: files as given, folders by the `.part` files in them.
pub fn piece_paths(args: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    let mut paths = Vec::new();
    for a in args {
        if a.is_dir() {
            let inside = merge::pieces_in(a)?;
            if inside.is_empty() {
                return Err(format!("{}: a folder without .part files", a.display()));
            }
            paths.extend(inside);
        } else {
            paths.push(a.clone());
        }
    }
    Ok(paths)
}

/// Runs `lucent merge`.
pub fn run(args: &MergeArgs) -> Result<(), String> {
    check_writable(&args.out).map_err(|e| e.to_string())?;
    let m = merge::merge(&piece_paths(&args.pieces)?, true, args.spp)?;
    write_image(&args.out, m.width, m.height, &m.mean, &m.display).map_err(|e| e.to_string())?;
    println!("merged {} pieces, {} spp at {}x{}; wrote {}", m.pieces, m.spp.0, m.width, m.height, args.out.display());
    Ok(())
}

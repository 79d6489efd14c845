//! The film: per-pixel sums owned by tiles, and turning them into images (and denoised ones).

pub mod accum;
pub mod adaptive;
pub mod denoise;
pub mod false_colour;
pub mod merge;
pub mod oidn;
pub mod output;
pub mod piece;
pub mod splat;
pub mod tonemap;
pub mod window;

pub use accum::{AovImages, Film, TILE_SIZE, Tile};

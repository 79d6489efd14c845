//! The film: per-pixel sums owned by tiles, and turning them into images.

pub mod accum;
pub mod merge;
pub mod output;
pub mod piece;
pub mod tonemap;
pub mod window;

pub use accum::{Film, Tile};

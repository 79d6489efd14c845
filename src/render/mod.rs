//! Progressive rendering: a session whose workers keep adding passes to the film.

mod session;

pub use session::{Job, RenderSession, SessionError, Snapshot, film_bytes, on_tile_grid, threshold_bytes};

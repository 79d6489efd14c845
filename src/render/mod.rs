//! Progressive rendering: a session whose workers keep adding passes to the film.

mod session;

pub use session::{Job, RenderSession, SessionError, Snapshot, film_bytes};

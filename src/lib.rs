//! Lucent: a physically based path tracer for glTF scenes that refines progressively.
//!
//! The data flows one way:
//!
//! ```text
//! glTF file / built-in scene
//!     -> loader      (flatten node transforms, materials, lights, cameras)
//!     -> Scene       (immutable: triangles + CWBVH, materials, lights, feature set)
//!     -> integrator  (path tracer with its sampling toggles, specialised per feature set)
//!     -> film        (per-pixel f64 sums owned by tiles)
//!     -> render      (session: workers, generations, snapshots)
//!     -> viewer      (winit + wgpu + egui window)  |  cli (headless render, benchmarks)
//! ```

pub mod bsdf;
pub mod cli;
pub mod config;
pub mod film;
pub mod integrator;
pub mod loader;
pub mod math;
pub mod render;
pub mod scene;
pub mod viewer;

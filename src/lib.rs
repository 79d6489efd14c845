//! Lucent: a physically based path tracer for glTF scenes that refines progressively.
//!
//! The data flows one way:
//!
//! ```text
//! glTF file / built-in scene
//!     -> loader      (flatten node transforms, materials, lights, cameras)
//!     -> scene       (immutable: triangles in eight-wide BVHs, two levels for instances;
//!                     materials, lights, feature set)
//!     -> integrator  (path tracer and distribution ray tracer with their sampling switches)
//!     -> film        (exact 128-bit fixed-point sums of radiance and f64 sums of squares,
//!                     owned by tiles; tone mapping; PNG, EXR and piece output)
//!     -> render      (session: workers, generations, snapshots)
//!     -> viewer      (winit + wgpu + egui window)  |  cli (headless render, benchmarks)
//! ```
//!
//! - [`loader`] reads glTF ([`loader::gltf`]) or builds the Cornell box ([`loader::builtin`]);
//!   [`open()`] is the one entry that loads, lights and builds a [`scene::Scene`].
//! - [`scene`] holds geometry and its BVH ([`scene::geometry`]), materials
//!   ([`scene::material`]), lights, one type per kind, and their sampling interface
//!   ([`scene::light`]), among them the environment ([`scene::environment`]), and cameras
//!   ([`scene::camera`]).
//! - [`bsdf`] has the reflection models in the shading frame; [`spectrum`] the quantity
//!   light transport carries.
//! - [`integrator`] estimates radiance per pixel sample ([`integrator::sample_pixel`]),
//!   configured by [`integrator::Settings`], whose parameter table ([`params`]) the command
//!   line, the viewer and view files ([`config`]) share.
//! - [`film`] accumulates samples ([`film::accum`]) and writes images ([`film::output`]).
//! - [`render`] runs a [`render::RenderSession`] of worker threads over the film.
//! - [`viewer`] and [`cli`] are the two front ends; `main.rs` only dispatches to them.
//!
//! A minimal program (examples/render.rs):
//!
//! ```no_run
//! use lucent::{open::OpenOptions, render::{Job, RenderSession}, integrator::Settings};
//! let scene = std::sync::Arc::new(lucent::open(None, &OpenOptions::default(), &mut |_| {})?);
//! let settings = Settings { width: 64, height: 64, target_spp: Some(16), ..Settings::default() };
//! let camera = scene.default_camera(1.0);
//! let session = RenderSession::new(Job { scene, camera, settings, window: None, aovs: false }, None).map_err(|e| e.to_string())?;
//! let image = session.wait_until_done();
//! println!("{} spp, {:.2} Msamples/s", image.spp, image.samples_per_second() / 1e6);
//! # Ok::<(), String>(())
//! ```

pub mod bsdf;
pub mod cli;
pub mod config;
pub mod film;
pub mod guard;
pub mod integrator;
pub mod loader;
pub mod math;
pub mod medium;
pub mod memory;
pub mod open;
pub mod params;
pub mod render;
pub mod scene;
pub mod spectrum;
pub mod viewer;

pub use open::open;

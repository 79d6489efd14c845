//! The library in a few lines: open a scene (a glTF file given as the first argument, or
//! the built-in Cornell box), render N samples per pixel (the second argument, default 16)
//! and write a linear EXR (the third, default render.exr).
//!
//!     cargo run --release --example render -- [SCENE.gltf] [SPP] [OUT.exr]

use lucent::film::{output::write_image, tonemap::Display};
use lucent::integrator::Settings;
use lucent::open::OpenOptions;
use lucent::render::{Job, RenderSession};
use std::path::PathBuf;
use std::sync::Arc;

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let scene = args.next().filter(|a| !a.is_empty()).map(PathBuf::from);
    let spp = args.next().map_or(Ok(16), |a| a.parse().map_err(|_| format!("not a sample count: {a}")))?;
    let out = args.next().map_or_else(|| PathBuf::from("render.exr"), PathBuf::from);

    let scene = Arc::new(lucent::open(scene.as_deref(), &OpenOptions::default(), &mut |stage| eprintln!("{stage:?}"))?);
    let settings = Settings { width: 256, height: 256, target_spp: Some(spp), ..Settings::default() };
    let camera = scene.default_camera(1.0);
    let session = RenderSession::new(Job { scene, camera, settings, window: None, aovs: false }, None)
        .map_err(|e| e.to_string())?;
    let image = session.wait_until_done();
    write_image(&out, image.width, image.height, &image.mean, &Display::default()).map_err(|e| e.to_string())?;
    println!("{} spp at {:.2} Msamples/s: wrote {}", image.spp, image.samples_per_second() / 1e6, out.display());
    Ok(())
}

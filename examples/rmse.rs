//! Root-mean-square error of images against a reference, over all pixels and apart from a
//! window (the Cornell light's edges, where pixel-area sampling's error gathers):
//! `cargo run --release --example rmse -- REF.exr [--window X0,Y0,X1,Y1] IMAGE.exr...`.
//! The error-at-equal-time figures of docs/performance.md come from it.

use std::process::ExitCode;

fn load(path: &str) -> Result<image::Rgb32FImage, String> {
    Ok(image::open(path).map_err(|e| format!("{path}: {e}"))?.to_rgb32f())
}

fn run() -> Result<(), String> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut window = None;
    if let Some(i) = args.iter().position(|a| a == "--window") {
        let spec = args.get(i + 1).ok_or("--window needs X0,Y0,X1,Y1")?.clone();
        let v: Vec<u32> =
            spec.split(',').map(str::parse).collect::<Result<_, _>>().map_err(|e| format!("--window: {e}"))?;
        let [x0, y0, x1, y1] = v[..] else { return Err("--window needs four numbers X0,Y0,X1,Y1".into()) };
        window = Some((x0, y0, x1, y1));
        args.drain(i..i + 2);
    }
    let (reference, images) = args.split_first().ok_or("usage: rmse REF.exr [--window X0,Y0,X1,Y1] IMAGE.exr...")?;
    let reference = load(reference)?;
    let inside = |x: u32, y: u32| window.is_some_and(|(x0, y0, x1, y1)| x >= x0 && x < x1 && y >= y0 && y < y1);
    for path in images {
        let image = load(path)?;
        if image.dimensions() != reference.dimensions() {
            return Err(format!("{path}: {:?} pixels, the reference {:?}", image.dimensions(), reference.dimensions()));
        }
        let (mut all, mut window_sum, mut outside_count) = (0.0f64, 0.0f64, 0u64);
        for (x, y, p) in image.enumerate_pixels() {
            let r = reference.get_pixel(x, y);
            let e: f64 = (0..3).map(|c| (p[c] as f64 - r[c] as f64).powi(2)).sum::<f64>() / 3.0;
            all += e;
            if inside(x, y) {
                window_sum += e;
            } else {
                outside_count += 1;
            }
        }
        let n = (image.width() * image.height()) as f64;
        let outside = ((all - window_sum) / outside_count.max(1) as f64).sqrt();
        match window {
            Some(_) => println!(
                "{path}: RMSE {:.5}, window's share of the squared error {:.3}, RMSE outside it {outside:.5}",
                (all / n).sqrt(),
                window_sum / all
            ),
            None => println!("{path}: RMSE {:.5}", (all / n).sqrt()),
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("rmse: {e}");
            ExitCode::FAILURE
        }
    }
}

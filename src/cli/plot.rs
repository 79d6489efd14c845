//! The convergence plot: RMSE against time on log-log axes, one line per strategy, as PNG
//! and SVG (plotters, with egui's bundled Ubuntu font so no system font is needed).

use super::args::StrategyName;
use super::convergence::Row;
use crate::film::output::replace_file;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

const SIZE: (u32, u32) = (900, 600);

/// Writes `<stem>.png` and `<stem>.svg`.
pub fn error_against_time(rows: &[Row], strategies: &[StrategyName], stem: &Path, title: &str) -> Result<(), String> {
    static FONT: Once = Once::new();
    FONT.call_once(|| {
        // The bytes are a valid TrueType font shipped with egui; failure would only drop text.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT);
    });
    let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let area = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        draw(&area, rows, strategies, title)?;
        area.present().map_err(|e| e.to_string())?;
    }
    let png = stem.with_extension("png");
    replace_file(&png, |tmp| {
        image::RgbImage::from_raw(SIZE.0, SIZE.1, rgb)
            .expect("buffer matches size")
            .save_with_format(tmp, image::ImageFormat::Png)
    })
    .map_err(|e| e.to_string())?;
    let mut svg = String::new();
    {
        let area = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        draw(&area, rows, strategies, title)?;
        area.present().map_err(|e| e.to_string())?;
    }
    replace_file(&stem.with_extension("svg"), |tmp| std::fs::write(tmp, &svg)).map_err(|e| e.to_string())
}

fn draw<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    rows: &[Row],
    strategies: &[StrategyName],
    title: &str,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    area.fill(&WHITE).map_err(err)?;
    let positive = rows.iter().filter(|r| r.seconds > 0.0 && r.rmse > 0.0);
    let (t0, t1, e0, e1) = positive.fold((f64::MAX, 0.0f64, f64::MAX, 0.0f64), |(a, b, c, d), r| {
        (a.min(r.seconds), b.max(r.seconds), c.min(r.rmse), d.max(r.rmse))
    });
    if t1 <= 0.0 {
        return Err("no wave to plot".into());
    }
    let mut chart = ChartBuilder::on(area)
        .caption(format!("{title}: RMSE against render time"), ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d((t0 * 0.8..t1 * 1.25).log_scale(), (e0 * 0.8..e1 * 1.25).log_scale())
        .map_err(err)?;
    chart.configure_mesh().x_desc("seconds").y_desc("RMSE").label_style(("sans-serif", 14)).draw().map_err(err)?;
    for (k, &s) in strategies.iter().enumerate() {
        let name = s.name();
        let points: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.strategy == name && r.seconds > 0.0 && r.rmse > 0.0)
            .map(|r| (r.seconds, r.rmse))
            .collect();
        let color = Palette99::pick(k).to_rgba();
        let style = if s.unbiased() { color.stroke_width(2) } else { color.stroke_width(1) };
        let label = if s.unbiased() { name } else { format!("{name} (biased)") };
        chart
            .draw_series(LineSeries::new(points.iter().copied(), style))
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
        chart.draw_series(points.iter().map(|&p| Circle::new(p, 2, color.filled()))).map_err(err)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .position(SeriesLabelPosition::LowerLeft)
        .draw()
        .map_err(err)?;
    Ok(())
}

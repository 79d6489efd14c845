//! The look-dev tools of the left panel: progress towards a target, the pinned probes'
//! live values, before/after comparison, and the luminance histogram with auto-exposure.

use super::UiState;
use super::inspect::describe;
use crate::film::tonemap::DISPLAY;
use crate::render::Snapshot;
use crate::viewer::compare::{CompareMode, difference_colour, size_mismatch};
use crate::viewer::histogram::{BINS, Histogram, PER_STOP, auto_exposure, clip_points};
use crate::viewer::progress::{TargetKind, format_seconds};
use crate::viewer::state::ViewerState;
use egui::{Color32, Rect, Sense, Ui, vec2};
use egui_plot::{Bar, BarChart, Plot, VLine};
use std::sync::Arc;

/// The histogram last drawn, and what it was computed from: (generation, spp, exposure bits).
#[derive(Default)]
pub struct ToolsUi {
    histogram: Option<((u64, u32, u32), Histogram)>,
}

impl ToolsUi {
    /// The histogram of `snap` at `exposure`, computed once per image and exposure.
    fn histogram(&mut self, snap: &Snapshot, exposure: f32) -> &Histogram {
        let key = (snap.generation, snap.spp, exposure.to_bits());
        if self.histogram.as_ref().is_none_or(|(k, _)| *k != key) {
            self.histogram = Some((key, Histogram::of(&snap.mean, exposure)));
        }
        &self.histogram.as_ref().expect("just computed").1
    }
}

/// The target picker and a progress bar with the time left.
pub(super) fn progress(ui: &mut Ui, state: &mut ViewerState) {
    ui.horizontal_wrapped(|ui| {
        ui.label("target");
        let kinds = [(TargetKind::Spp, "spp"), (TargetKind::Time, "time"), (TargetKind::Error, "error")];
        for (kind, name) in kinds {
            ui.selectable_value(&mut state.target.kind, kind, name);
        }
        match state.target.kind {
            TargetKind::Spp => {
                let text =
                    state.settings.target_spp.map_or("off (stop at spp, under Estimator)".into(), |n| format!("{n}"));
                ui.label(text);
            }
            TargetKind::Time => {
                ui.add(egui::DragValue::new(&mut state.target.seconds).range(0.1..=1e6).speed(1.0).suffix(" s"));
            }
            TargetKind::Error => {
                let mut percent = 100.0 * state.target.error;
                if ui.add(egui::DragValue::new(&mut percent).range(0.01..=100.0).speed(0.05).suffix(" %")).changed() {
                    state.target.error = percent / 100.0;
                }
            }
        }
    });
    if let Some(p) = state.progress() {
        let text = match (p.reached, p.remaining) {
            (true, _) => "reached: stopped".to_string(),
            (false, Some(t)) => format!("{:.0}%, about {} left", 100.0 * p.fraction, format_seconds(t)),
            (false, None) => format!("{:.0}%", 100.0 * p.fraction),
        };
        ui.add(egui::ProgressBar::new(p.fraction as f32).text(text));
    }
}

/// The probes' live values, each removable.
pub(super) fn probes(ui: &mut Ui, state: &mut ViewerState, ui_state: &UiState) {
    ui.label("hover the image for a pixel's values; Ctrl+click pins a probe");
    let Some(snap) = ui_state.shown.as_deref() else { return };
    let mut remove = None;
    for (k, values) in state.probes.values(snap).iter().enumerate() {
        ui.horizontal_wrapped(|ui| {
            if ui.small_button("x").on_hover_text("remove this probe").clicked() {
                remove = Some(k);
            }
            ui.monospace(format!("{}: {}", k + 1, values.as_ref().map_or("-".into(), describe)));
        });
    }
    if let Some(k) = remove {
        state.probes.remove(k);
    }
    if !state.probes.positions().is_empty() && ui.button("clear probes").clicked() {
        state.probes.clear();
    }
}

/// Pin, unpin, how the pinned and live images are shown, and the difference's legend.
pub(super) fn compare(ui: &mut Ui, state: &mut ViewerState, ui_state: &UiState) {
    ui.horizontal(|ui| {
        if ui.button("Pin image").on_hover_text("keep the current image to compare later ones with").clicked()
            && let Err(e) = state.pin_image()
        {
            state.error = Some(e);
        }
        if state.compare.pin().is_some()
            && ui.button("Unpin").clicked()
            && let Err(e) = state.unpin()
        {
            state.error = Some(e);
        }
    });
    let Some(pin) = state.compare.pin() else {
        ui.label("nothing pinned");
        return;
    };
    ui.label(format!("pinned: {}", pin.describe()));
    if let Some(file) = &state.compare.file {
        ui.label(format!("in {}", file.display()));
    }
    let size = (pin.width, pin.height);
    let view = &mut state.compare.view;
    ui.horizontal(|ui| {
        for (mode, name) in [
            (CompareMode::Live, "live"),
            (CompareMode::Split, "split"),
            (CompareMode::Pinned, "pinned"),
            (CompareMode::Difference, "difference"),
        ] {
            ui.selectable_value(&mut view.mode, mode, name);
        }
    });
    ui.label("hold Space to flip to the pinned image");
    match view.mode {
        CompareMode::Split => {
            let slider = ui.add(egui::Slider::new(&mut view.split, 0.0..=1.0).text("divider"));
            if slider.on_hover_text("or drag it on the image; it follows the selection until moved").changed() {
                state.compare.divider_moved = true;
            }
        }
        CompareMode::Difference => {
            ui.add(egui::Slider::new(&mut view.stops, 0.05..=8.0).logarithmic(true).text("stops at full colour"));
            legend(ui, view.stops);
        }
        _ => {}
    }
    let live = ui_state.shown.as_deref().map(|s| (s.width, s.height));
    if let Some(note) = live
        .filter(|_| !state.previewing())
        .and_then(|(w, h)| size_mismatch(state.compare.pin().expect("pinned"), w, h))
    {
        ui.colored_label(Color32::LIGHT_RED, note);
        if ui.button(format!("render at {}x{}", size.0, size.1)).clicked() {
            state.fixed_size = true;
            (state.settings.width, state.settings.height) = size;
        }
    }
}

/// The difference view's colours from `-stops` to `+stops`.
fn legend(ui: &mut Ui, stops: f32) {
    ui.horizontal(|ui| {
        ui.label(format!("-{stops:.2}"));
        let (rect, _) = ui.allocate_exact_size(vec2(160.0, 12.0), Sense::hover());
        let steps = 64;
        for i in 0..steps {
            let t = (i as f32 + 0.5) / steps as f32 * 2.0 - 1.0;
            let [r, g, b, _] = difference_colour(t * stops, stops);
            let x = rect.min.x + rect.width() * i as f32 / steps as f32;
            let cell =
                Rect::from_min_size(egui::pos2(x, rect.min.y), vec2(rect.width() / steps as f32 + 0.5, rect.height()));
            ui.painter().rect_filled(cell, 0.0, Color32::from_rgb(r, g, b));
        }
        ui.label(format!("+{stops:.2} stops"));
    });
    ui.label("live luminance against pinned: blue darker, black alike, orange brighter");
}

/// The exposure and tone curve, the histogram of displayed luminance with the curve's
/// clipping points, and auto-exposure.
pub(super) fn display(ui: &mut Ui, state: &mut ViewerState, ui_state: &mut UiState) {
    for p in DISPLAY {
        super::param_widget(ui, p, &mut state.display);
    }
    let Some(snap) = ui_state.shown.clone() else { return };
    histogram(ui, state, ui_state, &snap);
    let auto = &mut state.auto_exposure;
    ui.horizontal(|ui| {
        let button = ui.button("auto exposure").on_hover_text("set the exposure from the image (display only)");
        ui.add(egui::DragValue::new(&mut auto.percentile).range(0.1..=100.0).speed(0.5).suffix(" %ile"));
        ui.label("to grey");
        ui.add(egui::DragValue::new(&mut auto.grey).range(0.01..=1.0).speed(0.005));
        if button.clicked()
            && let Some(ev) = auto_exposure(&snap.mean, auto.percentile, auto.grey)
        {
            state.display.exposure = ev;
        }
    });
    ui.checkbox(&mut state.auto_exposure.continuous, "keep adjusting with every image");
}

/// A log2 histogram of the displayed luminance (after exposure, before the tone curve),
/// the black and white clipping points of the tone curve marked.
fn histogram(ui: &mut Ui, state: &ViewerState, ui_state: &mut UiState, snap: &Arc<Snapshot>) {
    let hist = ui_state.tools.histogram(snap, state.display.exposure);
    let width = 1.0 / PER_STOP as f64;
    // The first bin also holds black: it is counted in words, not drawn, so that a black
    // background does not flatten the rest.
    let bars: Vec<Bar> = (1..BINS)
        .map(|i| Bar::new(Histogram::start(i) as f64 + 0.5 * width, hist.counts[i] as f64).width(width))
        .collect();
    let (black, white) = clip_points(state.display.tonemap);
    Plot::new("histogram")
        .height(70.0)
        .show_y(false)
        .show_axes([true, false])
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .allow_boxed_zoom(false)
        .x_axis_label("stops (log2 luminance after exposure)")
        .show(ui, |plot| {
            plot.bar_chart(BarChart::new("pixels", bars).color(Color32::LIGHT_GRAY));
            if let Some(b) = black {
                plot.vline(VLine::new("black clip", b).color(Color32::LIGHT_BLUE));
            }
            if let Some(w) = white {
                plot.vline(VLine::new("white clip", w).color(Color32::from_rgb(255, 150, 40)));
            }
        });
    let total = snap.mean.len().max(1) as f64;
    let over = white
        .map_or(0, |w| (0..BINS).filter(|&i| Histogram::start(i) >= w).map(|i| hist.counts[i] as u64).sum::<u64>());
    ui.label(format!(
        "{:.1}% black or darker than the plot, {:.1}% at or past white",
        100.0 * hist.counts[0] as f64 / total,
        100.0 * over as f64 / total
    ));
}

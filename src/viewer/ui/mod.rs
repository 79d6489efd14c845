//! The egui panels: status (always in view) and render controls on the left, the
//! selection's material and the lights on the right, the converging image in the middle
//! with camera controls.

mod editors;
mod image;
mod inspect;
#[cfg(test)]
mod tests;
mod tools;
mod widgets;

use super::state::{ImageView, ViewerState};
use crate::film::false_colour;
use crate::integrator::settings::DRT_RAY_BUDGET;
use crate::integrator::{Integrator, Settings};
use crate::params::Group;
use crate::render::Snapshot;
use crate::scene::environment::BUILT_IN;
use egui::{Color32, Key, Modifiers, Ui};
use egui_plot::{GridMark, Legend, Line, Plot, log_grid_spacer};
use std::time::Instant;
pub(super) use widgets::param_widget;
use widgets::{colour_and_amount, legend};

/// What the firefly clamp trades, in one line beside it (the hover text says more).
const CLAMP_TRADE: &str = "bias for less noise: dims glass caustics";

/// UI-only state that does not affect the image.
pub struct UiState {
    /// The displayed image.
    pub texture: Option<egui::TextureHandle>,
    /// The snapshot shown.
    pub shown: Option<std::sync::Arc<Snapshot>>,
    /// Smoothed UI frame time in milliseconds.
    pub frame_ms: f32,
    /// The user asked to quit (Ctrl+Q).
    pub quit: bool,
    /// Cached figures of the look-dev tools.
    pub tools: tools::ToolsUi,
    last_input: Option<Instant>,
    /// The primary button was pressed on the split's divider and is still down: the drag
    /// moves the divider, not the camera.
    divider_held: bool,
}

impl UiState {
    /// Empty UI state.
    pub fn new() -> Self {
        Self {
            texture: None,
            shown: None,
            frame_ms: 0.0,
            quit: false,
            tools: tools::ToolsUi::default(),
            last_input: None,
            divider_held: false,
        }
    }
}

/// Draws one frame of UI and applies what the user did to `state`.
pub fn draw(ui: &mut Ui, state: &mut ViewerState, ui_state: &mut UiState) {
    // Key presses are taken from this frame's events with the modifiers each was pressed
    // with: a Ctrl+Q pressed and released within one slow frame is not missed, as it was
    // when the modifiers were read as held at the end of the frame.
    ui_state.quit |= ui.input_mut(|i| i.consume_key(Modifiers::COMMAND, Key::Q));
    if ui.input_mut(|i| i.consume_key(Modifiers::NONE, Key::F12)) {
        screenshot(state);
    }
    // The panel's width changes only when the user drags its edge: content wraps or is
    // cut, and the scroll bar floats over it, so the image (and its resolution) stays put.
    // The status and the target stay above the scrolled controls, always in view.
    egui::Panel::left("controls").resizable(true).default_size(330.0).size_range(260.0..=520.0).show(ui, |ui| {
        header(ui, state, ui_state);
        ui.separator();
        egui::ScrollArea::vertical().auto_shrink([false; 2]).show(ui, |ui| controls(ui, state, ui_state));
    });
    egui::Panel::right("editors").resizable(true).default_size(350.0).size_range(220.0..=560.0).show(ui, |ui| {
        egui::ScrollArea::vertical().auto_shrink(false).show(ui, |ui| editors::editors(ui, state));
    });
    egui::CentralPanel::no_frame().show(ui, |ui| image::image(ui, state, ui_state));
    notices(ui, state);
}

/// The last error and the last message, over the bottom of the image (wherever the
/// panels are scrolled), each until dismissed.
fn notices(ui: &mut Ui, state: &mut ViewerState) {
    if state.error.is_none() && state.message.is_none() {
        return;
    }
    egui::Area::new(egui::Id::unique("notices")).anchor(egui::Align2::CENTER_BOTTOM, [0.0, -12.0]).show(
        ui.ctx(),
        |ui| {
            egui::Frame::popup(ui.style()).show(ui, |ui| {
                ui.set_max_width(640.0);
                if let Some(e) = state.error.clone() {
                    ui.horizontal_wrapped(|ui| {
                        ui.colored_label(Color32::from_rgb(255, 90, 90), e);
                        if ui.small_button("dismiss").clicked() {
                            state.error = None;
                        }
                    });
                }
                if let Some(m) = state.message.clone() {
                    ui.horizontal_wrapped(|ui| {
                        ui.label(m);
                        if ui.small_button("ok").clicked() {
                            state.message = None;
                        }
                    });
                }
            });
        },
    );
}

fn screenshot(state: &mut ViewerState) {
    match state.screenshot() {
        Ok(p) => state.message = Some(format!("saved {} and .exr", p.display())),
        Err(e) => state.error = Some(e),
    }
}

fn status(ui: &mut Ui, state: &ViewerState, ui_state: &UiState) {
    match &ui_state.shown {
        Some(s) => {
            ui.label(format!("{} spp, {:.1} s, {}x{}", s.spp, s.elapsed.as_secs_f64(), s.width, s.height));
            ui.label(format!(
                "{:.2} Msamples/s, {:.2} Mrays/s",
                s.samples_per_second() / 1e6,
                s.rays_per_second() / 1e6
            ));
            let noise = s.relative_error().map_or("-".into(), |e| format!("{:.2}%", 100.0 * e));
            let noise = ui.label(format!(
                "noise (rel. std. error) {noise}{}, NaN/Inf dropped {}",
                if s.estimate.honest() { "" } else { " (overstated)" },
                s.rejected
            ));
            if !s.estimate.honest() {
                noise.on_hover_text(
                    "Sobol's stratified samples are better than their spread; a noise threshold estimates it honestly",
                );
            }
            if !s.pixel_spp.is_empty() {
                let (low, high) = false_colour::spp_range(&s.pixel_spp, s.spp);
                ui.label(format!(
                    "{:.1}% of pixels still sampling; mean {:.1} spp ({low} to {high})",
                    100.0 * s.active_share(),
                    s.mean_spp()
                ));
            }
            let causes = crate::integrator::nan::report();
            if !causes.is_empty() {
                ui.colored_label(egui::Color32::LIGHT_RED, format!("non-finite values by cause: {causes}"));
            }
        }
        None => {
            ui.label("first pass...");
        }
    }
    ui.label(format!("simulating {}", crate::integrator::simulated_effects(&state.scene, &state.settings)));
    let latency = state.latencies.last().map_or("-".into(), |d| format!("{:.0} ms", d.0.as_secs_f64() * 1e3));
    ui.label(format!("UI frame {:.1} ms, restart to image {latency}", ui_state.frame_ms));
}

/// The top of the left panel, never scrolled away: the scene, the status, the target and
/// its progress, pause and screenshot.
fn header(ui: &mut Ui, state: &mut ViewerState, ui_state: &UiState) {
    ui.heading(format!("Lucent: {}", state.scene.name));
    status(ui, state, ui_state);
    tools::progress(ui, state);
    ui.horizontal(|ui| {
        let label = if state.paused { "Resume" } else { "Pause" };
        if ui.button(label).clicked() {
            state.paused = !state.paused;
        }
        if ui.button("Screenshot (F12)").clicked() {
            screenshot(state);
        }
    });
}

fn controls(ui: &mut Ui, state: &mut ViewerState, ui_state: &mut UiState) {
    egui::CollapsingHeader::new("Estimator").default_open(true).show(ui, |ui| estimator(ui, state));
    egui::CollapsingHeader::new("Display").default_open(true).show(ui, |ui| {
        tools::display(ui, state, ui_state);
        let denoise = egui::Checkbox::new(&mut state.denoiser.enabled, "denoise (Intel Open Image Denoise)");
        ui.add_enabled(crate::film::denoise::available().is_ok(), denoise)
            .on_hover_text("shows the denoised image of the latest snapshot; the accumulated image is untouched");
        ui.label(state.denoiser.status());
        ui.checkbox(&mut state.fixed_size, "fixed resolution");
        if state.fixed_size {
            for p in Settings::table().iter().filter(|p| p.group == Group::Image) {
                param_widget(ui, p, &mut state.settings);
            }
        }
    });
    egui::CollapsingHeader::new("Compare").default_open(true).show(ui, |ui| tools::compare(ui, state, ui_state));
    egui::CollapsingHeader::new("Inspect").default_open(true).show(ui, |ui| tools::probes(ui, state, ui_state));
    egui::CollapsingHeader::new("Convergence").default_open(true).show(ui, |ui| convergence(ui, state, ui_state));
    egui::CollapsingHeader::new("Camera").default_open(true).show(ui, |ui| camera(ui, state));
    egui::CollapsingHeader::new("Environment").default_open(true).show(ui, |ui| environment(ui, state));
    egui::CollapsingHeader::new("Files").default_open(true).show(ui, |ui| files(ui, state));
}

/// The render settings of the table's estimator and robustness groups, with the
/// distribution ray tracer's cost beside them.
fn estimator(ui: &mut Ui, state: &mut ViewerState) {
    let s = &mut state.settings;
    for p in Settings::table().iter().filter(|p| p.group == Group::Estimator) {
        param_widget(ui, p, s);
        if p.name == "clamp" {
            ui.label(egui::RichText::new(CLAMP_TRADE).small().weak()).on_hover_text(
                "the clamp removes the energy of bright paths (caustics through glass, small bright lights)                  above its value: less noise, a darker, biased image",
            );
        }
    }
    if s.integrator == Integrator::Path && state.scene.delta_lights_behind_glass() {
        ui.label("point, spot or sun light through glass: the caustics it casts need bdpt or vcm");
    }
    if s.integrator == Integrator::Distribution {
        let rays = s.rays_per_sample_bound();
        ui.label(format!("up to {rays:.3e} rays per sample (branching^depth, budget {DRT_RAY_BUDGET:.0e})"));
    }
    if let Some(e) = &state.settings_error {
        ui.colored_label(Color32::LIGHT_RED, e);
    }
    egui::CollapsingHeader::new("Robustness (switch off to see what it prevents)").show(ui, |ui| {
        for p in Settings::table().iter().filter(|p| p.group == Group::Robustness) {
            param_widget(ui, p, s);
        }
    });
}

/// The estimated error against time (log-log) of this job and the previous ones, the time
/// to a target error, the target error mode (the noise threshold), and the false-colour
/// views of per-pixel error and samples with their legends.
fn convergence(ui: &mut Ui, state: &mut ViewerState, ui_state: &mut UiState) {
    let log = &state.convergence;
    let to_log = |points: &[[f64; 2]]| points.iter().map(|p| [p[0].log10(), p[1].log10()]).collect::<Vec<_>>();
    let power_of_ten = |mark: GridMark, _: &std::ops::RangeInclusive<f64>| significant(10f64.powf(mark.value));
    Plot::new("convergence")
        .height(150.0)
        .legend(Legend::default())
        .x_axis_label("render time (s)")
        .y_axis_label("rel. error")
        .y_axis_min_width(44.0)
        .x_axis_formatter(power_of_ten)
        .y_axis_formatter(power_of_ten)
        .x_grid_spacer(log_grid_spacer(10))
        .y_grid_spacer(log_grid_spacer(10))
        .allow_scroll(false)
        .show(ui, |plot| {
            for c in &log.previous {
                plot.line(Line::new(format!("#{} {}", c.number, c.label), to_log(&c.points)).width(1.0));
            }
            if let Some(c) = &log.current {
                plot.line(Line::new(format!("#{} {} (now)", c.number, c.label), to_log(&c.points)).width(2.5));
            }
        });
    // The target error (shared with the progress target); in target error mode it is the
    // noise threshold itself.
    let threshold = state.settings.noise_threshold;
    let shown = threshold.map_or(100.0 * state.target.error, |t| 100.0 * t as f64);
    let mut percent = shown;
    ui.horizontal(|ui| {
        ui.label("target error");
        ui.add(egui::DragValue::new(&mut percent).range(0.01..=100.0).speed(0.05).suffix(" %"));
    });
    ui.label(match log.time_to(percent / 100.0) {
        Some(0.0) => "reached".to_string(),
        Some(t) => format!("about {t:.0} s more at this rate (error ~ time^-1/2)"),
        None => "-".to_string(),
    });
    let table = Settings::table();
    let mut stop = threshold.is_some();
    if let Some(p) = table.iter().find(|p| p.name == "noise-threshold") {
        ui.checkbox(&mut stop, "stop pixels at the target (noise threshold)").on_hover_text(p.help);
    }
    state.target.error = percent / 100.0;
    if stop != threshold.is_some() || percent != shown {
        state.settings.noise_threshold = stop.then_some((percent / 100.0) as f32);
    }
    for p in table.iter().filter(|p| p.group == Group::Convergence && p.name != "noise-threshold") {
        param_widget(ui, p, &mut state.settings);
    }
    ui.horizontal_wrapped(|ui| {
        ui.label("show");
        ui.radio_value(&mut state.view, ImageView::Image, "image");
        ui.radio_value(&mut state.view, ImageView::Error, "per-pixel error");
        ui.radio_value(&mut state.view, ImageView::Spp, "samples per pixel");
    });
    let percent = |v: f32| format!("{}%", 100.0 * v);
    match (state.view, &ui_state.shown) {
        (ImageView::Error, _) => {
            let (low, high) = false_colour::ERROR_RANGE;
            legend(ui, false_colour::error_scale, [percent(low), percent((low * high).sqrt()), percent(high)]);
            ui.label("relative standard error of luminance, log scale");
        }
        (ImageView::Spp, Some(s)) => {
            let (low, high) = false_colour::spp_range(&s.pixel_spp, s.spp);
            let mid = ((low.max(1) as f64) * (high.max(1) as f64)).sqrt().round();
            legend(ui, false_colour::spp_scale, [low.to_string(), mid.to_string(), high.to_string()]);
            ui.label("samples per pixel, log scale");
        }
        _ => {}
    }
}

/// A tick value with three significant digits and no trailing zeros ("0.025", "10", "1.5").
fn significant(v: f64) -> String {
    let decimals = (2 - v.abs().log10().floor() as i32).clamp(0, 6) as usize;
    let text = format!("{v:.decimals$}");
    if text.contains('.') { text.trim_end_matches('0').trim_end_matches('.').to_string() } else { text }
}

fn camera(ui: &mut Ui, state: &mut ViewerState) {
    let mut fov = state.camera.yfov.to_degrees();
    if ui.add(egui::Slider::new(&mut fov, 5.0..=150.0).text("vertical fov")).changed() {
        state.camera.yfov = fov.to_radians();
    }
    let radius = state.scene.radius().max(1e-3);
    ui.add(egui::Slider::new(&mut state.fly_speed, radius * 1e-3..=radius * 4.0).logarithmic(true).text("fly speed"));
    ui.label("drag: orbit, shift/middle drag: pan, wheel: dolly, right drag: look, WASD/QE: fly, click: select, Ctrl+click: probe, Space: flip to the pinned image, Ctrl+Q: quit");
    ui.horizontal(|ui| {
        if ui.button("Reset").clicked() {
            state.reset_camera(if state.scene.cameras.is_empty() { None } else { Some(0) });
        }
        if ui.button("Frame scene").clicked() {
            state.reset_camera(None);
        }
    });
    let names: Vec<String> = state.scene.cameras.iter().map(|(n, _)| n.clone()).collect();
    if !names.is_empty() {
        egui::ComboBox::from_label("file cameras").selected_text("choose").show_ui(ui, |ui| {
            // Each camera with what it frames: the materials covering most of its view.
            let subjects = state.camera_subjects();
            for (i, (n, subject)) in names.iter().zip(subjects).enumerate() {
                if ui.selectable_label(false, format!("{n}: {subject}")).clicked() {
                    state.reset_camera(Some(i));
                }
            }
        });
    }
}

fn environment(ui: &mut Ui, state: &mut ViewerState) {
    let mut env = state.environment.clone();
    let name = |p: &std::path::Path| match p.file_name() {
        _ if p == std::path::Path::new(BUILT_IN) => "built-in: Venice sunset".into(),
        Some(n) => n.to_string_lossy().into_owned(),
        None => p.display().to_string(),
    };
    if state.lit_by_default() {
        ui.label("The scene has no light of its own, so the built-in sky lights it. Choose \"none\" for darkness.");
    }
    let shown = env.map.as_deref().map_or("none (uniform background)".into(), name);
    egui::ComboBox::from_label("map").selected_text(shown).show_ui(ui, |ui| {
        ui.selectable_value(&mut env.map, None, "none (uniform background)");
        for path in &state.environment_maps {
            ui.selectable_value(&mut env.map, Some(path.clone()), name(path)).on_hover_text(path.display().to_string());
        }
    });
    let mut dir = state.environment_dir().to_owned();
    ui.label("folder of maps (its .hdr and .exr files are offered in the list)");
    ui.add(egui::TextEdit::singleline(&mut dir).desired_width(f32::INFINITY));
    state.set_environment_dir(dir);
    if env.map.is_none() {
        ui.label("background: colour x radiance (0: black)");
        if let Some(b) = colour_and_amount(ui, env.background, "radiance", 0.0..=100.0) {
            env.background = b;
        }
    }
    ui.add(egui::Slider::new(&mut env.intensity, 0.0..=100.0).logarithmic(true).text("intensity"));
    ui.add(egui::Slider::new(&mut env.rotation, -180.0..=180.0).suffix("°").text("rotation"));
    if let Err(e) = state.set_environment(env) {
        state.error = Some(e);
    }
}

fn files(ui: &mut Ui, state: &mut ViewerState) {
    ui.label("open a .gltf/.glb (or drop it on the window)");
    ui.add(egui::TextEdit::singleline(&mut state.open_path).desired_width(f32::INFINITY));
    if ui.button("Open").clicked() && !state.open_path.trim().is_empty() {
        let path = state.open_path.trim().into();
        state.open(path);
    }
    if let Some(status) = state.loading_status() {
        ui.horizontal(|ui| {
            ui.spinner();
            ui.label("loading");
        });
        ui.label(status);
    }
    if !state.scene.variants.is_empty() {
        let mut chosen = state.variant.clone();
        egui::ComboBox::from_label("material variant")
            .selected_text(chosen.as_deref().unwrap_or("default materials"))
            .show_ui(ui, |ui| {
                ui.selectable_value(&mut chosen, None, "default materials");
                for v in &state.scene.variants {
                    ui.selectable_value(&mut chosen, Some(v.clone()), v);
                }
            })
            .response
            .on_hover_text("KHR_materials_variants: reopens the file with this variant's materials");
        if chosen != state.variant && state.loading_status().is_none() {
            state.open_variant(chosen);
        }
    }
    ui.label("screenshots (F12) go to this folder:");
    ui.add(egui::TextEdit::singleline(&mut state.screenshot_dir).desired_width(f32::INFINITY));
    ui.label("view file (camera + settings)");
    ui.add(egui::TextEdit::singleline(&mut state.view_path).desired_width(f32::INFINITY));
    ui.horizontal(|ui| {
        if ui.button("Save").clicked() {
            match state.save_view() {
                Ok(()) => state.message = Some(format!("saved {}", state.view_path)),
                Err(e) => state.error = Some(e),
            }
        }
        if ui.button("Load").clicked()
            && let Err(e) = state.load_view()
        {
            state.error = Some(e);
        }
    });
}

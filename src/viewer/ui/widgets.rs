//! Widgets shared by the panels: one per parameter-table entry, colour-with-magnitude, and
//! the legend of a false-colour scale.

use crate::params::{Domain, Param, Value};
use egui::Ui;
use glam::Vec3;

/// The widget of one table parameter, shown only where the parameter applies: a checkbox,
/// a slider for short ranges, a drag value for long ones, a menu for choices; optional
/// parameters get a checkbox that sets or unsets them, their value beside it greyed out
/// while unset, so that ticking it does not move what follows.
pub(in crate::viewer) fn param_widget<T>(ui: &mut Ui, p: &Param<T>, target: &mut T) {
    if !(p.shown)(target) {
        return;
    }
    let value = (p.get)(target);
    let new = match (p.domain, value) {
        (Domain::Switch, Value::Bool(mut on)) => {
            ui.checkbox(&mut on, p.label).on_hover_text(p.help);
            Value::Bool(on)
        }
        (Domain::Choice(options), Value::Choice(mut name)) => {
            egui::ComboBox::from_label(p.label).selected_text(name).show_ui(ui, |ui| {
                for c in options {
                    ui.selectable_value(&mut name, c.name, c.name).on_hover_text(c.help);
                }
            });
            Value::Choice(name)
        }
        (Domain::Int { min, max, optional }, v) => {
            ui.horizontal(|ui| {
                let mut set = v != Value::Unset;
                if optional {
                    ui.checkbox(&mut set, p.label).on_hover_text(p.help);
                }
                let mut i = if let Value::Int(i) = v { i } else { 256u64.clamp(min, max) };
                let widget = if max - min <= 64 {
                    let slider = egui::Slider::new(&mut i, min..=max).text(if optional { "" } else { p.label });
                    ui.add_enabled(set, slider)
                } else {
                    ui.add_enabled(set, egui::DragValue::new(&mut i).range(min..=max))
                };
                widget.on_hover_text(p.help);
                if !optional && max - min > 64 {
                    ui.label(p.label);
                }
                if set { Value::Int(i) } else { Value::Unset }
            })
            .inner
        }
        (Domain::Float { min, max, optional }, v) => {
            ui.horizontal(|ui| {
                let mut set = v != Value::Unset;
                if optional {
                    ui.checkbox(&mut set, p.label).on_hover_text(p.help);
                }
                let mut x = if let Value::Float(x) = v { x } else { 10.0f32.clamp(min, max) };
                if max - min <= 100.0 {
                    let slider = egui::Slider::new(&mut x, min..=max).text(if optional { "" } else { p.label });
                    ui.add_enabled(set, slider);
                } else {
                    ui.add_enabled(set, egui::DragValue::new(&mut x).range(min..=max).speed(0.1));
                }
                if set { Value::Float(x) } else { Value::Unset }
            })
            .inner
        }
        _ => value,
    };
    if new != value {
        (p.set)(target, new);
    }
}

/// A linear RGB colour: a swatch (shown in sRGB, clamped) that opens a hue, saturation and
/// value picker, and a drag value per linear channel in 0..=`max`. Edits only the copy it is
/// given and returns it only if a widget changed it, so a value that is merely shown is
/// never rewritten. egui's own colour picker is not used: its numeric row has a clipboard
/// button (U+1F4CB) that egui's default fonts, without the emoji fonts, draw as a box, and
/// it edits 8-bit sRGB.
pub(in crate::viewer) fn colour_edit(ui: &mut Ui, value: Vec3, max: f32) -> Option<Vec3> {
    let mut rgb = value;
    let mut changed = false;
    ui.horizontal(|ui| {
        let size = egui::vec2(ui.spacing().interact_size.y * 1.6, ui.spacing().interact_size.y);
        let (rect, swatch) = ui.allocate_exact_size(size, egui::Sense::click());
        let shown = rgb.clamp(Vec3::ZERO, Vec3::ONE);
        ui.painter().rect_filled(rect, 2.0, egui::Color32::from(egui::Rgba::from_rgb(shown.x, shown.y, shown.z)));
        ui.painter().rect_stroke(rect, 2.0, ui.visuals().widgets.inactive.fg_stroke, egui::StrokeKind::Inside);
        egui::Popup::menu(&swatch.on_hover_text("hue, saturation and value"))
            .close_behavior(egui::PopupCloseBehavior::CloseOnClickOutside)
            .show(|ui| changed |= hsv_picker(ui, &mut rgb, max));
        for (c, name) in ["red", "green", "blue"].iter().enumerate() {
            let channel = egui::DragValue::new(&mut rgb[c])
                .range(0.0..=max)
                .clamp_existing_to_range(false)
                .speed(0.002 * max.min(10.0))
                .max_decimals(3);
            changed |= ui.add(channel).on_hover_text(format!("{name}, linear")).changed();
        }
    });
    changed.then_some(rgb)
}

/// Hue, saturation and value (of the linear colour) as three sliders.
fn hsv_picker(ui: &mut Ui, rgb: &mut Vec3, max: f32) -> bool {
    let mut hsv = egui::ecolor::Hsva::from_rgb(rgb.to_array());
    let mut changed = ui.add(egui::Slider::new(&mut hsv.h, 0.0..=1.0).text("hue")).changed();
    changed |= ui.add(egui::Slider::new(&mut hsv.s, 0.0..=1.0).text("saturation")).changed();
    changed |= ui.add(egui::Slider::new(&mut hsv.v, 0.0..=max.min(100.0)).text("value")).changed();
    if changed {
        *rgb = Vec3::from(hsv.to_rgb()).clamp(Vec3::ZERO, Vec3::splat(max));
    }
    changed
}

/// A false-colour scale as a bar (`scale(t)` for t from 0 to 1) with its low, middle and
/// high values written under its ends and centre.
pub(super) fn legend(ui: &mut Ui, scale: fn(f64) -> [u8; 4], labels: [String; 3]) {
    let width = ui.available_width().min(260.0);
    let (rect, _) = ui.allocate_exact_size(egui::vec2(width, 14.0), egui::Sense::hover());
    const STEPS: usize = 64;
    for k in 0..STEPS {
        let [r, g, b, _] = scale((k as f64 + 0.5) / STEPS as f64);
        let x0 = rect.left() + rect.width() * k as f32 / STEPS as f32;
        let x1 = rect.left() + rect.width() * (k + 1) as f32 / STEPS as f32;
        let cell = egui::Rect::from_min_max(egui::pos2(x0, rect.top()), egui::pos2(x1 + 0.5, rect.bottom()));
        ui.painter().rect_filled(cell, 0.0, egui::Color32::from_rgb(r, g, b));
    }
    let (rect, _) = ui.allocate_exact_size(egui::vec2(width, 14.0), egui::Sense::hover());
    let font = egui::FontId::proportional(11.0);
    let colour = ui.visuals().text_color();
    let [low, mid, high] = labels;
    ui.painter().text(rect.left_top(), egui::Align2::LEFT_TOP, low, font.clone(), colour);
    ui.painter().text(rect.center_top(), egui::Align2::CENTER_TOP, mid, font.clone(), colour);
    ui.painter().text(rect.right_top(), egui::Align2::RIGHT_TOP, high, font, colour);
}

/// Colour and magnitude of an RGB quantity, edited separately; returns the new value only
/// if a widget changed (so values that do not round-trip exactly never trigger a restart).
pub(super) fn colour_and_amount(
    ui: &mut Ui,
    value: Vec3,
    label: &str,
    range: std::ops::RangeInclusive<f32>,
) -> Option<Vec3> {
    let peak = value.max_element();
    let colour = if peak > 0.0 { value / peak } else { Vec3::ONE };
    let mut amount = peak;
    let new_colour = colour_edit(ui, colour, 1.0);
    let amount_changed = ui.add(egui::Slider::new(&mut amount, range).logarithmic(true).text(label)).changed();
    (new_colour.is_some() || amount_changed).then(|| new_colour.unwrap_or(colour) * amount)
}

#[cfg(test)]
mod tests {
    use crate::scene::edit::{LIGHT_PARAMS, MATERIAL_PARAMS, Section};

    /// egui's colour picker shows a clipboard button (U+1F4CB) that its default fonts, without
    /// the emoji fonts, lack (drawn as a box): the editors avoid the picker, and their own
    /// labels use only glyphs the fonts have.
    #[test]
    fn the_editors_use_only_glyphs_the_default_fonts_have() {
        let ctx = egui::Context::default();
        let _ = ctx.run_ui(egui::RawInput::default(), |_| {});
        let font = egui::FontId::proportional(14.0);
        ctx.fonts_mut(|f| {
            assert!(!f.has_glyph(&font, '\u{1F4CB}'), "the picker's clipboard glyph is missing");
            let labels = MATERIAL_PARAMS.iter().map(|p| (p.name(), p.help));
            for (name, help) in labels.chain(LIGHT_PARAMS.iter().map(|p| (p.name(), p.help))) {
                assert!(f.has_glyphs(&font, &name) && f.has_glyphs(&font, help), "{name}: {help}");
            }
            for s in Section::MATERIAL.into_iter().chain([Section::Light]) {
                assert!(f.has_glyphs(&font, s.title()), "{}", s.title());
            }
            assert!(f.has_glyphs(&font, "x factor of texture ° cd lx"));
        });
    }
}

//! Widgets shared by the panels: one per parameter-table entry, and colour-with-magnitude.

use crate::params::{Domain, Param, Value};
use egui::Ui;
use glam::Vec3;

/// The widget of one table parameter, shown only where the parameter applies: a checkbox,
/// a slider for short ranges, a drag value for long ones, a menu for choices; optional
/// parameters get a checkbox that sets or unsets them.
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
                if set {
                    let widget = if max - min <= 64 {
                        ui.add(egui::Slider::new(&mut i, min..=max).text(if optional { "" } else { p.label }))
                    } else {
                        ui.add(egui::DragValue::new(&mut i).range(min..=max))
                    };
                    widget.on_hover_text(p.help);
                    if !optional && max - min > 64 {
                        ui.label(p.label);
                    }
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
                if set {
                    if max - min <= 100.0 {
                        ui.add(egui::Slider::new(&mut x, min..=max).text(if optional { "" } else { p.label }));
                    } else {
                        ui.add(egui::DragValue::new(&mut x).range(min..=max).speed(0.1));
                    }
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

/// Colour and magnitude of an RGB quantity, edited separately; returns the new value only
/// if a widget changed (so values that do not round-trip exactly never trigger a restart).
pub(super) fn colour_and_amount(
    ui: &mut Ui,
    value: Vec3,
    label: &str,
    range: std::ops::RangeInclusive<f32>,
) -> Option<Vec3> {
    let peak = value.max_element();
    let mut colour = if peak > 0.0 { (value / peak).to_array() } else { [1.0; 3] };
    let mut amount = peak;
    let mut changed = false;
    ui.horizontal(|ui| {
        changed |= ui.color_edit_button_rgb(&mut colour).changed();
        changed |= ui.add(egui::Slider::new(&mut amount, range).logarithmic(true).text(label)).changed();
    });
    changed.then(|| Vec3::from(colour) * amount)
}

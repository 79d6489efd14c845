//! The punctual lights: colour, intensity (candela, or lux for directional lights),
//! position, direction as yaw and pitch, and a spot's cone angles with inner < outer.

use super::super::widgets::colour_edit;
use crate::scene::light::{Cone, PunctualKind, PunctualLight};
use crate::viewer::state::ViewerState;
use egui::Ui;
use glam::Vec3;

/// Smallest gap kept between a spot's inner and outer cone angles (radians).
const CONE_GAP: f32 = 1e-3;

pub(super) fn lights(ui: &mut Ui, state: &mut ViewerState) {
    if state.scene.lights.is_empty() {
        return;
    }
    ui.separator();
    ui.heading("Lights (KHR_lights_punctual)");
    let step = 0.005 * state.scene.radius().max(1e-3);
    for i in 0..state.scene.lights.len() {
        let mut light = state.scene.lights[i].clone();
        let kind = match light.kind {
            PunctualKind::Point => "point",
            PunctualKind::Spot(_) => "spot",
            PunctualKind::Directional => "directional",
        };
        egui::CollapsingHeader::new(format!("{i}: {} ({kind})", light.name))
            .id_salt(("light", i))
            .default_open(state.scene.lights.len() <= 3)
            .show(ui, |ui| light_editor(ui, &mut light, step));
        if light != state.scene.lights[i] {
            state.edit(|_, lights| lights[i] = light);
        }
    }
}

fn light_editor(ui: &mut Ui, l: &mut PunctualLight, step: f32) {
    ui.horizontal(|ui| {
        if let Some(c) = colour_edit(ui, l.color, 1.0) {
            l.color = c;
        }
        ui.label("color");
    });
    let unit = if l.kind == PunctualKind::Directional { " lx" } else { " cd" };
    let mut intensity = l.intensity;
    let speed = (intensity * 0.01).max(0.01);
    ui.horizontal(|ui| {
        let drag = egui::DragValue::new(&mut intensity)
            .range(0.0..=f32::MAX)
            .clamp_existing_to_range(false)
            .speed(speed)
            .suffix(unit);
        if ui.add(drag).changed() {
            l.intensity = intensity;
        }
        ui.label("intensity").on_hover_text("glTF intensity: candela for point and spot lights, lux for directional");
    });
    if l.kind != PunctualKind::Directional {
        ui.horizontal(|ui| {
            for c in 0..3 {
                let mut x = l.position[c];
                if ui.add(egui::DragValue::new(&mut x).speed(step).prefix(["x ", "y ", "z "][c])).changed() {
                    l.position[c] = x;
                }
            }
            ui.label("position").on_hover_text("in the scene's coordinates (its node's translation when saved)");
        });
    }
    if l.kind != PunctualKind::Point {
        direction(ui, l);
    }
    if let PunctualKind::Spot(cone) = l.kind
        && let Some(cone) = cone_editor(ui, cone)
    {
        l.kind = PunctualKind::Spot(cone);
    }
}

/// The direction as yaw (about +y, from -z towards +x) and pitch (up from the horizon), in degrees.
fn direction(ui: &mut Ui, l: &mut PunctualLight) {
    let d = l.direction;
    let (mut yaw, mut pitch) = (d.x.atan2(-d.z).to_degrees() + 0.0, d.y.clamp(-1.0, 1.0).asin().to_degrees() + 0.0);
    ui.horizontal(|ui| {
        let yaw_changed = ui.add(egui::DragValue::new(&mut yaw).speed(0.5).suffix("°").prefix("yaw ")).changed();
        let pitch_drag = egui::DragValue::new(&mut pitch).range(-90.0..=90.0).speed(0.5).suffix("°").prefix("pitch ");
        let pitch_changed = ui.add(pitch_drag).changed();
        ui.label("direction").on_hover_text(format!("shines along ({:.4}, {:.4}, {:.4})", d.x, d.y, d.z));
        if yaw_changed || pitch_changed {
            let (yaw, pitch) = (yaw.to_radians(), pitch.to_radians());
            l.direction = Vec3::new(yaw.sin() * pitch.cos(), pitch.sin(), -yaw.cos() * pitch.cos()).normalize();
        }
    });
}

/// A spot's inner and outer cone angles in degrees, the inner kept below the outer.
fn cone_editor(ui: &mut Ui, cone: Cone) -> Option<Cone> {
    let (mut inner, mut outer) = (cone.inner().to_degrees(), cone.outer().to_degrees());
    let inner_changed = ui.add(egui::Slider::new(&mut inner, 0.0..=90.0).suffix("°").text("innerConeAngle")).changed();
    let outer_changed = ui.add(egui::Slider::new(&mut outer, 0.0..=90.0).suffix("°").text("outerConeAngle")).changed();
    if !(inner_changed || outer_changed) {
        return None;
    }
    let right = std::f32::consts::FRAC_PI_2;
    let (mut inner, mut outer) = (inner.to_radians(), outer.to_radians().clamp(CONE_GAP, right));
    if inner >= outer {
        if inner_changed {
            inner = outer - CONE_GAP;
        } else {
            outer = (inner + CONE_GAP).min(right);
            inner = inner.min(outer - CONE_GAP);
        }
    }
    Some(Cone::new(inner.max(0.0), outer))
}

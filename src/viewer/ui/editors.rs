//! The right panel: the selected material's parameters, its medium, and the lights.

use super::widgets::colour_and_amount;
use crate::medium::{Volume, phase::MAX_G};
use crate::viewer::state::ViewerState;
use egui::Ui;
use glam::Vec3;

/// The medium inside a volume, in glTF's terms: attenuation colour at a distance (the
/// extinction), multiscatter colour (the albedo) and the Henyey-Greenstein g. Values are
/// written back only when a widget changed, so an unedited volume never restarts the render.
fn volume_editor(ui: &mut Ui, v: &mut Volume) {
    ui.label("volume (KHR_materials_volume, _volume_scatter)");
    if v.grid.is_some() {
        grid_editor(ui, v);
        return;
    }
    let mut distance = 1.0 / v.sigma_t.max_element().max(1e-6);
    let mut attenuation = (-v.sigma_t * distance).exp().to_array();
    let mut multiscatter = Volume::multiscatter_colour(v.albedo).to_array();
    let mut g = v.g;
    let mut changed = false;
    ui.horizontal(|ui| {
        changed |= ui.color_edit_button_rgb(&mut attenuation).changed();
        ui.label("attenuation colour");
    });
    let range = 1e-4..=1e4;
    changed |= ui.add(egui::Slider::new(&mut distance, range).logarithmic(true).text("attenuation distance")).changed();
    ui.horizontal(|ui| {
        changed |= ui.color_edit_button_rgb(&mut multiscatter).changed();
        ui.label("multiscatter colour");
    });
    changed |= ui.add(egui::Slider::new(&mut g, -MAX_G..=MAX_G).text("anisotropy g")).changed();
    if changed {
        let attenuation = Vec3::from(attenuation).clamp(Vec3::splat(1e-6), Vec3::ONE);
        *v = Volume {
            sigma_t: -attenuation.map(f32::ln) / distance,
            albedo: Volume::single_scatter_albedo(Vec3::from(multiscatter)),
            g,
            ..*v
        };
    }
}

/// A density grid's medium (from `SCENE.media.toml`): its density scale (the grey
/// extinction where the grid's value is 1), albedo and g.
fn grid_editor(ui: &mut Ui, v: &mut Volume) {
    let mut density = v.sigma_t.x;
    let mut albedo = v.albedo.to_array();
    let mut g = v.g;
    let mut changed = false;
    changed |= ui.add(egui::Slider::new(&mut density, 0.0..=1e4).logarithmic(true).text("density scale")).changed();
    ui.horizontal(|ui| {
        changed |= ui.color_edit_button_rgb(&mut albedo).changed();
        ui.label("albedo");
    });
    changed |= ui.add(egui::Slider::new(&mut g, -MAX_G..=MAX_G).text("anisotropy g")).changed();
    if changed {
        *v = Volume {
            sigma_t: Vec3::splat(density.max(0.0)),
            albedo: Vec3::from(albedo).clamp(Vec3::ZERO, Vec3::ONE),
            g,
            ..*v
        };
    }
}

pub(super) fn editors(ui: &mut Ui, state: &mut ViewerState) {
    if let Some(index) = state.selected {
        let mut m = state.scene.materials[index as usize].clone();
        ui.heading(format!("Material: {}", m.name));
        if let Some(measured) = &m.measured {
            ui.label(format!("measured BRDF {} (replaces the parameters below)", measured.path.display()));
        }
        let mut base = m.base_color.to_array();
        ui.horizontal(|ui| {
            ui.color_edit_button_rgb(&mut base);
            ui.label("base colour");
        });
        m.base_color = Vec3::from(base);
        ui.add(egui::Slider::new(&mut m.metallic, 0.0..=1.0).text("metallic"));
        ui.add(egui::Slider::new(&mut m.roughness, 0.0..=1.0).text("roughness"));
        ui.add(egui::Slider::new(&mut m.specular, 0.0..=1.0).text("specular"));
        ui.add(egui::Slider::new(&mut m.ior, 1.0..=3.0).text("IOR"));
        if m.volume.is_some() && m.transmission > 0.0 {
            ui.add(egui::Slider::new(&mut m.dispersion, 0.0..=2.0).text("dispersion (20 / Abbe number)"));
        }
        if let Some(e) = colour_and_amount(ui, m.emissive, "emission", 0.0..=1000.0) {
            m.emissive = e;
        }
        if let Some(v) = &mut m.volume {
            volume_editor(ui, v);
        }
        state.edit(|materials, _| materials[index as usize] = m);
        if ui.button("Deselect").clicked() {
            state.selected = None;
        }
        ui.separator();
    }
    for i in 0..state.scene.lights.len() {
        let light = &state.scene.lights[i];
        ui.label(format!("Light: {} ({:?})", light.name, light.kind));
        if let Some(intensity) = colour_and_amount(ui, light.intensity, "intensity", 0.0..=1e6) {
            state.edit(|_, lights| lights[i].intensity = intensity);
        }
    }
    if state.edited() && ui.button("Reset to file").clicked() {
        state.reset_edits();
    }
}

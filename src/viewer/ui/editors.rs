//! The right panel: a list of the scene's materials, every parameter of the chosen one
//! grouped and named as glTF names them (`scene::edit::MATERIAL_PARAMS`), its medium, the
//! punctual lights, and saving the edited scene as glTF.

mod lights;

use super::widgets::colour_edit;
use crate::medium::{Volume, phase::MAX_G};
use crate::scene::edit::{Kind, MATERIAL_PARAMS, Param, ParamValue, Section};
use crate::scene::material::Material;
use crate::scene::texture::Texture;
use crate::viewer::state::ViewerState;
use egui::{Color32, Ui};
use glam::Vec3;

pub(super) fn editors(ui: &mut Ui, state: &mut ViewerState) {
    let area = ui.clip_rect();
    material_list(ui, state);
    if let Some(index) = state.selected {
        material(ui, state, index as usize);
    }
    lights::lights(ui, state);
    ui.separator();
    save(ui, state);
    // The selection's outline hides while the panel is in use, so that edits can be judged.
    let (hover, press, down) = ui.input(|i| (i.pointer.hover_pos(), i.pointer.press_origin(), i.pointer.any_down()));
    let in_use = hover.is_some_and(|p| area.contains(p)) || (down && press.is_some_and(|p| area.contains(p)));
    state.show_selection = !(in_use || egui::Popup::is_any_open(ui.ctx()));
}

/// Every material by index and name, to choose one without clicking in the image.
fn material_list(ui: &mut Ui, state: &mut ViewerState) {
    ui.heading("Materials");
    let name = |i: u32| format!("{i}: {}", state.scene.materials[i as usize].name);
    let shown = state.selected.map_or_else(|| "none (click the image or choose)".into(), name);
    let mut selected = state.selected;
    egui::ComboBox::from_id_salt("materials").selected_text(shown).width(ui.available_width() - 40.0).show_ui(
        ui,
        |ui| {
            ui.selectable_value(&mut selected, None, "none");
            for i in 0..state.scene.materials.len() as u32 {
                ui.selectable_value(&mut selected, Some(i), name(i));
            }
        },
    );
    state.selected = selected;
}

/// The parameters of material `index`, a section per glTF extension.
fn material(ui: &mut Ui, state: &mut ViewerState, index: usize) {
    let mut m = state.scene.materials[index].clone();
    let textures = state.scene.textures.clone();
    ui.label(match m.file_index {
        Some(i) => format!("materials[{i}] of the file"),
        None => "glTF's default material (saved as a new material)".into(),
    });
    if let Some(measured) = &m.measured {
        ui.colored_label(
            Color32::LIGHT_BLUE,
            format!("measured BRDF {} (replaces the parameters below)", measured.path.display()),
        );
    }
    let defaults = Material::default();
    for section in Section::MATERIAL {
        let params: Vec<&Param<Material>> =
            MATERIAL_PARAMS.iter().filter(|p| p.section == section && (p.applies)(&m)).collect();
        let used = params.iter().any(|p| (p.get)(&m) != (p.get)(&defaults));
        egui::CollapsingHeader::new(section.title())
            .id_salt(("section", index, section.title()))
            .default_open(section == Section::Core || used)
            .show(ui, |ui| {
                for p in params {
                    param_row(ui, p, &mut m, &textures);
                }
                if section == Section::Volume && m.volume.is_some_and(|v| v.grid.is_some()) {
                    grid_editor(ui, &mut m);
                }
            });
    }
    state.edit(|materials, _| materials[index] = m);
    if ui.button("Deselect").clicked() {
        state.selected = None;
    }
}

/// One parameter: its widget labelled with the glTF property name (help and view-file key
/// on hover), and, for a textured one, a line saying it is a factor of which texture.
fn param_row(ui: &mut Ui, p: &Param<Material>, m: &mut Material, textures: &[Texture]) {
    let hover = format!("{} ({} in view files)", p.help, p.key);
    if let Some(value) = widget(ui, p.kind, (p.get)(m), &p.name(), &hover)
        && p.kind.check(value).is_ok()
    {
        (p.set)(m, value);
    }
    if let Some(slot) = &p.texture
        && let Some(t) = (slot.get)(m)
    {
        let name = textures.get(t.texture as usize).map_or("?", |t| &t.name);
        ui.weak(format!("x factor of texture {} {name:?} ({})", t.texture, slot.channels));
    }
}

/// The widget for a value of `kind`; the new value if it was changed.
fn widget(ui: &mut Ui, kind: Kind, value: ParamValue, label: &str, hover: &str) -> Option<ParamValue> {
    ui.horizontal(|ui| match (kind, value) {
        (Kind::Number { min, max }, ParamValue::Number(mut x)) if max.is_finite() && max - min <= 10.0 => {
            let slider = egui::Slider::new(&mut x, min..=max).clamping(egui::SliderClamping::Edits).text(label);
            ui.add(slider).on_hover_text(hover).changed().then_some(ParamValue::Number(x))
        }
        (Kind::Number { min, max }, ParamValue::Number(x)) => number(ui, (min, max), x, label, hover),
        (Kind::Colour { max }, ParamValue::Triple(c)) => {
            let new = colour_edit(ui, c, max);
            ui.label(label).on_hover_text(hover);
            new.map(ParamValue::Triple)
        }
        (Kind::Switch, ParamValue::Switch(mut on)) => {
            ui.checkbox(&mut on, label).on_hover_text(hover).changed().then_some(ParamValue::Switch(on))
        }
        (Kind::Choice(names), ParamValue::Choice(mut chosen)) => {
            let before = chosen;
            egui::ComboBox::from_id_salt(label).selected_text(chosen).show_ui(ui, |ui| {
                for n in names {
                    ui.selectable_value(&mut chosen, n, *n);
                }
            });
            ui.label(label).on_hover_text(hover);
            (chosen != before).then_some(ParamValue::Choice(chosen))
        }
        _ => None,
    })
    .inner
}

/// A number of a long range (an infinite maximum, glTF's "absent", gets a checkbox).
fn number(ui: &mut Ui, (min, max): (f32, f32), mut x: f32, label: &str, hover: &str) -> Option<ParamValue> {
    let mut changed = false;
    if max == f32::INFINITY {
        let mut infinite = x == f32::INFINITY;
        if ui.checkbox(&mut infinite, "inf").on_hover_text("absent from the file: infinite").changed() {
            x = if infinite { f32::INFINITY } else { 1.0 };
            changed = true;
        }
        if infinite {
            ui.label(label).on_hover_text(hover);
            return changed.then_some(ParamValue::Number(x));
        }
    }
    let speed = (x.abs() * 0.01).max(0.001);
    let drag = egui::DragValue::new(&mut x).range(min..=max.min(f32::MAX)).clamp_existing_to_range(false).speed(speed);
    changed |= ui.add(drag).on_hover_text(hover).changed();
    ui.label(label).on_hover_text(hover);
    changed.then_some(ParamValue::Number(x))
}

/// A density grid's medium (from `SCENE.media.toml`): its density scale (the grey
/// extinction where the grid's value is 1), albedo and g. These are the sidecar's, so
/// "Save glTF" does not write them.
fn grid_editor(ui: &mut Ui, m: &mut Material) {
    let Some(v) = &mut m.volume else { return };
    ui.label("density grid from the media sidecar (not saved to glTF)");
    let mut density = v.sigma_t.x;
    let mut g = v.g;
    let mut changed =
        ui.add(egui::Slider::new(&mut density, 0.0..=1e4).logarithmic(true).text("density scale")).changed();
    let albedo = colour_edit(ui, v.albedo, 1.0);
    changed |= albedo.is_some();
    changed |= ui.add(egui::Slider::new(&mut g, -MAX_G..=MAX_G).text("anisotropy g")).changed();
    if changed {
        *v = Volume { sigma_t: Vec3::splat(density.max(0.0)), albedo: albedo.unwrap_or(v.albedo), g, ..*v };
    }
}

/// "Reset to file", and "Save glTF" with its path and result.
fn save(ui: &mut Ui, state: &mut ViewerState) {
    if state.edited() && ui.button("Reset to file").clicked() {
        state.reset_edits();
    }
    ui.label("save the scene with these materials and lights");
    ui.add(egui::TextEdit::singleline(&mut state.gltf_path).desired_width(f32::INFINITY))
        .on_hover_text("a .gltf beside its buffers and images (its URIs follow it elsewhere), or a .glb for a .glb");
    if ui.button("Save glTF").clicked() {
        state.gltf_saved = Some(state.save_gltf());
    }
    match &state.gltf_saved {
        Some(Ok(saved)) => {
            ui.label(format!("saved {}", saved.display()));
        }
        Some(Err(e)) => {
            ui.colored_label(Color32::from_rgb(255, 90, 90), e);
        }
        None => {}
    }
}

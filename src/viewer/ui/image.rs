//! The central image: drawn to fit, with the camera's mouse and keyboard controls,
//! click-to-select and Ctrl+click to pin a probe (the inspector's overlay is `inspect`).

use super::UiState;
use crate::viewer::state::ViewerState;
use egui::{Color32, Key, PointerButton, Rect, Sense, Ui, pos2};
use glam::{UVec2, Vec2, Vec3};
use std::time::{Duration, Instant};

/// How long after the last camera input the full-resolution render resumes.
const PREVIEW_HOLD: Duration = Duration::from_millis(200);

/// Dolly steps (each 10% of the distance to the target) per line of mouse-wheel scrolling:
/// 2.6% per line. X11 reports two lines per notch (seen under Xvfb), so five notches there
/// move the default view 23% of the way to the Cornell box's centre, still outside its
/// open front (26% away); with egui's smoothed scroll, five notches went inside.
const DOLLY_STEPS_PER_LINE: f32 = 0.25;

/// Lines of wheel scrolling in an input event: lines as they come, points (trackpads) at
/// egui's native 40 points per line, pages as ten lines. Raw events, not egui's smoothed
/// scroll, which spreads a notch over several frames.
fn wheel_lines(event: &egui::Event) -> f32 {
    match event {
        egui::Event::MouseWheel { unit, delta, .. } => match unit {
            egui::MouseWheelUnit::Line => delta.y,
            egui::MouseWheelUnit::Point => delta.y / 40.0,
            egui::MouseWheelUnit::Page => 10.0 * delta.y,
        },
        _ => 0.0,
    }
}

/// When to draw the next frame while the camera preview is held, `held` after the last
/// camera input: a fly key held moves the camera every frame, so soon (16 ms); otherwise
/// only when the hold ends and the render sharpens. Mouse input and new images bring their
/// own frames. A frame every 16 ms through the whole hold, as before, spent a core on
/// frames of 50-80 ms under software rendering while a drag already drew one per motion
/// event, taking it from the workers rendering the preview.
pub(super) fn preview_repaint(flying: bool, held: Duration) -> Duration {
    if flying { Duration::from_millis(16) } else { PREVIEW_HOLD.saturating_sub(held) }
}

pub(super) fn image(ui: &mut Ui, state: &mut ViewerState, ui_state: &mut UiState) {
    let (rect, response) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
    let ppp = ui.ctx().pixels_per_point();
    state.viewport =
        UVec2::new((rect.width() * ppp).round().max(1.0) as u32, (rect.height() * ppp).round().max(1.0) as u32);
    let aspect = state.aspect();
    let size = if rect.width() / rect.height() > aspect {
        egui::vec2(rect.height() * aspect, rect.height())
    } else {
        egui::vec2(rect.width(), rect.width() / aspect)
    };
    let shown = Rect::from_center_size(rect.center(), size);
    if let Some(tex) = &ui_state.texture {
        let uv = Rect::from_min_max(pos2(0.0, 0.0), pos2(1.0, 1.0));
        ui.painter().image(tex.id(), shown, uv, Color32::WHITE);
    }
    let divider = super::inspect::divider_drag(ui, state, ui_state, shown);
    super::inspect::overlay(ui, state, ui_state, shown, &response);
    let height = shown.height();
    let delta = response.drag_delta();
    let d = Vec2::new(delta.x, delta.y);
    let shift = ui.input(|i| i.modifiers.shift);
    let mut moved = false;
    // While the divider has the primary button's drag, the camera does not.
    if !divider && response.dragged_by(PointerButton::Primary) && d != Vec2::ZERO {
        if shift {
            state.camera.pan(d, height)
        } else {
            state.camera.orbit(d, height)
        }
        moved = true;
    } else if response.dragged_by(PointerButton::Middle) && d != Vec2::ZERO {
        state.camera.pan(d, height);
        moved = true;
    } else if response.dragged_by(PointerButton::Secondary) && d != Vec2::ZERO {
        state.camera.look(d, height);
        moved = true;
    }
    if response.hovered() {
        let lines = ui.input(|i| i.events.iter().map(wheel_lines).sum::<f32>());
        if lines != 0.0 {
            state.camera.dolly(lines * DOLLY_STEPS_PER_LINE);
            moved = true;
        }
    }
    let mut flying = false;
    if !ui.ctx().egui_wants_keyboard_input() && !ui.input(|i| i.modifiers.command) {
        // A key pressed in this frame counts even if it was released within it (a tap
        // during a slow frame).
        let (dt, keys) = ui.input(|i| {
            let k = |key| if i.key_down(key) || i.key_pressed(key) { 1.0 } else { 0.0 };
            (i.stable_dt.min(0.1), Vec3::new(k(Key::D) - k(Key::A), k(Key::E) - k(Key::Q), k(Key::W) - k(Key::S)))
        });
        if keys != Vec3::ZERO {
            state.camera.fly(keys, state.fly_speed * dt);
            moved = true;
            flying = true;
        }
    }
    if response.clicked()
        && !divider
        && let Some(p) = response.interact_pointer_pos().filter(|p| shown.contains(*p))
    {
        if ui.input(|i| i.modifiers.command) {
            super::inspect::pin_probe(state, ui_state, p, shown);
        } else {
            state.selected = state.pick(super::inspect::uv_of(p, shown));
        }
    }
    let now = Instant::now();
    if moved {
        ui_state.last_input = Some(now);
    }
    let held = ui_state.last_input.map(|t| now - t).filter(|d| *d < PREVIEW_HOLD);
    state.moving = held.is_some();
    if let Some(held) = held {
        ui.ctx().request_repaint_after(preview_repaint(flying, held));
    }
}

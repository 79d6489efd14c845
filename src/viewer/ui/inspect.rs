//! What is drawn over the central image and read from it: the hovered pixel's values, the
//! probes' markers (Ctrl+click pins one), the split's draggable divider, and Space to flip
//! to the pinned image.

use super::UiState;
use crate::render::Snapshot;
use crate::viewer::compare::{CompareMode, size_mismatch, stops_difference};
use crate::viewer::inspect::{PixelValues, pixel_at, pixel_values};
use crate::viewer::state::ViewerState;
use egui::{
    Align2, Color32, CursorIcon, Event, FontId, Key, PointerButton, Pos2, Rect, Response, Sense, Stroke, Ui, pos2, vec2,
};
use glam::Vec2;

/// Image position ([0, 1]^2) of screen point `p` on the image drawn in `shown`.
pub(super) fn uv_of(p: Pos2, shown: Rect) -> Vec2 {
    let uv = (p - shown.min) / shown.size();
    Vec2::new(uv.x, uv.y)
}

/// One pixel's values as the inspector words them.
pub(super) fn describe(v: &PixelValues) -> String {
    let error = v.relative_error.map_or("-".into(), |e| format!("{:.2}%", 100.0 * e));
    format!(
        "({}, {})  RGB {:.4} {:.4} {:.4}\nluminance {:.4}, {} spp, rel. std. error {error}",
        v.pixel.x, v.pixel.y, v.rgb.x, v.rgb.y, v.rgb.z, v.luminance, v.samples
    )
}

/// Draws the divider, the probes and the hovered pixel's values over the image drawn in
/// `shown`, and takes Space (flip) and the divider's drag.
pub(super) fn overlay(ui: &mut Ui, state: &mut ViewerState, ui_state: &UiState, shown: Rect, response: &Response) {
    state.compare.flip = !ui.ctx().egui_wants_keyboard_input() && ui.input(|i| i.key_down(Key::Space));
    let Some(snap) = ui_state.shown.as_deref() else { return };
    divider(ui, state, ui_state, snap, shown);
    let painter = ui.painter_at(shown);
    for (k, &uv) in state.probes.positions().iter().enumerate() {
        let p = shown.min + vec2(uv.x, uv.y) * shown.size();
        painter.circle_stroke(p, 6.0, Stroke::new(3.0, Color32::BLACK));
        painter.circle_stroke(p, 6.0, Stroke::new(1.5, Color32::WHITE));
        let at = p + vec2(8.0, -8.0);
        painter.text(
            at + vec2(1.0, 1.0),
            Align2::LEFT_BOTTOM,
            format!("{}", k + 1),
            FontId::proportional(14.0),
            Color32::BLACK,
        );
        painter.text(at, Align2::LEFT_BOTTOM, format!("{}", k + 1), FontId::proportional(14.0), Color32::WHITE);
    }
    if response.dragged() {
        return;
    }
    let Some(pointer) = response.hover_pos().filter(|p| shown.contains(*p)) else { return };
    let Some(values) = pixel_at(uv_of(pointer, shown), snap.width, snap.height).and_then(|p| pixel_values(snap, p))
    else {
        return;
    };
    let mut text = describe(&values);
    if let Some(pin) = state.compare.pin().filter(|p| size_mismatch(p, snap.width, snap.height).is_none()) {
        let pinned = crate::math::luminance(pin.pixels[(values.pixel.y * snap.width + values.pixel.x) as usize]);
        let stops = stops_difference(values.luminance, pinned);
        text.push_str(&format!("\npinned: luminance {pinned:.4}, live {stops:+.2} stops"));
    }
    // Below right of the cursor, moved to the other side where it would leave the image
    // area, and kept inside it.
    let area = ui.clip_rect();
    let painter = ui.painter();
    let galley = painter.layout_no_wrap(text, FontId::monospace(12.0), Color32::WHITE);
    let size = galley.size() + vec2(8.0, 8.0);
    let mut at = pointer + vec2(16.0, 16.0);
    if at.x + size.x > area.max.x {
        at.x = pointer.x - 16.0 - size.x;
    }
    if at.y + size.y > area.max.y {
        at.y = pointer.y - 16.0 - size.y;
    }
    at = at.clamp(area.min, (area.max - size).max(area.min));
    painter.rect_filled(Rect::from_min_size(at, size), 3.0, Color32::from_black_alpha(190));
    painter.galley(at + vec2(4.0, 4.0), galley, Color32::WHITE);
}

/// Half the width of the band around the divider that grabs it, in points.
const GRIP: f32 = 6.0;

/// Whether the split's divider is drawn over the live image `snap`.
fn split_shown(state: &ViewerState, snap: &Snapshot) -> bool {
    let comparable = state.compare.pin().is_some_and(|p| size_mismatch(p, snap.width, snap.height).is_none());
    comparable && state.compare.mode() == CompareMode::Split
}

/// Moves the split's divider with a drag that pressed on it, before the camera sees the
/// drag: with slow frames, the press and the first movement arrive in one frame, and the
/// pointer has left the divider by the time egui gives the drag to a widget, so the press
/// position decides here and the divider follows the pointer. Returns whether the
/// primary button's press belongs to the divider (the camera and picking leave it alone).
pub(super) fn divider_drag(ui: &Ui, state: &mut ViewerState, ui_state: &mut UiState, shown: Rect) -> bool {
    if !ui_state.shown.as_deref().is_some_and(|snap| split_shown(state, snap)) {
        ui_state.divider_held = false;
        return false;
    }
    // Where the primary button went down in this frame (from the event: a press released
    // within the frame has no press origin any more).
    let (pressed, down, latest) = ui.input(|i| {
        let pressed = i.events.iter().find_map(|e| match e {
            Event::PointerButton { pos, button: PointerButton::Primary, pressed: true, .. } => Some(*pos),
            _ => None,
        });
        (pressed, i.pointer.primary_down(), i.pointer.latest_pos())
    });
    let x = shown.min.x + state.compare.view.split.clamp(0.0, 1.0) * shown.width();
    if pressed.is_some_and(|p| (p.x - x).abs() <= GRIP && (shown.min.y..=shown.max.y).contains(&p.y)) {
        ui_state.divider_held = true;
    }
    if !ui_state.divider_held {
        return false;
    }
    if let Some(p) = latest {
        state.compare.view.split = ((p.x - shown.min.x) / shown.width()).clamp(0.0, 1.0);
        state.compare.divider_moved = true;
    }
    ui_state.divider_held = down;
    true
}

/// The split's divider: a line with a handle (dragged by `divider_drag`).
fn divider(ui: &mut Ui, state: &mut ViewerState, ui_state: &UiState, snap: &Snapshot, shown: Rect) {
    if !split_shown(state, snap) {
        return;
    }
    let x = shown.min.x + state.compare.view.split.clamp(0.0, 1.0) * shown.width();
    let grip = Rect::from_min_max(pos2(x - GRIP, shown.min.y), pos2(x + GRIP, shown.max.y));
    let response = ui
        .interact(grip, ui.make_persistent_id("compare divider"), Sense::hover())
        .on_hover_cursor(CursorIcon::ResizeHorizontal);
    let painter = ui.painter_at(shown);
    let stroke = Stroke::new(if response.hovered() || ui_state.divider_held { 3.0 } else { 2.0 }, Color32::WHITE);
    painter
        .line_segment([pos2(x, shown.min.y), pos2(x, shown.max.y)], Stroke::new(4.0, Color32::from_black_alpha(120)));
    painter.line_segment([pos2(x, shown.min.y), pos2(x, shown.max.y)], stroke);
    let handle = pos2(x, shown.center().y);
    painter.circle_filled(handle, 9.0, Color32::from_black_alpha(160));
    painter.circle_stroke(handle, 9.0, stroke);
    let font = FontId::proportional(12.0);
    painter.text(pos2(x - 12.0, shown.min.y + 6.0), Align2::RIGHT_TOP, "pinned", font.clone(), Color32::WHITE);
    painter.text(pos2(x + 12.0, shown.min.y + 6.0), Align2::LEFT_TOP, "live", font, Color32::WHITE);
}

/// Pins a probe at screen point `p` on the image drawn in `shown`.
pub(super) fn pin_probe(state: &mut ViewerState, ui_state: &UiState, p: Pos2, shown: Rect) {
    let (width, height) = match ui_state.shown.as_deref() {
        Some(s) => (s.width, s.height),
        None => {
            let s = state.effective_settings();
            (s.width, s.height)
        }
    };
    state.probes.add(uv_of(p, shown), width, height);
}

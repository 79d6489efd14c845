//! The panels headless: frames of the whole UI run through egui without a window, fed the
//! input events a slow frame delivers at once, and read back from the text they paint.

use super::{UiState, draw, param_widget};
use crate::film::tonemap::Display;
use crate::integrator::Settings;
use crate::loader::builtin;
use crate::scene::Scene;
use crate::viewer::compare::{CompareMode, Pin, PinInfo};
use crate::viewer::state::ViewerState;
use egui::{Event, Key, Modifiers, MouseWheelSource, MouseWheelUnit, PointerButton, Pos2, Rect, Shape, TouchPhase};
use std::time::Duration;

/// The viewer on the built-in Cornell box at 48x48, its UI, and egui, in a `size` window.
struct Harness {
    ctx: egui::Context,
    state: ViewerState,
    ui: UiState,
    size: egui::Vec2,
    time: f64,
}

impl Harness {
    /// The harness with the first image rendered and shown.
    fn new(width: f32, height: f32) -> Self {
        let settings = Settings { width: 48, height: 48, ..Settings::default() };
        let scene = Scene::build(builtin::cornell_box());
        let state = ViewerState::new(scene, None, settings, true, Display::default(), None, Some(1)).unwrap();
        let mut ui = UiState::new();
        ui.shown = Some(state.wait_for_update(None, Duration::from_secs(30)).expect("an image"));
        Self { ctx: egui::Context::default(), state, ui, size: egui::vec2(width, height), time: 0.0 }
    }

    /// Runs one frame with `events` (200 ms after the last, as under software rendering) and
    /// returns the texts painted where they can be seen, with their rectangles.
    fn frame(&mut self, events: Vec<Event>) -> Vec<(String, Rect)> {
        self.time += 0.2;
        let input = egui::RawInput {
            screen_rect: Some(Rect::from_min_size(Pos2::ZERO, self.size)),
            time: Some(self.time),
            events,
            ..egui::RawInput::default()
        };
        let (state, ui) = (&mut self.state, &mut self.ui);
        let output = self.ctx.run_ui(input, |root| draw(root, state, ui));
        let mut texts = Vec::new();
        for clipped in &output.shapes {
            let clip = clipped.clip_rect.intersect(Rect::from_min_size(Pos2::ZERO, self.size));
            visible_texts(&clipped.shape, clip, &mut texts);
        }
        texts
    }
}

/// The texts of `shape` that show inside `clip`.
fn visible_texts(shape: &Shape, clip: Rect, out: &mut Vec<(String, Rect)>) {
    match shape {
        Shape::Vec(shapes) => shapes.iter().for_each(|s| visible_texts(s, clip, out)),
        Shape::Text(t) if clip.intersects(t.visual_bounding_rect()) => {
            out.push((t.galley.text().to_string(), t.visual_bounding_rect()))
        }
        _ => {}
    }
}

fn shows(texts: &[(String, Rect)], f: impl Fn(&str) -> bool) -> bool {
    texts.iter().any(|(t, _)| f(t))
}

#[test]
fn ticking_the_firefly_clamp_moves_nothing() {
    let clamp = Settings::table().iter().find(|p| p.name == "clamp").expect("the clamp is in the table");
    let ctx = egui::Context::default();
    let rect = |value: Option<f32>| {
        let mut settings = Settings { firefly_clamp: value, ..Settings::default() };
        let mut rect = Rect::NOTHING;
        for _ in 0..2 {
            let _ = ctx.run_ui(egui::RawInput::default(), |ui| {
                rect = ui.scope(|ui| param_widget(ui, clamp, &mut settings)).response.rect;
            });
        }
        rect
    };
    let (off, on) = (rect(None), rect(Some(10.0)));
    assert!(off.is_positive() && off == on, "the clamp's row is {off:?} off and {on:?} on");
}

#[test]
fn the_status_stays_in_view_when_the_controls_scroll() {
    let mut h = Harness::new(1600.0, 700.0);
    let status = |t: &str| t.contains(" spp, ") && t.contains("48x48");
    let texts = h.frame(Vec::new());
    assert!(shows(&texts, status) && !shows(&texts, |t| t == "Files"), "the panel is longer than the window");
    let wheel = Event::MouseWheel {
        unit: MouseWheelUnit::Point,
        delta: egui::vec2(0.0, -400.0),
        phase: TouchPhase::Move,
        source: MouseWheelSource::Wheel,
        modifiers: Modifiers::NONE,
    };
    let mut texts = Vec::new();
    for _ in 0..30 {
        texts = h.frame(vec![Event::PointerMoved(egui::pos2(150.0, 600.0)), wheel.clone()]);
    }
    assert!(shows(&texts, |t| t == "Files"), "scrolled to the bottom of the controls");
    assert!(shows(&texts, status), "the status scrolled away");
}

#[test]
fn a_ctrl_q_pressed_and_released_within_one_frame_quits() {
    let mut h = Harness::new(1600.0, 1000.0);
    h.frame(Vec::new());
    assert!(!h.ui.quit);
    // Ctrl went down and up around the Q within the frame: it is no longer held at its end.
    let q =
        |pressed| Event::Key { key: Key::Q, physical_key: None, pressed, repeat: false, modifiers: Modifiers::COMMAND };
    h.frame(vec![q(true), q(false)]);
    assert!(h.ui.quit, "the Ctrl+Q was missed");
}

#[test]
fn a_divider_pressed_and_dragged_within_one_frame_moves_the_divider_not_the_camera() {
    let mut h = Harness::new(1600.0, 1000.0);
    let snap = h.ui.shown.clone().unwrap();
    let info = PinInfo::default();
    let pin = Pin { width: snap.width, height: snap.height, pixels: snap.mean.clone(), info };
    h.state.compare.set_pin(Some(pin), None);
    h.state.compare.view.mode = CompareMode::Split;
    let texts = h.frame(Vec::new());
    // The divider runs between its labels, "pinned" 12 points left of it and "live" 12
    // points right of it (the compare panel's buttons have these names too).
    let rects = |name: &str| texts.iter().filter(|(t, _)| t == name).map(|(_, r)| *r).collect::<Vec<_>>();
    let (pinned, live) = rects("pinned")
        .into_iter()
        .flat_map(|p| rects("live").into_iter().map(move |l| (p, l)))
        .find(|(p, l)| (18.0..30.0).contains(&(l.left() - p.right())) && (l.top() - p.top()).abs() < 3.0)
        .expect("the divider's labels");
    let on_divider = egui::pos2(0.5 * (pinned.right() + live.left()), live.bottom() + 10.0);
    let camera = h.state.camera;
    let split = h.state.compare.view.split;
    let button = |pos, pressed| Event::PointerButton {
        pos,
        button: PointerButton::Primary,
        pressed,
        modifiers: Modifiers::NONE,
    };
    h.frame(vec![Event::PointerMoved(on_divider)]);
    // One slow frame: the press on the divider and a move of 40 points to the right; then
    // 40 more, and the release.
    let moved = on_divider + egui::vec2(40.0, 0.0);
    h.frame(vec![button(on_divider, true), Event::PointerMoved(moved)]);
    let further = moved + egui::vec2(40.0, 0.0);
    h.frame(vec![Event::PointerMoved(further)]);
    h.frame(vec![button(further, false)]);
    assert_eq!(h.state.camera, camera, "the camera orbited");
    assert!(h.state.compare.view.split > split && h.state.compare.divider_moved, "the divider stayed");
}

#[test]
fn a_held_preview_repaints_when_it_ends_unless_a_fly_key_moves_the_camera() {
    use super::image::preview_repaint;
    // A frame every 16 ms through the whole hold took a core from the render workers
    // under software rendering: only flying needs one.
    assert_eq!(preview_repaint(false, Duration::from_millis(50)), Duration::from_millis(150));
    assert_eq!(preview_repaint(false, Duration::from_millis(250)), Duration::ZERO);
    assert_eq!(preview_repaint(true, Duration::from_millis(50)), Duration::from_millis(16));
}

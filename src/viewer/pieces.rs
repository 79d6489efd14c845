//! The viewer on a folder of pieces (`lucent view DIR`), for a render a cluster is making:
//! a thread watches the folder and merges the pieces that have arrived (`film::merge`,
//! every pixel the mean of the samples it has so far), and the window shows that image
//! with the samples per pixel so far, until the last piece lands.

use crate::film::merge::{Merged, merge, pieces_in};
use crate::film::output::write_image;
use crate::film::tonemap::{DISPLAY, Display};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::WindowId;

/// How often the folder is listed.
const WATCH: Duration = Duration::from_millis(300);

/// The latest merge of the folder (or why there is none), shared with the watcher.
type Latest = Arc<Mutex<Option<Arc<Result<Merged, String>>>>>;

/// A thread that merges the folder's pieces whenever they change.
struct Watcher {
    latest: Latest,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

/// The pieces in `dir`, with their sizes and times: what decides whether to merge again.
fn listing(dir: &Path) -> Result<Vec<(PathBuf, u64, Option<SystemTime>)>, String> {
    Ok(pieces_in(dir)?
        .into_iter()
        .map(|p| {
            let meta = std::fs::metadata(&p).ok();
            let (len, time) = meta.map_or((0, None), |m| (m.len(), m.modified().ok()));
            (p, len, time)
        })
        .collect())
}

impl Watcher {
    fn new(dir: PathBuf) -> Self {
        let latest: Latest = Arc::default();
        let stop = Arc::new(AtomicBool::new(false));
        let (out, quit) = (Arc::clone(&latest), Arc::clone(&stop));
        let thread = std::thread::spawn(move || {
            let mut seen = None;
            while !quit.load(Ordering::Relaxed) {
                let now = listing(&dir);
                if seen.as_ref() != Some(&now) {
                    let result = now.clone().and_then(|l| {
                        let paths: Vec<PathBuf> = l.into_iter().map(|(p, _, _)| p).collect();
                        if paths.is_empty() {
                            Err(format!("no pieces in {} yet", dir.display()))
                        } else {
                            merge(&paths, false, None)
                        }
                    });
                    match &result {
                        Ok(m) => eprintln!("viewer: {}, {} spp so far", pieces_merged(m.pieces), m.spp.0),
                        Err(e) => eprintln!("viewer: {e}"),
                    }
                    *out.lock().unwrap_or_else(|e| e.into_inner()) = Some(Arc::new(result));
                    seen = Some(now);
                }
                std::thread::sleep(WATCH);
            }
        });
        Self { latest, stop, thread: Some(thread) }
    }

    fn latest(&self) -> Option<Arc<Result<Merged, String>>> {
        self.latest.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

impl Drop for Watcher {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Opens the window on `dir`; with `screenshot` (a PNG and a sample count), saves the
/// merge once every pixel has that many samples, and exits.
pub fn run(dir: PathBuf, screenshot: Option<(PathBuf, u32)>) -> Result<(), String> {
    if !dir.is_dir() {
        return Err(format!("{}: not a folder of pieces", dir.display()));
    }
    let event_loop = EventLoop::new().map_err(|e| format!("cannot open a window: {e}"))?;
    let mut app = App {
        watcher: Watcher::new(dir.clone()),
        dir,
        screenshot,
        egui: egui::Context::default(),
        window: None,
        shown: None,
        display: None,
        drawn_with: None,
        texture: None,
        result: Ok(()),
    };
    event_loop.run_app(&mut app).map_err(|e| format!("the window's event loop failed: {e}"))?;
    app.result
}

/// The window on a folder of pieces.
struct App {
    dir: PathBuf,
    watcher: Watcher,
    screenshot: Option<(PathBuf, u32)>,
    egui: egui::Context,
    window: Option<super::WindowParts>,
    /// The merge on screen.
    shown: Option<Arc<Result<Merged, String>>>,
    /// The display transform (the pieces' own until the user changes it).
    display: Option<Display>,
    /// The display the texture was made with.
    drawn_with: Option<Display>,
    texture: Option<egui::TextureHandle>,
    result: Result<(), String>,
}

impl App {
    /// Takes the newest merge; true if it changed what is on screen.
    fn update(&mut self) -> bool {
        let Some(latest) = self.watcher.latest() else { return false };
        let fresh = self.shown.as_ref().is_none_or(|s| !Arc::ptr_eq(s, &latest));
        if fresh {
            self.shown = Some(latest);
        }
        let Some(Ok(m)) = self.shown.as_deref() else { return fresh };
        let display = *self.display.get_or_insert(m.display);
        if fresh || self.drawn_with != Some(display) {
            let rgba: Vec<[u8; 4]> =
                m.mean.iter().map(|&p| display.to_srgb8(p)).map(|[r, g, b]| [r, g, b, 255]).collect();
            let image =
                egui::ColorImage::from_rgba_unmultiplied([m.width as usize, m.height as usize], rgba.as_flattened());
            match &mut self.texture {
                Some(t) => t.set(image, egui::TextureOptions::LINEAR),
                None => self.texture = Some(self.egui.load_texture("pieces", image, egui::TextureOptions::LINEAR)),
            }
            self.drawn_with = Some(display);
        }
        true
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) {
        self.update();
        let Some((window, gpu, egui_state)) = &mut self.window else { return };
        let input = egui_state.take_egui_input(window);
        let (dir, shown, texture, display) = (&self.dir, self.shown.as_deref(), &self.texture, &mut self.display);
        let output = self.egui.run_ui(input, |ui| draw(ui, dir, shown, texture.as_ref(), display));
        egui_state.handle_platform_output(window, output.platform_output);
        let primitives = self.egui.tessellate(output.shapes, output.pixels_per_point);
        gpu.paint(window, &primitives, &output.textures_delta, output.pixels_per_point);
        if let Some((path, spp)) = self.screenshot.clone() {
            self.finish_screenshot(event_loop, &path, spp);
        }
    }

    /// In --screenshot mode: once every pixel has `spp` samples and is on screen, save
    /// the merge with the pieces' display and exit; a refused merge ends it with its error.
    fn finish_screenshot(&mut self, event_loop: &ActiveEventLoop, path: &Path, spp: u32) {
        match self.shown.as_deref() {
            Some(Ok(m)) if m.spp.0 >= spp => {
                self.result = write_image(path, m.width, m.height, &m.mean, &m.display).map_err(|e| e.to_string());
                if self.result.is_ok() {
                    let merged = pieces_merged(m.pieces);
                    println!("{merged}, {} spp at {}x{}; wrote {}", m.spp.0, m.width, m.height, path.display());
                }
                event_loop.exit();
            }
            Some(Err(e)) if !e.starts_with("no pieces") => {
                self.result = Err(e.clone());
                event_loop.exit();
            }
            _ => {}
        }
    }
}

/// "1 piece merged", "3 pieces merged".
fn pieces_merged(n: usize) -> String {
    if n == 1 { "1 piece merged".into() } else { format!("{n} pieces merged") }
}

/// The panel (folder, pieces, spp so far, display) and the image.
fn draw(
    ui: &mut egui::Ui,
    dir: &Path,
    shown: Option<&Result<Merged, String>>,
    texture: Option<&egui::TextureHandle>,
    display: &mut Option<Display>,
) {
    egui::Panel::left("pieces").resizable(true).default_size(280.0).show(ui, |ui| {
        ui.heading("Pieces");
        ui.label(dir.display().to_string());
        match shown {
            None => {
                ui.label("reading the folder...");
            }
            Some(Err(e)) => {
                ui.colored_label(egui::Color32::from_rgb(255, 90, 90), e);
            }
            Some(Ok(m)) => {
                ui.label(format!("{}, {}x{}", pieces_merged(m.pieces), m.width, m.height));
                let (low, high) = m.spp;
                ui.label(if low == high {
                    format!("{low} spp so far")
                } else {
                    format!("{low} spp so far ({high} where more pieces arrived)")
                });
                ui.label(format!("NaN/Inf dropped {}", m.rejected));
            }
        }
        if let Some(d) = display {
            ui.separator();
            for p in DISPLAY {
                super::ui::param_widget(ui, p, d);
            }
        }
    });
    egui::CentralPanel::no_frame().show(ui, |ui| {
        let (rect, _) = ui.allocate_exact_size(ui.available_size(), egui::Sense::hover());
        if let (Some(tex), Some(Ok(m))) = (texture, shown) {
            let aspect = m.width as f32 / m.height as f32;
            let size = if rect.width() / rect.height() > aspect {
                egui::vec2(rect.height() * aspect, rect.height())
            } else {
                egui::vec2(rect.width(), rect.width() / aspect)
            };
            let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
            ui.painter().image(tex.id(), egui::Rect::from_center_size(rect.center(), size), uv, egui::Color32::WHITE);
        }
    });
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let title = format!("Lucent: pieces in {}", self.dir.display());
        match super::open_window(event_loop, &self.egui, &title) {
            Ok(w) => self.window = Some(w),
            Err(e) => {
                self.result = Err(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some((window, gpu, egui_state)) = &mut self.window else { return };
        let response = egui_state.on_window_event(window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                gpu.resize(size.width, size.height);
                self.frame(event_loop);
            }
            WindowEvent::RedrawRequested => {}
            _ if response.repaint => self.frame(event_loop),
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            return;
        }
        let arrived = self.watcher.latest().is_some_and(|l| self.shown.as_ref().is_none_or(|s| !Arc::ptr_eq(s, &l)));
        if arrived || self.shown.is_none() || self.display != self.drawn_with {
            self.frame(event_loop);
        }
        event_loop.set_control_flow(ControlFlow::WaitUntil(Instant::now() + Duration::from_millis(100)));
    }
}

//! The interactive viewer: a winit window with a wgpu surface, egui panels, and the image
//! converging live while the render session's workers keep adding samples.

pub mod camera_control;
pub mod compare;
pub mod convergence;
pub mod denoise;
mod gpu;
pub mod histogram;
pub mod inspect;
mod pieces;
pub mod progress;
pub mod state;
mod ui;

use crate::config::ViewFile;
use crate::open::{OpenOptions, open};
use crate::render::Snapshot;
use crate::scene::instances::Instancing;
use gpu::Gpu;
use state::ViewerState;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};
use ui::UiState;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

/// How often the event loop looks for a new image when nothing else happens.
const POLL: Duration = Duration::from_millis(33);

/// Shortest interval between two images of the same job on screen: several updates a
/// second without spending the render cores on redraws (a new job's first image and the
/// final one are shown at once).
const REFRESH: Duration = Duration::from_millis(250);

/// What decides how an image is drawn: display transform, image view (radiance, error,
/// samples), outlined material, the denoised result shown, and the before/after comparison.
type Look =
    (crate::film::tonemap::Display, state::ImageView, Option<u32>, Option<(u64, u32)>, (compare::CompareView, u64));

/// What the viewer opens, as the command line resolved it.
pub struct Launch {
    /// The glTF file (None: the built-in Cornell box).
    pub scene: Option<PathBuf>,
    /// Settings, display, camera and environment.
    pub view: ViewFile,
    /// Look through the file's camera with this index instead of `view.camera`.
    pub file_camera: Option<usize>,
    /// Leave a scene without light of its own dark instead of lighting it with the built-in sky.
    pub keep_dark: bool,
    /// The KHR_materials_variants variant to open the scene in.
    pub variant: Option<String>,
    /// Which meshes placed many times stay instanced.
    pub instancing: Instancing,
    /// Render at the view's size instead of following the window.
    pub fixed_size: bool,
    /// Worker threads (None: one per core).
    pub threads: Option<usize>,
    /// Render until the target spp, save this PNG (and an EXR beside it) and exit.
    pub screenshot: Option<PathBuf>,
    /// Start with the Denoise toggle on or off (None: on wherever the library is found).
    pub denoise: Option<bool>,
    /// Pin this linear image for before/after comparison instead of the scene's last pin.
    pub compare: Option<PathBuf>,
    /// The path "Save glTF" writes to; with a screenshot, written as the viewer exits.
    pub save_gltf: Option<PathBuf>,
}

/// Opens the viewer (on a folder of pieces: their merge as they arrive); with a screenshot
/// path, renders to the target spp, saves and exits.
pub fn run(launch: Launch) -> Result<(), String> {
    let Launch {
        scene: path,
        view,
        file_camera,
        fixed_size,
        keep_dark,
        variant,
        instancing,
        threads,
        screenshot,
        denoise,
        compare,
        save_gltf,
    } = launch;
    if let Some(dir) = path.as_ref().filter(|p| p.is_dir()) {
        if denoise == Some(true) {
            return Err("--denoise needs a scene: pieces carry no albedo and normal images".into());
        }
        return pieces::run(dir.clone(), screenshot.zip(view.settings.target_spp));
    }
    let scene = open(
        path.as_deref(),
        &OpenOptions {
            environment: view.environment.clone(),
            keep_dark,
            variant: variant.clone(),
            instancing,
            ..OpenOptions::default()
        },
        &mut |_| {},
    )?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let camera = match file_camera {
        Some(i) => Some(scene.file_camera(i).map_err(|e| format!("--{e}"))?),
        None => view.camera,
    };
    let mut state = ViewerState::new(scene, path, view.settings, fixed_size, view.display, camera, threads)?;
    state.sharpen_from_coarsest();
    state.apply_edits(&view)?;
    state.variant = variant;
    state.denoiser.enabled = denoise.unwrap_or_else(|| crate::film::denoise::available().is_ok());
    if let Some(gltf) = &save_gltf {
        state.gltf_path = gltf.display().to_string();
    }
    state.compare.store = compare::PinStore::user();
    match compare {
        Some(file) => state.compare_with(&file)?,
        None => state.load_pin(),
    }
    let event_loop = EventLoop::new().map_err(|e| format!("cannot open a window: {e}"))?;
    let mut app = App::new(state, screenshot);
    app.save_gltf = save_gltf.is_some();
    event_loop.run_app(&mut app).map_err(|e| format!("the window's event loop failed: {e}"))?;
    if app.screenshot.is_none() {
        eprintln!("{}", app.summary());
    }
    app.result
}

/// A window, its GPU surface and egui's state.
type WindowParts = (Arc<Window>, Gpu, egui_winit::State);

/// Opens a 1280x800 window titled `title` with a surface on any adapter that presents to it.
fn open_window(event_loop: &ActiveEventLoop, egui: &egui::Context, title: &str) -> Result<WindowParts, String> {
    let attributes =
        Window::default_attributes().with_title(title).with_inner_size(winit::dpi::LogicalSize::new(1280.0, 800.0));
    let window = Arc::new(event_loop.create_window(attributes).map_err(|e| format!("cannot open a window: {e}"))?);
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
        event_loop.owned_display_handle(),
    )));
    let gpu = Gpu::new(&instance, Arc::clone(&window))?;
    eprintln!("viewer: presenting with {}", gpu.adapter);
    let egui_state = egui_winit::State::new(
        egui.clone(),
        egui::ViewportId::ROOT,
        &window,
        Some(window.scale_factor() as f32),
        window.theme(),
        Some(gpu.max_texture_side()),
    );
    Ok((window, gpu, egui_state))
}

/// The window, its GPU resources, egui, and the viewer state.
struct App {
    state: ViewerState,
    ui: UiState,
    egui: egui::Context,
    window: Option<WindowParts>,
    screenshot: Option<PathBuf>,
    /// In screenshot mode, also write the scene as glTF (to `state.gltf_path`).
    save_gltf: bool,
    /// When egui asked to be drawn again.
    repaint_at: Option<Instant>,
    /// Whether something asked for a frame since the last one.
    redraw_wanted: bool,
    /// When the image on screen was last replaced.
    shown_at: Instant,
    /// How the image on screen was drawn (display transform, error view, selection).
    shown_look: Look,
    frames: u32,
    frame_time: Duration,
    result: Result<(), String>,
}

impl App {
    fn new(state: ViewerState, screenshot: Option<PathBuf>) -> Self {
        Self {
            state,
            ui: UiState::new(),
            egui: egui::Context::default(),
            window: None,
            screenshot,
            save_gltf: false,
            repaint_at: None,
            redraw_wanted: true,
            shown_at: Instant::now(),
            shown_look: Look::default(),
            frames: 0,
            frame_time: Duration::ZERO,
            result: Ok(()),
        }
    }

    /// UI frame time and restart latencies over the whole session, one line: the median
    /// time from a restart to its first image at each preview level and at full resolution.
    fn summary(&self) -> String {
        let median = |divisor: u32| {
            let mut ms: Vec<f64> =
                self.state.latencies.iter().filter(|l| l.1 == divisor).map(|l| l.0.as_secs_f64() * 1e3).collect();
            ms.sort_by(f64::total_cmp);
            let level = if divisor == 1 { "full".to_string() } else { format!("1/{divisor}") };
            ms.get(ms.len() / 2).map(|m| format!("{level} {m:.0} ms (median of {})", ms.len()))
        };
        let levels: Vec<String> = [8, 4, 2, 1].into_iter().filter_map(median).collect();
        format!(
            "viewer: {} UI frames, mean {:.1} ms; restart to first image: {}",
            self.frames,
            self.frame_time.as_secs_f64() * 1e3 / self.frames.max(1) as f64,
            if levels.is_empty() { "-".to_string() } else { levels.join(", ") }
        )
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, error: String) {
        self.result = Err(error);
        event_loop.exit();
    }

    /// How the state asks images to be drawn now.
    fn look(&self) -> Look {
        (
            self.state.display,
            self.state.view,
            self.state.highlighted(),
            self.state.denoiser.shown_key(),
            self.state.compare.look(),
        )
    }

    /// The newest image, if it should replace the one on screen now (or be redrawn, if
    /// the way it is drawn changed).
    fn image_due(&mut self) -> Option<Arc<Snapshot>> {
        let snap = self.state.snapshot()?;
        let due = match &self.ui.shown {
            None => true,
            _ if self.look() != self.shown_look => true,
            Some(s) if Arc::ptr_eq(s, &snap) => false,
            Some(s) => s.generation != snap.generation || snap.done || self.shown_at.elapsed() >= REFRESH,
        };
        due.then_some(snap)
    }

    /// Shows the newest image, if it is due.
    fn update_image(&mut self) {
        let Some(snap) = self.image_due() else { return };
        if self.ui.shown.as_ref().is_none_or(|s| !Arc::ptr_eq(s, &snap)) {
            self.state.record_convergence(&snap);
        }
        self.shown_at = Instant::now();
        self.state.auto_expose(&snap);
        self.shown_look = self.look();
        let rgba = self.state.display_rgba(&snap);
        let size = [snap.width as usize, snap.height as usize];
        let image = egui::ColorImage::from_rgba_unmultiplied(size, rgba.as_flattened());
        match &mut self.ui.texture {
            Some(t) => t.set(image, egui::TextureOptions::LINEAR),
            None => self.ui.texture = Some(self.egui.load_texture("render", image, egui::TextureOptions::LINEAR)),
        }
        self.ui.shown = Some(snap);
    }

    /// Runs the UI, paints the window and applies what the user changed.
    fn frame(&mut self, event_loop: &ActiveEventLoop) {
        let start = Instant::now();
        self.state.poll_loading();
        self.update_image();
        let Some((window, gpu, egui_state)) = &mut self.window else { return };
        let title = format!("Lucent: {}", self.state.scene.name);
        if window.title() != title {
            window.set_title(&title);
        }
        let input = egui_state.take_egui_input(window);
        let (state, ui_state) = (&mut self.state, &mut self.ui);
        let output = self.egui.run_ui(input, |ui| ui::draw(ui, state, ui_state));
        egui_state.handle_platform_output(window, output.platform_output);
        let primitives = self.egui.tessellate(output.shapes, output.pixels_per_point);
        gpu.paint(window, &primitives, &output.textures_delta, output.pixels_per_point);
        let delay = output.viewport_output.get(&egui::ViewportId::ROOT).map_or(Duration::MAX, |v| v.repaint_delay);
        self.repaint_at = Instant::now().checked_add(delay);
        self.state.sync();
        let took = start.elapsed();
        self.frames += 1;
        self.frame_time += took;
        let ms = took.as_secs_f32() * 1e3;
        self.ui.frame_ms = if self.frames == 1 { ms } else { 0.9 * self.ui.frame_ms + 0.1 * ms };
        if self.ui.quit {
            event_loop.exit();
        } else if let Some(path) = self.screenshot.clone() {
            self.finish_screenshot(event_loop, &path);
        }
    }

    /// In --screenshot mode: once the target is reached and shown (denoised, with the
    /// toggle on), save and exit.
    fn finish_screenshot(&mut self, event_loop: &ActiveEventLoop, path: &Path) {
        let Some(snap) = self.ui.shown.clone() else { return };
        if !snap.done || snap.generation != self.state.generation() {
            return;
        }
        let denoiser = &self.state.denoiser;
        if denoiser.enabled && !denoiser.done_with(&snap) {
            if let Some(e) = denoiser.error() {
                let e = e.to_string();
                self.fail(event_loop, e);
            }
            return;
        }
        match self.state.save_images(&snap, path).and_then(|()| match self.save_gltf {
            true => self.state.save_gltf().map(|_| ()),
            false => Ok(()),
        }) {
            Ok(()) => {
                println!("{}; {}; wrote {}", snap.summary(&self.state.scene.name), self.summary(), path.display());
                event_loop.exit();
            }
            Err(e) => self.fail(event_loop, e),
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let (window, gpu, egui_state) = match open_window(event_loop, &self.egui, "Lucent") {
            Ok(w) => w,
            Err(e) => return self.fail(event_loop, e),
        };
        self.window = Some((window, gpu, egui_state));
        self.redraw_wanted = true;
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some((window, gpu, egui_state)) = &mut self.window else { return };
        let response = egui_state.on_window_event(window, &event);
        self.redraw_wanted |= match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                false
            }
            WindowEvent::Resized(size) => {
                gpu.resize(size.width, size.height);
                true
            }
            WindowEvent::DroppedFile(path) => {
                self.state.open(path);
                true
            }
            // Under X11 each present can come back as an expose, and so as a redraw request;
            // frames are drawn from `about_to_wait` when something asked for one instead, or
            // the UI would redraw in a loop and take the cores from the render workers.
            WindowEvent::RedrawRequested => false,
            _ => response.repaint,
        };
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            return;
        }
        self.state.poll_denoiser();
        let newer = self.image_due().is_some();
        let due = self.repaint_at.is_some_and(|t| t <= Instant::now());
        if std::mem::take(&mut self.redraw_wanted) || newer || due || self.state.loading_status().is_some() {
            self.frame(event_loop);
        }
        let next = Instant::now() + POLL;
        let wake = self.repaint_at.map_or(next, |t| t.min(next));
        event_loop.set_control_flow(ControlFlow::WaitUntil(wake));
    }
}

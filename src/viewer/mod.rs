//! The interactive viewer: a winit window with a wgpu surface, egui panels, and the image
//! converging live while the render session's workers keep adding samples.

pub mod camera_control;
mod gpu;
pub mod state;
mod ui;

use crate::cli::args::ViewArgs;
use crate::cli::render::load_scene;
use crate::film::output::Format;
use crate::film::output::check_writable;
use gpu::Gpu;
use state::ViewerState;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};
use ui::UiState;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

/// How often the event loop looks for a new image when nothing else happens.
const POLL: Duration = Duration::from_millis(33);

/// Opens the viewer; with `--screenshot`, renders to `--spp`, saves and exits.
pub fn run(args: &ViewArgs) -> Result<(), String> {
    let resolved = args.options.resolve(args.spp)?;
    if let Some(shot) = &args.screenshot
        && check_writable(shot).map_err(|e| e.to_string())? != Format::Png
    {
        return Err(format!("--screenshot {} must name a .png (the .exr is written beside it)", shot.display()));
    }
    let fixed = args.options.width.is_some() || args.options.height.is_some() || args.options.view.is_some();
    let scene = load_scene(args.scene.as_deref())?;
    let state = ViewerState::new(
        scene,
        args.scene.clone(),
        resolved.settings,
        fixed,
        resolved.display,
        resolved.camera,
        args.options.threads,
    )?;
    let event_loop = EventLoop::new().map_err(|e| format!("cannot open a window: {e}"))?;
    let mut app = App::new(state, args.screenshot.clone());
    event_loop.run_app(&mut app).map_err(|e| format!("the window's event loop failed: {e}"))?;
    app.result
}

/// The window, its GPU resources, egui, and the viewer state.
struct App {
    state: ViewerState,
    ui: UiState,
    egui: egui::Context,
    window: Option<(Arc<Window>, Gpu, egui_winit::State)>,
    screenshot: Option<PathBuf>,
    repaint_at: Option<Instant>,
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
            repaint_at: None,
            frames: 0,
            frame_time: Duration::ZERO,
            result: Ok(()),
        }
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, error: String) {
        self.result = Err(error);
        event_loop.exit();
    }

    /// Shows the newest snapshot, if newer than the one on screen.
    fn update_image(&mut self) -> bool {
        let Some(snap) = self.state.snapshot() else { return false };
        if self.ui.shown.as_ref().is_some_and(|s| Arc::ptr_eq(s, &snap)) {
            return false;
        }
        let rgba = self.state.display_rgba(&snap);
        let image =
            egui::ColorImage::from_rgba_unmultiplied([snap.width as usize, snap.height as usize], rgba.as_flattened());
        match &mut self.ui.texture {
            Some(t) => t.set(image, egui::TextureOptions::LINEAR),
            None => self.ui.texture = Some(self.egui.load_texture("render", image, egui::TextureOptions::LINEAR)),
        }
        self.ui.shown = Some(snap);
        true
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) {
        let start = Instant::now();
        self.state.poll_loading();
        self.update_image();
        let Some((window, gpu, egui_state)) = &mut self.window else { return };
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
        if let Some(path) = self.screenshot.clone() {
            self.finish_screenshot(event_loop, &path);
        }
    }

    /// In --screenshot mode: once the target is reached and shown, save and exit.
    fn finish_screenshot(&mut self, event_loop: &ActiveEventLoop, path: &std::path::Path) {
        let Some(snap) = self.ui.shown.clone() else { return };
        if !snap.done || snap.generation != self.state.generation() {
            return;
        }
        match self.state.save_images(&snap, path) {
            Ok(()) => {
                let mean_frame = self.frame_time.as_secs_f64() * 1e3 / self.frames.max(1) as f64;
                let latency = self.state.latencies.first().map_or(0.0, |d| d.as_secs_f64() * 1e3);
                println!(
                    "{}: {} spp at {}x{} in {:.2} s: {:.2} Msamples/s, {:.2} Mrays/s, {} NaN/Inf dropped; \
                     {} UI frames, mean {:.1} ms; first image after {:.0} ms; wrote {}",
                    self.state.scene.name,
                    snap.spp,
                    snap.width,
                    snap.height,
                    snap.elapsed.as_secs_f64(),
                    snap.samples_per_second() / 1e6,
                    snap.rays_per_second() / 1e6,
                    snap.rejected,
                    self.frames,
                    mean_frame,
                    latency,
                    path.display()
                );
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
        let attributes = Window::default_attributes()
            .with_title("Lucent")
            .with_inner_size(winit::dpi::LogicalSize::new(1280.0, 800.0));
        let window = match event_loop.create_window(attributes) {
            Ok(w) => Arc::new(w),
            Err(e) => return self.fail(event_loop, format!("cannot open a window: {e}")),
        };
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
            event_loop.owned_display_handle(),
        )));
        let gpu = match Gpu::new(&instance, Arc::clone(&window)) {
            Ok(g) => g,
            Err(e) => return self.fail(event_loop, e),
        };
        eprintln!("viewer: presenting with {}", gpu.adapter);
        let egui_state = egui_winit::State::new(
            self.egui.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            window.theme(),
            Some(gpu.max_texture_side()),
        );
        window.request_redraw();
        self.window = Some((window, gpu, egui_state));
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some((window, gpu, egui_state)) = &mut self.window else { return };
        let response = egui_state.on_window_event(window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                gpu.resize(size.width, size.height);
                window.request_redraw();
            }
            WindowEvent::DroppedFile(path) => {
                self.state.open(path);
                window.request_redraw();
            }
            WindowEvent::RedrawRequested => self.frame(event_loop),
            _ => {
                if response.repaint {
                    window.request_redraw();
                }
            }
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let Some((window, _, _)) = &self.window else { return };
        let newer =
            self.state.snapshot().is_some_and(|s| self.ui.shown.as_ref().is_none_or(|shown| !Arc::ptr_eq(shown, &s)));
        let due = self.repaint_at.is_some_and(|t| t <= Instant::now());
        if newer || due || self.state.loading_status().is_some() {
            window.request_redraw();
        }
        let next = Instant::now() + POLL;
        let wake = self.repaint_at.map_or(next, |t| t.min(next));
        event_loop.set_control_flow(ControlFlow::WaitUntil(wake));
    }
}

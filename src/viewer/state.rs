//! The viewer's state apart from the window: scene, render session, view, editors, file
//! loading, screenshots and the denoiser. Plain data around the session, so its logic is
//! tested headless.
//! The UI edits fields freely; `sync` turns any change into a restart of accumulation.

use super::camera_control::CameraController;
use super::compare::{Compare, CompareMode, Pin, PinInfo};
use super::convergence::{self, ConvergenceLog};
use super::denoise::Denoiser;
use super::histogram::AutoExposure;
use super::inspect::Probes;
use super::progress::{Progress, Target, progress};
use crate::config::ViewFile;
use crate::film::false_colour;
use crate::film::output::{replace_file, write_image};
use crate::film::tonemap::Display;
use crate::integrator::Settings;
use crate::loader::save;
use crate::open::{OpenOptions, Stage, open};
use crate::render::{Job, RenderSession, Snapshot};
use crate::scene::{
    Scene,
    camera::Camera,
    environment::{BUILT_IN, EnvMap, EnvSettings, Environment},
    light::PunctualLight,
    material::Material,
};
use glam::{UVec2, Vec2, Vec3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::{Arc, Weak, atomic::AtomicBool, atomic::Ordering};
use std::time::{Duration, Instant};

/// Whether jobs ask for the denoiser's AOVs: whenever the library is found, so that
/// toggling it on shows the image accumulated so far instead of restarting.
fn want_aovs() -> bool {
    crate::film::denoise::available().is_ok()
}

/// Divisor of the resolution while the camera moves: a pass at 1/64 of the pixels shows a
/// first image within a frame. Once the camera stops, each level's first image halves
/// the divisor (1/8, 1/4, 1/2, full), so the view sharpens in steps that cost together a
/// third of one full-resolution pass.
const COARSEST: u32 = 8;

/// What the image area shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ImageView {
    /// The tonemapped image.
    #[default]
    Image,
    /// Each pixel's estimated relative standard error, in false colour.
    Error,
    /// Each pixel's samples, in false colour.
    Spp,
}

/// A scene being loaded on its own thread.
struct Loading {
    path: PathBuf,
    /// The material variant asked for, and whether this reopens the current file in it
    /// (the camera, probes and pin stay).
    variant: (Option<String>, bool),
    building: Arc<AtomicBool>,
    result: Receiver<Result<Scene, String>>,
}

/// What the session is rendering, to notice changes.
#[derive(Clone)]
struct JobKey {
    scene: Arc<Scene>,
    camera: Camera,
    settings: Settings,
}

impl PartialEq for JobKey {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.scene, &other.scene) && self.camera == other.camera && self.settings == other.settings
    }
}

/// Material ids per pixel of one view, for highlighting the selection.
struct IdBuffer {
    key: (UVec2, Camera, usize),
    ids: Vec<u32>,
}

/// Everything the viewer shows and edits.
pub struct ViewerState {
    /// The scene being rendered (replaced, not mutated, by edits).
    pub scene: Arc<Scene>,
    /// Where it came from (None: built in).
    pub source: Option<PathBuf>,
    /// The KHR_materials_variants variant it was opened in (None: its default materials).
    pub variant: Option<String>,
    original: (Vec<Material>, Vec<PunctualLight>),
    session: RenderSession,
    sent: JobKey,
    /// Render settings at full resolution (width/height used when `fixed_size`).
    pub settings: Settings,
    /// Render at `settings.width` x `settings.height` instead of following the window.
    pub fixed_size: bool,
    /// Pixel size of the image area in the window.
    pub viewport: UVec2,
    /// Exposure and tone curve.
    pub display: Display,
    /// The view.
    pub camera: CameraController,
    /// Fly speed in scene units per second.
    pub fly_speed: f32,
    /// The camera is moving: render the coarsest preview (set by the UI).
    pub moving: bool,
    /// Divisor of the resolution now (1: full resolution; see `COARSEST`).
    divisor: u32,
    /// Workers paused.
    pub paused: bool,
    /// Selected material, if any.
    pub selected: Option<u32>,
    /// Whether the selection is outlined in the image (the editor hides it while the
    /// material's widgets are hovered or in use, so that edits can be judged).
    pub show_selection: bool,
    /// Where "Save glTF" writes the scene with its edits.
    pub gltf_path: String,
    /// The last "Save glTF": where it went, or why it failed (shown under the button until
    /// another scene, or the same file in another variant, opens).
    pub gltf_saved: Option<Result<PathBuf, String>>,
    /// The last error, shown until dismissed.
    pub error: Option<String>,
    /// Why the current settings cannot start (shown beside them until they can).
    pub settings_error: Option<String>,
    /// Estimated error against time of this job and the previous ones.
    pub convergence: ConvergenceLog,
    /// The image the convergence log measures (scene with its edits, camera, size) and its
    /// number, bumped when it changes.
    convergence_view: (Option<(Weak<Scene>, Camera, UVec2)>, u64),
    /// What the image area shows: the image, or a false-colour view.
    pub view: ImageView,
    /// The Denoise toggle and its worker.
    pub denoiser: Denoiser,
    /// The last notice (where a screenshot went, ...).
    pub message: Option<String>,
    /// Folder for screenshots (by default beside the scene, see `default_screenshot_dir`).
    pub screenshot_dir: String,
    /// Path typed in the open field.
    pub open_path: String,
    /// Path of the view file to save or load.
    pub view_path: String,
    /// The environment lighting the scene (kept while it is black, to edit it).
    pub environment: EnvSettings,
    /// Environment maps offered in the picker besides none: the built-in sky, the map the
    /// viewer started with, and the .hdr/.exr files in `environment_dir`.
    pub environment_maps: Vec<PathBuf>,
    /// Folder whose maps the picker offers (change it with `set_environment_dir`).
    environment_dir: String,
    /// The map the viewer started with (--env or --view), if it is a file.
    startup_map: Option<PathBuf>,
    /// The last map loaded, reused while only intensity, rotation or background change.
    environment_map: Option<(PathBuf, Arc<EnvMap>)>,
    loading: Option<Loading>,
    restarted: Instant,
    /// Times from a restart to the first image of the new job, and the job's resolution
    /// divisor (1: full resolution).
    pub latencies: Vec<(Duration, u32)>,
    awaiting_first_image: bool,
    ids: Option<IdBuffer>,
    /// Probes pinned on the image.
    pub probes: Probes,
    /// The pinned image and how it is compared with the live one.
    pub compare: Compare,
    /// What the render runs towards.
    pub target: Target,
    /// How auto-exposure chooses the exposure, and whether it keeps adjusting it.
    pub auto_exposure: AutoExposure,
    /// The estimated error of the latest image, by (generation, spp).
    error_seen: Option<((u64, u32), Option<f64>)>,
}

impl ViewerState {
    /// Starts rendering `scene` from `camera` (or the scene's default view).
    pub fn new(
        scene: Scene,
        source: Option<PathBuf>,
        settings: Settings,
        fixed_size: bool,
        display: Display,
        camera: Option<Camera>,
        threads: Option<usize>,
    ) -> Result<Self, String> {
        let scene = Arc::new(scene);
        let viewport = UVec2::new(settings.width, settings.height);
        let controller = controller_for(&scene, camera, settings.width as f32 / settings.height as f32);
        let sent = JobKey { scene: Arc::clone(&scene), camera: controller.camera(), settings };
        let job = Job { scene: Arc::clone(&scene), camera: sent.camera, settings, window: None, aovs: want_aovs() };
        let session = RenderSession::new_yielding(job, threads).map_err(|e| e.to_string())?;
        let screenshot_dir = default_screenshot_dir(source.as_deref()).to_string_lossy().into_owned();
        let fly_speed = 0.25 * scene.radius().max(1e-3);
        let environment = scene.environment.as_ref().map_or_else(EnvSettings::default, |e| e.settings.clone());
        let environment_map =
            scene.environment.as_ref().and_then(|e| Some((e.settings.map.clone()?, e.map()?.clone())));
        let startup_map = environment.map.clone().filter(|m| m != Path::new(BUILT_IN));
        let environment_dir = match startup_map.as_deref().and_then(Path::parent) {
            Some(dir) if !dir.as_os_str().is_empty() => dir.to_string_lossy().into_owned(),
            _ => ".".into(),
        };
        Ok(Self {
            original: (scene.materials.clone(), scene.lights.clone()),
            scene,
            session,
            sent,
            settings,
            fixed_size,
            viewport,
            display,
            camera: controller,
            fly_speed,
            moving: false,
            divisor: 1,
            paused: false,
            selected: None,
            show_selection: true,
            gltf_path: save::default_path(source.as_deref()).display().to_string(),
            gltf_saved: None,
            error: None,
            settings_error: None,
            convergence: ConvergenceLog::default(),
            convergence_view: (None, 0),
            view: ImageView::Image,
            denoiser: Denoiser::default(),
            message: None,
            screenshot_dir,
            open_path: String::new(),
            view_path: "view.toml".into(),
            environment,
            environment_maps: environment_maps(startup_map.as_deref(), Path::new(&environment_dir)),
            environment_dir,
            startup_map,
            environment_map,
            source,
            variant: None,
            loading: None,
            restarted: Instant::now(),
            latencies: Vec::new(),
            awaiting_first_image: true,
            ids: None,
            probes: Probes::default(),
            compare: Compare::default(),
            target: Target::default(),
            auto_exposure: AutoExposure::default(),
            error_seen: None,
        })
    }

    /// The settings at full resolution: the fixed size, or the image area's, letterboxed to
    /// the camera's frame if it has one (`render_size`).
    fn effective_settings_full(&self) -> Settings {
        self.settings_for(self.camera.aspect)
    }

    /// The settings at full resolution for a camera whose frame has aspect `frame`.
    fn settings_for(&self, frame: Option<f32>) -> Settings {
        let mut s = self.settings;
        if !self.fixed_size {
            let size = render_size(self.viewport, frame);
            (s.width, s.height) = (size.x, size.y);
        }
        s
    }

    /// Renders the next images from the coarsest preview up, as after a camera move: the
    /// window opens a scene this way, so that its first image comes within a frame instead
    /// of after a whole full-resolution pass.
    pub fn sharpen_from_coarsest(&mut self) {
        self.divisor = COARSEST;
    }

    /// Whether a reduced-resolution preview is rendered (the camera moves, or the view is
    /// still sharpening after it stopped).
    pub fn previewing(&self) -> bool {
        self.moving || self.divisor > 1
    }

    /// The settings actually rendered: full resolution, or reduced while the camera moves
    /// and while the preview sharpens after it stopped.
    pub fn effective_settings(&self) -> Settings {
        let mut s = self.effective_settings_full();
        let divisor = if self.moving { COARSEST } else { self.divisor };
        if divisor > 1 {
            s.width = s.width.div_ceil(divisor);
            s.height = s.height.div_ceil(divisor);
            s.target_spp = None;
        }
        s
    }

    /// Sends the current scene, camera and settings to the session if anything changed
    /// (restarting accumulation), and applies pause (the user's, or a time or error target
    /// reached). Returns whether it restarted.
    pub fn sync(&mut self) -> bool {
        if self.moving {
            self.divisor = COARSEST;
        }
        let restarted = self.send_job();
        let reached = self.progress().is_some_and(|p| p.reached);
        self.session.set_paused(self.paused || reached);
        restarted
    }

    /// How far the current full-resolution job is towards the target (None while
    /// previewing, before its first image, or without a target).
    pub fn progress(&mut self) -> Option<Progress> {
        let snap = self.session.snapshot().filter(|_| !self.previewing())?;
        let key = (snap.generation, snap.spp);
        let error = match self.error_seen {
            Some((seen, error)) if seen == key => error,
            _ => {
                let error = snap.relative_error();
                self.error_seen = Some((key, error));
                error
            }
        };
        progress(&self.target, self.sent.settings.target_spp, snap.spp, snap.elapsed.as_secs_f64(), error)
    }

    /// Sends the job if it changed; returns whether it did.
    fn send_job(&mut self) -> bool {
        let want = JobKey {
            scene: Arc::clone(&self.scene),
            camera: self.camera.camera(),
            settings: self.effective_settings(),
        };
        if want == self.sent {
            return false;
        }
        let job = Job {
            scene: Arc::clone(&want.scene),
            camera: want.camera,
            settings: want.settings,
            window: None,
            aovs: want_aovs(),
        };
        match self.session.set_job(job) {
            Ok(_) => {
                self.settings_error = None;
                self.sent = want;
                self.restarted = Instant::now();
                self.awaiting_first_image = true;
                true
            }
            Err(e) => {
                self.settings_error = Some(e.to_string());
                false
            }
        }
    }

    /// The generation of the job being rendered.
    pub fn generation(&self) -> u64 {
        self.session.generation()
    }

    /// The latest image of the current job, if one pass has completed. The first image of
    /// a preview level, once the camera stopped, moves on to the next finer level (at the
    /// next `sync`).
    pub fn snapshot(&mut self) -> Option<Arc<Snapshot>> {
        let snap = self.session.snapshot();
        if snap.is_some() && self.awaiting_first_image {
            self.awaiting_first_image = false;
            let divisor = self.effective_settings_full().width as f32 / self.sent.settings.width.max(1) as f32;
            self.latencies.push((self.restarted.elapsed(), (divisor.round() as u32).next_power_of_two()));
        }
        if snap.is_some() && !self.moving && self.divisor > 1 && self.sent.settings == self.effective_settings() {
            self.divisor /= 2;
        }
        snap
    }

    /// Waits up to `timeout` for an image newer than `seen`.
    pub fn wait_for_update(&self, seen: Option<&Arc<Snapshot>>, timeout: Duration) -> Option<Arc<Snapshot>> {
        self.session.wait_for_update(seen, timeout)
    }

    /// Starts loading a glTF file on a background thread; the current scene keeps rendering.
    pub fn open(&mut self, path: PathBuf) {
        self.load(path, None, false);
    }

    /// Reopens the current file in KHR_materials_variants variant `variant` (None: the
    /// default materials), keeping the view; material edits not saved are dropped.
    pub fn open_variant(&mut self, variant: Option<String>) {
        if let Some(path) = self.source.clone() {
            self.load(path, variant, true);
        }
    }

    fn load(&mut self, path: PathBuf, variant: Option<String>, same_file: bool) {
        let (tx, rx) = std::sync::mpsc::channel();
        let building = Arc::new(AtomicBool::new(false));
        let (p, b, v) = (path.clone(), Arc::clone(&building), variant.clone());
        std::thread::spawn(move || {
            let mut progress = |stage| b.store(stage == Stage::Building, Ordering::Relaxed);
            let _ = tx.send(open(Some(&p), &OpenOptions { variant: v, ..OpenOptions::default() }, &mut progress));
        });
        self.error = None;
        self.loading = Some(Loading { path, variant: (variant, same_file), building, result: rx });
    }

    /// What is being loaded and its stage, for the progress display.
    pub fn loading_status(&self) -> Option<String> {
        self.loading.as_ref().map(|l| {
            let stage = if l.building.load(Ordering::Relaxed) { "building the BVH" } else { "reading" };
            format!("loading {} ({stage})", l.path.display())
        })
    }

    /// Takes a finished load: a new scene replaces the old one, an error is shown and the
    /// old scene stays. Returns true when a load finished.
    pub fn poll_loading(&mut self) -> bool {
        let Some(loading) = &self.loading else { return false };
        let result = match loading.result.try_recv() {
            Ok(r) => r,
            Err(TryRecvError::Empty) => return false,
            Err(TryRecvError::Disconnected) => Err(format!("loading {} stopped unexpectedly", loading.path.display())),
        };
        let path = loading.path.clone();
        let (variant, same_file) = loading.variant.clone();
        self.loading = None;
        match result {
            Ok(scene) => {
                // An environment the user chose lights the new scene too; the default sky of
                // a scene without light of its own does not (the new one may have lights).
                let scene = match &self.scene.environment {
                    Some(env) if !self.lit_by_default() => scene.with_environment(Some(env.clone())),
                    _ => scene,
                };
                self.environment = scene.environment.as_ref().map_or_else(EnvSettings::default, |e| e.settings.clone());
                let scene = Arc::new(scene);
                self.variant = variant;
                self.original = (scene.materials.clone(), scene.lights.clone());
                self.gltf_saved = None;
                if same_file {
                    self.scene = scene;
                    self.selected = None;
                    return true;
                }
                let aspect = self.free_aspect();
                self.camera = controller_for(&scene, None, aspect);
                self.divisor = COARSEST;
                self.fly_speed = 0.25 * scene.radius().max(1e-3);
                self.message = (!scene.warnings.is_empty()).then(|| scene.warnings.join("; "));
                if Path::new(&self.screenshot_dir) == default_screenshot_dir(self.source.as_deref()) {
                    self.screenshot_dir = default_screenshot_dir(Some(&path)).to_string_lossy().into_owned();
                }
                self.scene = scene;
                self.gltf_path = save::default_path(Some(&path)).display().to_string();
                self.source = Some(path);
                self.convergence.clear();
                self.selected = None;
                self.probes.clear();
                self.load_pin();
            }
            Err(e) => self.error = Some(e),
        }
        true
    }

    /// Whether the built-in sky lights the scene because it has no light of its own (and
    /// the user has not chosen another environment).
    pub fn lit_by_default(&self) -> bool {
        self.environment == EnvSettings::built_in() && !self.scene.has_own_light()
    }

    /// Aspect ratio of the rendered image.
    pub fn aspect(&self) -> f32 {
        let s = self.effective_settings();
        s.width as f32 / s.height as f32
    }

    /// Aspect ratio of the image of a camera without a frame of its own (the image area's,
    /// or the fixed size's), for framing the scene.
    fn free_aspect(&self) -> f32 {
        let s = self.settings_for(None);
        s.width as f32 / s.height as f32
    }

    /// Applies an edit to the materials and lights: the BVH is kept, accumulation restarts,
    /// and the split's divider moves onto the selection (`place_divider`).
    pub fn edit(&mut self, f: impl FnOnce(&mut Vec<Material>, &mut Vec<PunctualLight>)) {
        let (mut materials, mut lights) = (self.scene.materials.clone(), self.scene.lights.clone());
        f(&mut materials, &mut lights);
        if materials != self.scene.materials || lights != self.scene.lights {
            self.scene = Arc::new(self.scene.with_edits(materials, lights));
            self.place_divider();
        }
    }

    /// In the split, until the user moves the divider, puts it through the middle of the
    /// selected material's columns, so that an edited object shows before (left) and after
    /// (right) side by side, whichever half of the image it is in.
    pub fn place_divider(&mut self) {
        if self.compare.mode() != CompareMode::Split || self.compare.divider_moved {
            return;
        }
        if let Some(u) = self.selected.and_then(|m| self.material_columns(m)) {
            self.compare.view.split = 0.5 * (u.0 + u.1);
        }
    }

    /// The leftmost and rightmost image column ([0, 1]) where material `material` is seen,
    /// from a grid of 64 x 64 primary rays (None: not seen).
    fn material_columns(&self, material: u32) -> Option<(f32, f32)> {
        const GRID: u32 = 64;
        let s = self.effective_settings();
        let size = Vec2::new(s.width as f32, s.height as f32);
        let rays = self.camera.camera().rays(s.width, s.height);
        let geometry = &self.scene.geometry;
        (0..GRID * GRID)
            .into_par_iter()
            .filter_map(|i| {
                let uv = (Vec2::new((i % GRID) as f32, (i / GRID) as f32) + 0.5) / GRID as f32;
                let hit = geometry.intersect(&rays.ray(uv * size))?;
                (geometry.attrs(hit.tri).material == material).then_some((uv.x, uv.x))
            })
            .reduce_with(|a, b| (a.0.min(b.0), a.1.max(b.1)))
    }

    /// Lights the scene with `settings`. A map is read only when its path changes; on error
    /// (a missing or unreadable map, a bad value) the old environment stays.
    pub fn set_environment(&mut self, settings: EnvSettings) -> Result<(), String> {
        if settings == self.environment {
            return Ok(());
        }
        settings.validate()?;
        let map = match &settings.map {
            None => None,
            Some(path) => match &self.environment_map {
                Some((p, map)) if p == path => Some(Arc::clone(map)),
                _ => {
                    let map = Arc::new(EnvMap::load(path)?);
                    self.environment_map = Some((path.clone(), Arc::clone(&map)));
                    Some(map)
                }
            },
        };
        let env = Environment::with_map(settings.clone(), map);
        self.scene = Arc::new(self.scene.with_environment(Some(env)));
        self.environment = settings;
        Ok(())
    }

    /// The folder whose .hdr and .exr files the picker offers.
    pub fn environment_dir(&self) -> &str {
        &self.environment_dir
    }

    /// Offers the maps in `dir` instead, rescanning if it changed.
    pub fn set_environment_dir(&mut self, dir: String) {
        if dir != self.environment_dir {
            self.environment_maps = environment_maps(self.startup_map.as_deref(), Path::new(&dir));
            self.environment_dir = dir;
        }
    }

    /// Restores the materials and lights as the file has them.
    pub fn reset_edits(&mut self) {
        let (m, l) = self.original.clone();
        self.edit(|materials, lights| {
            *materials = m;
            *lights = l;
        });
    }

    /// Whether materials or lights differ from the file.
    pub fn edited(&self) -> bool {
        self.scene.materials != self.original.0 || self.scene.lights != self.original.1
    }

    /// The materials and lights as the file has them.
    pub fn original(&self) -> (&[Material], &[PunctualLight]) {
        (&self.original.0, &self.original.1)
    }

    /// Makes the materials and lights the file's with a view file's edits applied; on
    /// error (a material it names is not in the scene, a bad value) nothing changes.
    pub fn apply_edits(&mut self, view: &ViewFile) -> Result<(), String> {
        let (mut materials, mut lights) = self.original.clone();
        view.apply_edits(&mut materials, &mut lights)?;
        self.edit(|m, l| {
            *m = materials;
            *l = lights;
        });
        Ok(())
    }

    /// Writes the scene's file with the edited materials and lights to `gltf_path` (through
    /// a temporary file, so a failure leaves nothing); returns where it went.
    pub fn save_gltf(&self) -> Result<PathBuf, String> {
        let out = PathBuf::from(self.gltf_path.trim());
        let edits = save::Edits { original: self.original(), edited: (&self.scene.materials, &self.scene.lights) };
        let bytes = save::patched(self.source.as_deref(), edits, &out)?;
        replace_file(&out, |tmp| std::fs::write(tmp, &bytes)).map_err(|e| e.to_string())?;
        Ok(out)
    }

    /// Puts the camera back to the file's camera `index`, or the default view.
    pub fn reset_camera(&mut self, index: Option<usize>) {
        let aspect = self.free_aspect();
        let camera = index.and_then(|i| self.scene.cameras.get(i)).map(|(_, c)| *c);
        self.camera = controller_for(&self.scene, camera, aspect);
    }

    /// What each of the file's cameras frames, in the order of `scene.cameras`
    /// (`camera_subject`).
    pub fn camera_subjects(&self) -> Vec<String> {
        self.scene.cameras.iter().map(|(_, camera)| camera_subject(&self.scene, camera)).collect()
    }

    /// The material seen through image position `uv` ([0, 1]^2, top-left origin).
    pub fn pick(&self, uv: Vec2) -> Option<u32> {
        let s = self.effective_settings();
        let ray = self.camera.camera().rays(s.width, s.height).ray(uv * Vec2::new(s.width as f32, s.height as f32));
        let hit = self.scene.geometry.intersect(&ray)?;
        Some(self.scene.geometry.attrs(hit.tri).material)
    }

    /// Logs a shown image's estimated error, if it is a full-resolution one (previews
    /// during camera motion are not part of the job's convergence). Curves are compared
    /// on one image: another scene, edit, camera or size starts the log over.
    pub fn record_convergence(&mut self, snap: &Snapshot) {
        let full = self.effective_settings_full();
        if snap.width != full.width || snap.height != full.height {
            return;
        }
        let size = UVec2::new(snap.width, snap.height);
        let (seen, number) = &mut self.convergence_view;
        let same = seen.as_ref().is_some_and(|(scene, camera, s)| {
            std::ptr::eq(scene.as_ptr(), Arc::as_ptr(&self.sent.scene)) && *camera == self.sent.camera && *s == size
        });
        if !same {
            *seen = Some((Arc::downgrade(&self.sent.scene), self.sent.camera, size));
            *number += 1;
        }
        self.convergence.record(snap, &convergence::label(&self.sent.settings), *number);
    }

    /// Hands the latest snapshot to the denoiser if it is due, and takes its result; true
    /// when a new result arrived. Never waits.
    pub fn poll_denoiser(&mut self) -> bool {
        let snap = self.session.snapshot();
        self.denoiser.poll(snap.as_ref())
    }

    /// The selected material, while it is outlined.
    pub fn highlighted(&self) -> Option<u32> {
        self.selected.filter(|_| self.show_selection)
    }

    /// Tonemaps a snapshot to RGBA8 for display (its denoised image when the toggle is on and
    /// one of this job is ready), outlining the selected material's pixels (those with a
    /// neighbour, or the image's edge, outside it; its inside is left as it renders); or the
    /// false colour of each pixel's relative standard error or of its samples; or, comparing
    /// with a pin of its size, their composition (`compare::compose`).
    pub fn display_rgba(&mut self, snap: &Snapshot) -> Vec<[u8; 4]> {
        match self.view {
            ImageView::Image => {}
            ImageView::Error => {
                return (0..snap.mean.len())
                    .map(|i| false_colour::error_colour(snap.pixel_relative_error(i).unwrap_or(0.0) as f32))
                    .collect();
            }
            ImageView::Spp => {
                let range = false_colour::spp_range(&snap.pixel_spp, snap.spp);
                return (0..snap.mean.len()).map(|i| false_colour::spp_colour(snap.pixel_spp(i), range)).collect();
            }
        }
        let live = self.denoiser.shown(snap).map_or(&snap.mean, |d| &d.image);
        if let Some(rgba) = self.compare.rgba(live, snap.width, snap.height, &self.display) {
            return rgba;
        }
        let selected = self.highlighted();
        if selected.is_some() {
            self.update_material_ids(snap);
        }
        let mask = selected.zip(self.ids.as_ref().map(|b| &b.ids));
        let (w, h) = (snap.width as usize, snap.height as usize);
        let edge = |m: u32, ids: &[u32], i: usize| {
            let (x, y) = (i % w, i / w);
            let outside = |x: usize, y: usize| ids.get(y * w + x) != Some(&m);
            x == 0
                || y == 0
                || x + 1 == w
                || y + 1 == h
                || outside(x - 1, y)
                || outside(x + 1, y)
                || outside(x, y - 1)
                || outside(x, y + 1)
        };
        self.denoiser
            .shown(snap)
            .map_or(&snap.mean, |d| &d.image)
            .iter()
            .enumerate()
            .map(|(i, &p)| match &mask {
                Some((m, ids)) if ids.get(i) == Some(m) && edge(*m, ids, i) => [255, 170, 40, 255],
                _ => {
                    let [r, g, b] = self.display.to_srgb8(p);
                    [r, g, b, 255]
                }
            })
            .collect()
    }

    /// Material ids of the snapshot's pixels (primary rays through pixel centres), cached per view.
    fn update_material_ids(&mut self, snap: &Snapshot) {
        let key = (UVec2::new(snap.width, snap.height), self.sent.camera, Arc::as_ptr(&self.scene) as usize);
        if self.ids.as_ref().is_none_or(|b| b.key != key) {
            let rays = key.1.rays(snap.width, snap.height);
            let scene = &self.scene;
            let ids = (0..snap.width * snap.height)
                .into_par_iter()
                .map(|i| {
                    let film = Vec2::new((i % snap.width) as f32 + 0.5, (i / snap.width) as f32 + 0.5);
                    scene.geometry.intersect(&rays.ray(film)).map_or(u32::MAX, |h| scene.geometry.attrs(h.tri).material)
                })
                .collect();
            self.ids = Some(IdBuffer { key, ids });
        }
    }

    /// Saves the latest image as `<scene>-<spp>spp.png` (tonemapped) and `.exr` (linear)
    /// in the screenshot folder; with a denoised image of this job shown, that image's
    /// snapshot, denoised in the PNG and `.denoised.exr`. Returns the PNG's path.
    pub fn screenshot(&mut self) -> Result<PathBuf, String> {
        let latest = self.snapshot().ok_or("nothing rendered yet")?;
        let snap = self.denoiser.shown(&latest).map_or(latest, |d| Arc::clone(&d.source));
        let name = format!("{}-{}spp.png", self.scene.name, snap.spp);
        let dir = Path::new(&self.screenshot_dir);
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let path = dir.join(name);
        self.save_images(&snap, &path)?;
        Ok(path)
    }

    /// Writes `png` (tonemapped) and the same path with .exr (linear) from `snap`; when its
    /// denoised image is shown, the PNG is that image and `.denoised.exr` holds it too,
    /// while the `.exr` stays the noisy one.
    pub fn save_images(&self, snap: &Snapshot, png: &Path) -> Result<(), String> {
        let (w, h) = (snap.width, snap.height);
        let write =
            |path: &Path, pixels: &[Vec3]| write_image(path, w, h, pixels, &self.display).map_err(|e| e.to_string());
        let denoised = self.denoiser.shown(snap).filter(|d| d.source.spp == snap.spp);
        write(png, denoised.map_or(&snap.mean, |d| &d.image))?;
        write(&png.with_extension("exr"), &snap.mean)?;
        match denoised {
            Some(d) => write(&png.with_extension("denoised.exr"), &d.image),
            None => Ok(()),
        }
    }

    /// Pins the latest image for before/after comparison (showing the split if only the
    /// live image was shown) and saves it in the pin store, where the next start finds it.
    /// The pin is kept in memory even if it cannot be saved.
    pub fn pin_image(&mut self) -> Result<(), String> {
        let snap = self.snapshot().ok_or("nothing rendered yet")?;
        let mut label = convergence::label(&self.sent.settings);
        if self.edited() {
            label.push_str(", materials or lights edited");
        }
        let info =
            PinInfo { scene: self.scene.name.clone(), spp: snap.spp, seconds: snap.elapsed.as_secs_f64(), label };
        let pin = Pin { width: snap.width, height: snap.height, pixels: snap.mean.clone(), info };
        if self.compare.view.mode == CompareMode::Live {
            self.compare.view.mode = CompareMode::Split;
        }
        let saved = self.compare.store.as_ref().map(|store| store.save(self.source.as_deref(), &pin));
        let file = saved.as_ref().and_then(|s| s.as_ref().ok()).cloned();
        self.compare.set_pin(Some(pin), file);
        self.place_divider();
        saved.transpose().map(|_| ()).map_err(|e| format!("pinned in memory only: {e}"))
    }

    /// Drops the pinned image, from the pin store too.
    pub fn unpin(&mut self) -> Result<(), String> {
        self.compare.set_pin(None, None);
        self.compare.store.as_ref().map_or(Ok(()), |store| store.forget(self.source.as_deref()))
    }

    /// Takes the image the pin store holds for the current scene, if any (an unreadable
    /// one is reported and left alone).
    pub fn load_pin(&mut self) {
        let Some(store) = &self.compare.store else { return };
        match store.load(self.source.as_deref()) {
            Ok(pin) => {
                let file = pin.as_ref().map(|_| store.path_for(self.source.as_deref()));
                self.compare.set_pin(pin, file);
            }
            Err(e) => {
                self.compare.set_pin(None, None);
                self.error = Some(e);
            }
        }
    }

    /// Pins a linear image file (a reference render, an earlier pin) and shows the split.
    pub fn compare_with(&mut self, path: &Path) -> Result<(), String> {
        let pin = Pin::read(path)?;
        self.compare.set_pin(Some(pin), Some(path.to_path_buf()));
        self.compare.view.mode = CompareMode::Split;
        Ok(())
    }

    /// Sets the exposure by auto-exposure from `snap`, if it keeps adjusting.
    pub fn auto_expose(&mut self, snap: &Snapshot) {
        if self.auto_exposure.continuous {
            self.display.exposure = self.auto_exposure.adjust(self.display.exposure, &snap.mean);
        }
    }

    /// Saves camera, settings, display, environment and the material and light edits to `view_path`.
    pub fn save_view(&self) -> Result<(), String> {
        let mut view = ViewFile {
            camera: Some(self.camera.camera()),
            settings: self.effective_settings_full(),
            display: self.display,
            environment: self.environment.clone(),
            ..ViewFile::default()
        };
        view.record_edits(self.original(), (&self.scene.materials, &self.scene.lights));
        view.save(Path::new(&self.view_path))
    }

    /// Loads camera, settings, display, environment and the material and light edits from
    /// `view_path` (the resolution keeps following the window unless it is fixed).
    pub fn load_view(&mut self) -> Result<(), String> {
        let view = ViewFile::load(Path::new(&self.view_path))?;
        // Whether to go over the ray budget is the user's choice here, not the file's.
        let settings = Settings { allow_expensive: self.settings.allow_expensive, ..view.settings };
        settings.validate().map_err(|e| format!("{}: {e}", self.view_path))?;
        self.apply_edits(&view)?;
        let aspect = self.free_aspect();
        if let Some(cam) = view.camera {
            self.camera = controller_for(&self.scene, Some(cam), aspect);
        }
        self.settings = settings;
        self.display = view.display;
        self.set_environment(view.environment)
    }
}

/// The full-resolution size rendered in an image area of `area` pixels: all of it, or for a
/// camera whose frame has aspect `frame` (width over height), the largest rectangle of that
/// aspect inside it, so that the frame is shown whole, letterboxed, instead of cropped.
pub fn render_size(area: UVec2, frame: Option<f32>) -> UVec2 {
    let area = area.clamp(UVec2::ONE, UVec2::splat(16384));
    let Some(aspect) = frame.filter(|a| a.is_finite() && *a > 0.0) else { return area };
    let (w, h) = (area.x as f32, area.y as f32);
    let size = if w / h > aspect { (h * aspect, h) } else { (w, w / aspect) };
    UVec2::new(size.0.round() as u32, size.1.round() as u32).clamp(UVec2::ONE, area)
}

/// Where screenshots go unless the user chooses: the scene's folder if it is writable,
/// else the user's pictures folder (XDG's, or ~/Pictures; its `Lucent` subfolder), else the
/// current folder.
pub fn default_screenshot_dir(scene: Option<&Path>) -> PathBuf {
    let writable = |dir: &Path| {
        let probe = dir.join(format!(".lucent-probe-{}", std::process::id()));
        std::fs::write(&probe, b"").and_then(|()| std::fs::remove_file(&probe)).is_ok()
    };
    scene
        .and_then(Path::parent)
        .map(|d| if d.as_os_str().is_empty() { Path::new(".") } else { d })
        .filter(|d| writable(d))
        .map(Path::to_path_buf)
        .or_else(|| {
            dirs::picture_dir().or_else(|| dirs::home_dir().map(|h| h.join("Pictures"))).map(|d| d.join("Lucent"))
        })
        .unwrap_or_else(|| PathBuf::from("."))
}

/// The maps to offer: the built-in sky, `startup` (if any), then the .hdr and .exr files in
/// `dir`, sorted (none if it cannot be read), each file once.
fn environment_maps(startup: Option<&Path>, dir: &Path) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("hdr") || e.eq_ignore_ascii_case("exr")))
        .collect();
    found.sort();
    let same = |a: &Path, b: &Path| {
        a == b || std::fs::canonicalize(a).is_ok_and(|a| std::fs::canonicalize(b).is_ok_and(|b| a == b))
    };
    let mut maps = vec![PathBuf::from(BUILT_IN)];
    maps.extend(startup.map(Path::to_path_buf));
    maps.extend(found.into_iter().filter(|p| startup.is_none_or(|s| !same(s, p))));
    maps
}

/// What `camera` frames, for the camera list: the materials covering most of its frame,
/// largest share first, from a grid of 16 rows of primary rays in the frame's aspect (at
/// most two, each over 5% of the rays; "background only" when no ray hits). 256 rays: cheap
/// enough to run whenever the list is open, unlike a thumbnail render.
pub fn camera_subject(scene: &Scene, camera: &Camera) -> String {
    const ROWS: u32 = 16;
    let aspect = camera.aspect.filter(|a| a.is_finite() && *a > 0.0).unwrap_or(1.0);
    let (w, h) = (((ROWS as f32 * aspect).round() as u32).clamp(1, 4 * ROWS), ROWS);
    let rays = camera.rays(w, h);
    let mut counts = vec![0u32; scene.materials.len()];
    for i in 0..w * h {
        let film = Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
        if let Some(hit) = scene.geometry.intersect(&rays.ray(film))
            && let Some(c) = counts.get_mut(scene.geometry.attrs(hit.tri).material as usize)
        {
            *c += 1;
        }
    }
    let mut seen: Vec<(usize, u32)> = counts.into_iter().enumerate().filter(|(_, c)| 20 * c > w * h).collect();
    seen.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let parts: Vec<String> = seen
        .iter()
        .take(2)
        .map(|&(m, c)| {
            let name = &scene.materials[m].name;
            let name = if name.is_empty() { format!("material {m}") } else { name.clone() };
            format!("{name} {:.0}%", 100.0 * c as f32 / (w * h) as f32)
        })
        .collect();
    if parts.is_empty() { "background only".into() } else { parts.join(", ") }
}

/// A controller for `camera` (or the scene's default view), orbiting the scene's centre depth.
fn controller_for(scene: &Scene, camera: Option<Camera>, aspect: f32) -> CameraController {
    let camera = camera.unwrap_or_else(|| scene.default_camera(aspect));
    let centre = 0.5 * (scene.bounds.0 + scene.bounds.1);
    let forward = camera.rotation * -Vec3::Z;
    let depth = (centre - camera.position).dot(forward);
    let distance = if depth > 0.0 { depth } else { scene.radius().max(1e-3) };
    CameraController::from_camera(&camera, distance)
}

//! A render session: a coordinator thread runs passes over the film's tiles on a rayon pool
//! (each worker owns whole tiles, so the add path takes no lock), publishes a snapshot
//! after every pass, and restarts at once when a new job bumps the generation. A job may ask
//! for the denoiser's albedo and normal images too (AOVs), which leave its radiance unchanged.
//! With a noise threshold, each tile checks its pixels itself at fixed sample counts inside
//! the passes (`film::adaptive`), so which pixels stop depends neither on the pass sizes,
//! which follow the timing, nor on the thread count.

use crate::film::adaptive::{self, ErrorEstimate, LUMINANCE, LUMINANCE_FLOOR};
use crate::film::{AovImages, Film, TILE_SIZE, Tile, splat::Splats, window::Window};
use crate::integrator::kernel::Splat;
use crate::integrator::photons::{LightVertex, Photons};
use crate::integrator::{Context, Integrator, PathOutput, Settings, View, sample_pixels, settings::InvalidSettings};
use crate::memory::{Limits, format_bytes};
use crate::scene::{Scene, camera::Camera};
use crate::spectrum::Spectrum;
use glam::{UVec2, Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What to render: a scene, a camera and settings. Replacing it restarts accumulation.
#[derive(Clone)]
pub struct Job {
    /// The scene (shared, immutable).
    pub scene: Arc<Scene>,
    /// The view.
    pub camera: Camera,
    /// Integrator and film settings.
    pub settings: Settings,
    /// The part of the frame to render (`None`: all of it).
    pub window: Option<Window>,
    /// Also accumulate the denoiser's albedo and normal images (not image-defining: the
    /// radiance is the same bits either way).
    pub aovs: bool,
}

impl Job {
    /// The pixels rendered: the window, or the whole frame.
    pub fn window(&self) -> Window {
        self.window.unwrap_or(Window::full(self.settings.width, self.settings.height))
    }
}

/// The state of the image (of the job's window) at the end of a pass.
#[derive(Clone, Debug)]
pub struct Snapshot {
    /// Generation of the job this image belongs to.
    pub generation: u64,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major mean radiance per pixel.
    pub mean: Vec<Vec3>,
    /// Row-major estimated variance of each pixel's mean, per channel (see `estimate`).
    pub variance: Vec<Vec3>,
    /// Mean albedo and normal images, if the job asked for them.
    pub aovs: Option<AovImages>,
    /// Row-major estimated variance of each pixel's mean luminance, covariance between
    /// channels included; with a noise threshold only (empty otherwise).
    pub luminance_variance: Vec<f32>,
    /// How the variances were estimated, and whether that is honest.
    pub estimate: ErrorEstimate,
    /// Samples per pixel accumulated (by the pixels still taking samples).
    pub spp: u32,
    /// Row-major samples each pixel took, with a noise threshold (empty otherwise: `spp` each).
    pub pixel_spp: Vec<u32>,
    /// Pixels still taking samples.
    pub active: u64,
    /// Time spent rendering this generation (pauses excluded).
    pub elapsed: Duration,
    /// Pixel samples taken (including rejected ones).
    pub samples: u64,
    /// Rays traced (camera, bounce and shadow).
    pub rays: u64,
    /// Samples dropped for being NaN or infinite.
    pub rejected: u64,
    /// Whether the target spp is reached.
    pub done: bool,
    /// The film's sums, in the last snapshot of a render to a target (for pieces).
    pub film: Option<Arc<Film>>,
}

impl Snapshot {
    /// Pixel samples per second of render time.
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }

    /// Rays per second of render time.
    pub fn rays_per_second(&self) -> f64 {
        self.rays as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }

    /// One line of figures: spp, size, time, samples/s, rays/s and NaN/Inf samples dropped.
    pub fn summary(&self, scene: &str) -> String {
        format!(
            "{scene}: {} spp at {}x{} in {:.3} s: {:.3} Msamples/s, {:.2} Mrays/s, {} NaN/Inf samples dropped",
            self.spp,
            self.width,
            self.height,
            self.elapsed.as_secs_f64(),
            self.samples_per_second() / 1e6,
            self.rays_per_second() / 1e6,
            self.rejected
        )
    }

    /// Estimated remaining noise: the mean over lit pixels of `pixel_relative_error`.
    /// None before two samples per pixel.
    pub fn relative_error(&self) -> Option<f64> {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for e in (0..self.mean.len()).filter_map(|i| self.pixel_relative_error(i)) {
            sum += e;
            n += 1;
        }
        (self.spp >= 2 && n > 0).then(|| sum / n as f64)
    }

    /// Relative standard error of pixel `i`'s luminance, relative to its luminance or
    /// `LUMINANCE_FLOOR`, whichever is larger, as the noise threshold measures it; without a
    /// threshold the luminance variance is taken as sum w_c^2 var_c, ignoring the covariance
    /// between channels. None for unlit pixels and while the error is unknown.
    pub fn pixel_relative_error(&self, i: usize) -> Option<f64> {
        let m = self.mean[i];
        let lum: f64 = (0..3).map(|c| LUMINANCE[c] * m[c] as f64).sum();
        let var = match self.luminance_variance.get(i) {
            Some(&v) => v as f64,
            None => (0..3).map(|c| LUMINANCE[c] * LUMINANCE[c] * self.variance[i][c] as f64).sum(),
        };
        (lum > 0.0 && var.is_finite()).then(|| var.sqrt() / lum.max(LUMINANCE_FLOOR))
    }

    /// Samples pixel `i` took.
    pub fn pixel_spp(&self, i: usize) -> u32 {
        self.pixel_spp.get(i).copied().unwrap_or(self.spp)
    }

    /// Mean samples per pixel.
    pub fn mean_spp(&self) -> f64 {
        if self.pixel_spp.is_empty() {
            return self.spp as f64;
        }
        self.pixel_spp.iter().map(|&n| n as f64).sum::<f64>() / self.pixel_spp.len().max(1) as f64
    }

    /// Share of the pixels still taking samples, in [0, 1].
    pub fn active_share(&self) -> f64 {
        self.active as f64 / (self.width as u64 * self.height as u64).max(1) as f64
    }
}

/// Why a session cannot take a job; its `Display` is one line.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// A setting is out of range, or the workers could not start.
    #[error(transparent)]
    Settings(#[from] InvalidSettings),
    /// The film and the snapshots the session keeps would exceed the memory limit.
    #[error(
        "image too large: {width}x{height} needs about {} for the film, over the memory limit of {}: render it in windows (lucent render --region) and merge them",
        format_bytes(*bytes),
        format_bytes(*limit)
    )]
    TooLarge {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// Bytes the film would take (`film_bytes`).
        bytes: u64,
        /// The limit.
        limit: u64,
    },
}

/// Bytes a session holds for a `width` x `height` film: the film and two snapshots' mean and variance.
///
/// The snapshot last published stays while the next one is built from the film.
pub fn film_bytes(width: u32, height: u32) -> u64 {
    let snapshot = 2 * width as u64 * height as u64 * std::mem::size_of::<Vec3>() as u64;
    Film::bytes(width, height) + 2 * snapshot
}

/// Bytes AOVs add to a session's film: their sums, and two snapshots' albedo and normal.
fn aov_bytes(width: u32, height: u32) -> u64 {
    let snapshot = 2 * width as u64 * height as u64 * std::mem::size_of::<Vec3>() as u64;
    Film::aov_bytes(width, height) + 2 * snapshot
}

/// Bytes a noise threshold adds to `film_bytes`: the film's error sums and stopping counts,
/// and two snapshots' luminance variances and samples per pixel.
pub fn threshold_bytes(width: u32, height: u32) -> u64 {
    Film::threshold_bytes(width, height) + 2 * width as u64 * height as u64 * 8
}

struct Pending {
    job: Job,
    generation: u64,
}

#[derive(Default)]
struct State {
    pending: Option<Pending>,
    latest: Option<Arc<Snapshot>>,
    paused: bool,
    stop: bool,
    /// When jobs end, whatever their sample count (`stop_at`).
    deadline: Option<Instant>,
    /// Only a job's last snapshot carries images (`images_at_end_only`).
    images_at_end: bool,
}

struct Shared {
    generation: AtomicU64,
    state: Mutex<State>,
    wake: Condvar,
    published: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Owns the render workers; dropping it stops and joins them.
pub struct RenderSession {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    limits: Limits,
}

impl RenderSession {
    /// Starts rendering `job` on `threads` workers (None: one per core) within the default `Limits`.
    pub fn new(job: Job, threads: Option<usize>) -> Result<Self, SessionError> {
        Self::start(job, threads, false, Limits::default())
    }

    /// Like `new`, but the workers run at the lowest OS priority, so that an interactive UI
    /// on the same cores (and a software rasteriser) always gets the CPU first; the workers
    /// still take every idle cycle.
    pub fn new_yielding(job: Job, threads: Option<usize>) -> Result<Self, SessionError> {
        Self::start(job, threads, true, Limits::default())
    }

    /// Like `new`, refusing this job and later ones whose film (`film_bytes`) exceeds `limits`.
    pub fn with_limits(job: Job, threads: Option<usize>, limits: Limits) -> Result<Self, SessionError> {
        Self::start(job, threads, false, limits)
    }

    fn start(job: Job, threads: Option<usize>, yielding: bool, limits: Limits) -> Result<Self, SessionError> {
        check_job(&job, &limits)?;
        let shared = Arc::new(Shared {
            generation: AtomicU64::new(0),
            state: Mutex::new(State::default()),
            wake: Condvar::new(),
            published: Condvar::new(),
        });
        let mut builder = rayon::ThreadPoolBuilder::new().thread_name(|i| format!("lucent-render-{i}"));
        if let Some(n) = threads {
            builder = builder.num_threads(n.max(1));
        }
        if yielding {
            // Best effort: if the OS refuses, the workers simply keep normal priority.
            builder = builder.start_handler(|_| {
                let _ = thread_priority::set_current_thread_priority(thread_priority::ThreadPriority::Min);
            });
        }
        let pool = builder.build().map_err(|e| InvalidSettings(format!("cannot start workers: {e}")))?;
        let worker_shared = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("lucent-session".into())
            .spawn(move || coordinate(&worker_shared, &pool))
            .map_err(|e| InvalidSettings(format!("cannot start the session thread: {e}")))?;
        let session = Self { shared, thread: Some(thread), limits };
        session.set_job(job)?;
        Ok(session)
    }

    /// Replaces the job: in-flight work is dropped and accumulation restarts at once.
    /// Returns the new generation.
    pub fn set_job(&self, job: Job) -> Result<u64, SessionError> {
        check_job(&job, &self.limits)?;
        let mut state = self.shared.lock();
        let generation = self.shared.generation.fetch_add(1, Ordering::SeqCst) + 1;
        state.pending = Some(Pending { job, generation });
        self.shared.wake.notify_all();
        Ok(generation)
    }

    /// The current generation (bumped by every `set_job`).
    pub fn generation(&self) -> u64 {
        self.shared.generation.load(Ordering::SeqCst)
    }

    /// Ends the job before `deadline`: the job is done when the measured time per sample says
    /// that its next pass would not end by then (the first pass always runs). A render given
    /// a time budget thus takes no longer than it and computes no pass it then drops. Passes
    /// are not shortened to fill the time left: each shorter pass adds one more Sobol net
    /// (`next_pass`), which did not lower the error at equal time (docs/performance.md).
    pub fn stop_at(&self, deadline: Instant) {
        self.shared.lock().deadline = Some(deadline);
        self.shared.wake.notify_all();
    }

    /// From now on, the snapshots published before a job is done carry its counts (spp,
    /// samples, rays, active pixels, time) and no images: `mean`, `variance`,
    /// `luminance_variance` and `pixel_spp` are empty and `aovs` is None. For callers that
    /// read only the last snapshot's images, as the command line's render does: building
    /// them after every pass happens on one thread while the workers wait. Without a
    /// deadline its passes then run longer (`BATCH_PASS`).
    pub fn images_at_end_only(&self) {
        self.shared.lock().images_at_end = true;
    }

    /// Pauses or resumes the workers (a pass in flight completes first); wakes the
    /// session only when the state changes, so calling it every UI frame costs a lock.
    pub fn set_paused(&self, paused: bool) {
        let mut state = self.shared.lock();
        if state.paused != paused {
            state.paused = paused;
            self.shared.wake.notify_all();
        }
    }

    /// The latest published snapshot of the current generation, without waiting.
    pub fn snapshot(&self) -> Option<Arc<Snapshot>> {
        let state = self.shared.lock();
        state.latest.clone().filter(|s| s.generation == self.generation())
    }

    /// Waits up to `timeout` for a snapshot of the current generation that differs from
    /// `seen` (pass the last one you got, or None), and returns the latest one.
    pub fn wait_for_update(&self, seen: Option<&Arc<Snapshot>>, timeout: Duration) -> Option<Arc<Snapshot>> {
        let deadline = Instant::now() + timeout;
        let mut state = self.shared.lock();
        loop {
            let generation = self.generation();
            if let Some(latest) = state.latest.as_ref().filter(|s| s.generation == generation)
                && seen.is_none_or(|s| !Arc::ptr_eq(s, latest))
            {
                return Some(Arc::clone(latest));
            }
            let now = Instant::now();
            if now >= deadline {
                return state.latest.clone().filter(|s| s.generation == generation);
            }
            state = self.shared.published.wait_timeout(state, deadline - now).unwrap_or_else(|e| e.into_inner()).0;
        }
    }

    /// Blocks until the target spp of the current job is reached; returns the final image.
    /// Only meaningful for jobs with a target.
    pub fn wait_until_done(&self) -> Arc<Snapshot> {
        let mut seen = None;
        loop {
            if let Some(s) = self.wait_for_update(seen.as_ref(), Duration::from_secs(1)) {
                if s.done {
                    return s;
                }
                seen = Some(s);
            }
        }
    }
}

impl Drop for RenderSession {
    fn drop(&mut self) {
        self.shared.lock().stop = true;
        self.shared.generation.fetch_add(1, Ordering::SeqCst);
        self.shared.wake.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Checks the job's settings, and that its film fits in the memory limit before it is allocated.
fn check_job(job: &Job, limits: &Limits) -> Result<(), SessionError> {
    job.settings.validate()?;
    if job.settings.integrator == Integrator::Distribution && job.scene.features.media {
        return Err(SessionError::Settings(InvalidSettings(format!(
            "{} has a scattering medium, which distribution ray tracing does not simulate: use --integrator path",
            job.scene.name
        ))));
    }
    if job.settings.integrator == Integrator::Distribution && job.settings.wants_spectral(job.scene.features.dispersion)
    {
        return Err(SessionError::Settings(InvalidSettings(format!(
            "{}: distribution ray tracing is RGB only; use --integrator path, or --spectral off to ignore dispersion",
            job.scene.name
        ))));
    }
    if job.settings.integrator.is_bidirectional() {
        let s = &job.settings;
        let name = if s.integrator == Integrator::Vcm {
            "vertex connection and merging"
        } else {
            "bidirectional path tracing"
        };
        let refuse = |why: &str| {
            Err(SessionError::Settings(InvalidSettings(format!(
                "{}: {name} {why}; use --integrator path",
                job.scene.name
            ))))
        };
        if s.noise_threshold.is_some() {
            return refuse(
                "adds light to any pixel, so a pixel's noise cannot stop its samples (no --noise-threshold)",
            );
        }
        if s.max_depth > crate::integrator::MAX_BIDIRECTIONAL_DEPTH {
            return refuse(&format!(
                "follows paths of at most {} bounces (--max-depth {})",
                crate::integrator::MAX_BIDIRECTIONAL_DEPTH,
                s.max_depth
            ));
        }
        if job.window.is_some() {
            return refuse(
                "renders whole frames only (a region's light paths land anywhere in the frame): split it by --samples instead",
            );
        }
    }
    if let Some(w) = job.window {
        w.check(job.settings.width, job.settings.height)
            .map_err(|e| SessionError::Settings(InvalidSettings(format!("window {w}: {e}"))))?;
    }
    let threshold = job.settings.noise_threshold.is_some();
    if threshold && job.settings.first_sample != 0 {
        return Err(SessionError::Settings(InvalidSettings(
            "a noise threshold stops pixels by their samples from the first on, so it cannot render a range of samples (--samples): split the render by --region instead".into(),
        )));
    }
    if let Some(w) = job.window.filter(|w| threshold && !on_tile_grid(w, job.settings.width, job.settings.height)) {
        return Err(SessionError::Settings(InvalidSettings(format!(
            "window {w}: with a noise threshold a window must lie on the {TILE_SIZE}-pixel tile grid (X0 and Y0 multiples of {TILE_SIZE}, X1 and Y1 too or the frame's edge), where its pixels stop as in the whole frame"
        ))));
    }
    let window = job.window();
    let (width, height) = (window.width(), window.height());
    let aovs = if job.aovs { aov_bytes(width, height) } else { 0 };
    let merging = if job.settings.integrator == Integrator::Vcm {
        LightVertex::bytes(width, height, job.settings.max_depth)
    } else {
        0
    };
    let bytes = film_bytes(width, height) + aovs + merging + if threshold { threshold_bytes(width, height) } else { 0 };
    if bytes > limits.memory {
        return Err(SessionError::TooLarge { width, height, bytes, limit: limits.memory });
    }
    Ok(())
}

/// Whether `w` lies on the tile grid of a `width` x `height` frame, so that its tiles are
/// the frame's (and a noise threshold stops its pixels as in the whole frame).
pub fn on_tile_grid(w: &Window, width: u32, height: u32) -> bool {
    let edge = |v: u32, end: u32| v.is_multiple_of(TILE_SIZE) || v == end;
    w.x0.is_multiple_of(TILE_SIZE) && w.y0.is_multiple_of(TILE_SIZE) && edge(w.x1, width) && edge(w.y1, height)
}

/// The generation being rendered and its film.
struct Active {
    job: Job,
    generation: u64,
    film: Film,
    /// Light-tracing contributions to any pixel (bidirectional path tracing only).
    splats: Option<Splats>,
    view: View,
    spp: u32,
    pass_spp: u32,
    elapsed: Duration,
    samples: u64,
    traced: u64,
    /// Every pixel stopped by the noise threshold.
    converged: bool,
    /// The session's deadline left no time for another pass.
    timed_out: bool,
}

impl Active {
    fn new(job: Job, generation: u64) -> Self {
        let s = job.settings;
        let mut film = Film::window(job.window());
        if job.aovs {
            film.record_aovs();
        }
        Self {
            film: if s.noise_threshold.is_some() { film.with_threshold() } else { film },
            splats: s.integrator.is_bidirectional().then(|| Splats::new(s.width, s.height)),
            view: View::new(&job.scene, &job.camera, s.width, s.height),
            job,
            generation,
            spp: 0,
            pass_spp: 1,
            elapsed: Duration::ZERO,
            samples: 0,
            traced: 0,
            converged: false,
            timed_out: false,
        }
    }

    fn done(&self) -> bool {
        self.converged || self.timed_out || self.job.settings.target_spp.is_some_and(|t| self.spp >= t)
    }
}

/// The session thread: waits for work, runs passes, publishes snapshots.
fn coordinate(shared: &Shared, pool: &rayon::ThreadPool) {
    let mut active: Option<Active> = None;
    loop {
        let (deadline, images_at_end) = {
            let mut state = shared.lock();
            loop {
                if state.stop {
                    return;
                }
                if let Some(p) = state.pending.take() {
                    active = Some(Active::new(p.job, p.generation));
                    break;
                }
                if !state.paused && active.as_ref().is_some_and(|a| !a.done()) {
                    break;
                }
                state = shared.wake.wait(state).unwrap_or_else(|e| e.into_inner());
            }
            (state.deadline, state.images_at_end)
        };
        let Some(a) = active.as_mut() else { continue };
        let pace = if images_at_end && deadline.is_none() { BATCH_PASS } else { INTERACTIVE_PASS };
        if !run_pass(shared, pool, a, deadline, pace) {
            continue;
        }
        let replicates = a.job.settings.replicates() > 1;
        let images = a.done() || !images_at_end;
        let (variance, luminance_variance) =
            if images { a.film.variance_images(replicates) } else { (Vec::new(), Vec::new()) };
        let snapshot = Arc::new(Snapshot {
            generation: a.generation,
            width: a.film.width,
            height: a.film.height,
            mean: if images { a.film.mean_image(a.splats.as_ref()) } else { Vec::new() },
            variance,
            luminance_variance,
            estimate: ErrorEstimate::of(a.job.settings.sampler, replicates),
            aovs: if images { a.film.aov_images() } else { None },
            spp: a.spp,
            pixel_spp: if images { a.film.spp_image(a.spp) } else { Vec::new() },
            active: a.film.active_pixels(),
            elapsed: a.elapsed,
            samples: a.samples,
            rays: a.traced,
            rejected: a.film.rejected() + a.splats.as_ref().map_or(0, Splats::rejected),
            done: a.done(),
            // A finished job adds nothing more: its sums move into the last snapshot, with
            // its splats (which a piece holds in its pixels' sums).
            film: a.done().then(|| {
                let mut film = std::mem::replace(&mut a.film, Film::new(0, 0));
                if let Some(s) = &a.splats {
                    film.add_splats(s);
                }
                Arc::new(film)
            }),
        });
        shared.lock().latest = Some(snapshot);
        shared.published.notify_all();
    }
}

/// Everything a tile needs to render its share of one pass.
struct Pass<'a> {
    splats: Option<&'a Splats>,
    photons: Option<&'a Photons>,
    scene: &'a Scene,
    settings: &'a Settings,
    view: &'a View,
    first: u64,
    count: u32,
    current: &'a AtomicU64,
    generation: u64,
    aovs: bool,
}

/// The noise threshold's parameters, for a pass.
#[derive(Clone, Copy)]
struct Threshold {
    threshold: f64,
    min_spp: u32,
    replicates: bool,
}

impl Pass<'_> {
    fn stale(&self) -> bool {
        self.current.load(Ordering::Relaxed) != self.generation
    }

    fn threshold(&self) -> Option<Threshold> {
        let s = self.settings;
        s.noise_threshold.map(|t| Threshold { threshold: t as f64, min_spp: s.min_spp, replicates: s.replicates() > 1 })
    }

    /// Adds samples `first..first + count` to every pixel of the tile that takes samples,
    /// checking the noise threshold at each check count on the way; returns (samples, rays).
    fn render_tile(&self, tile: &mut Tile) -> (u64, u64) {
        let (mut samples, mut traced) = (0u64, 0u64);
        let threshold = self.threshold();
        let end = self.first + self.count as u64;
        let mut start = self.first;
        while start < end {
            let check = threshold.map(|t| adaptive::next_check(start, t.min_spp));
            let stop = check.map_or(end, |c| c.min(end));
            for ly in 0..tile.size.y {
                for lx in 0..tile.size.x {
                    if self.stale() {
                        return (samples, traced);
                    }
                    let local = UVec2::new(lx, ly);
                    if !tile.active(local) {
                        continue;
                    }
                    let pixel = tile.origin + local;
                    let add = |index, out: PathOutput| {
                        tile.add(local, out.radiance);
                        if let Some(aov) = out.aov {
                            tile.add_aov(local, aov.albedo, aov.normal);
                        }
                        if threshold.is_some() {
                            tile.add_error(local, index, out.radiance);
                        }
                        traced += out.rays as u64;
                    };
                    let mut splat = |at: Vec2, value: Spectrum| {
                        if let Some(s) = self.splats {
                            s.add(at, value);
                        }
                    };
                    let (range, aovs) = (start..stop, self.aovs);
                    let beyond = (&mut splat as Splat, self.photons);
                    sample_pixels(self.scene, self.settings, self.view, pixel, range, aovs, add, beyond);
                    samples += stop - start;
                }
            }
            if let Some(t) = threshold.filter(|_| check == Some(stop)) {
                adaptive::check(tile, stop as u32, t.threshold, t.replicates);
            }
            start = stop;
        }
        (samples, traced)
    }
}

/// Whether a pass of `count` samples per pixel ends before `deadline` at the rate measured
/// so far (`elapsed` for `spp` samples); with nothing measured yet, it does.
fn fits(count: u32, (spp, elapsed): (u32, Duration), deadline: Option<Instant>) -> bool {
    let Some(deadline) = deadline.filter(|_| spp > 0) else { return true };
    let left = deadline.saturating_duration_since(Instant::now()).as_secs_f64();
    elapsed.as_secs_f64() / spp as f64 * count as f64 <= left
}

/// Adds one pass to the film, sizing the next one for `pace` (`next_pass`); false if a newer
/// job arrived meanwhile (the pass is dropped). Where the deadline leaves no time for the
/// pass, none runs and the job is done.
fn run_pass(
    shared: &Shared,
    pool: &rayon::ThreadPool,
    a: &mut Active,
    deadline: Option<Instant>,
    pace: Duration,
) -> bool {
    let remaining = a.job.settings.target_spp.map_or(u32::MAX, |t| t - a.spp);
    let count = a.pass_spp.min(remaining);
    if !fits(count, (a.spp, a.elapsed), deadline) {
        a.timed_out = true;
        return true;
    }
    let first = a.job.settings.first_sample as u64 + a.spp as u64;
    let pass = Pass {
        splats: a.splats.as_ref(),
        photons: None,
        scene: &a.job.scene,
        settings: &a.job.settings,
        view: &a.view,
        first,
        count,
        current: &shared.generation,
        generation: a.generation,
        aovs: a.job.aovs,
    };
    let start = Instant::now();
    let (mut samples, mut traced) = (0, 0);
    if a.job.settings.integrator == Integrator::Vcm {
        // An iteration at a time: its light subpaths (one per pixel), then its camera paths.
        let cx = Context { scene: &a.job.scene, settings: &a.job.settings };
        let size = (a.job.settings.width, a.job.settings.height);
        for index in first..first + count as u64 {
            let photons = pool.install(|| Photons::trace(cx, size, index, &mut traced));
            if pass.stale() {
                return false;
            }
            let iteration = Pass { photons: Some(&photons), first: index, count: 1, ..pass };
            let (n, rays) = render_tiles(pool, &mut a.film, &iteration);
            (samples, traced) = (samples + n, traced + rays);
        }
    } else {
        (samples, traced) = render_tiles(pool, &mut a.film, &pass);
    }
    if pass.stale() {
        return false;
    }
    let took = start.elapsed();
    a.spp += pass.count;
    a.converged = a.job.settings.noise_threshold.is_some() && a.film.active_pixels() == 0;
    a.elapsed += took;
    a.samples += samples;
    a.traced += traced;
    a.pass_spp = next_pass(count, pass.first + count as u64, took, pace);
    true
}

/// Renders `pass` on every tile of `film`; returns (samples, rays).
fn render_tiles(pool: &rayon::ThreadPool, film: &mut Film, pass: &Pass) -> (u64, u64) {
    pool.install(|| {
        film.tiles.par_iter_mut().map(|tile| pass.render_tile(tile)).reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1))
    })
}

/// How long a pass should take at least where snapshots are watched (the viewer's refresh)
/// or a deadline must be met in fine steps.
const INTERACTIVE_PASS: Duration = Duration::from_millis(100);

/// How long a pass should take at least where only the last snapshot's images are read and
/// no deadline is set (the command line's renders of a fixed count): at the end of every
/// pass the workers wait for its last tile, so fewer, longer passes wait less.
const BATCH_PASS: Duration = Duration::from_millis(400);

/// Samples in the pass after one of `pass` samples that took `took` and ended at sample
/// index `end`: a power of two, doubled for passes under `pace` (up to 64) and halved for
/// passes over four times that, and doubled only where `end` is a multiple of the doubled
/// size. Every pass then covers an aligned block of 2^k indices, one of the Sobol
/// sequence's (0, k, 2)-nets, and the samples a snapshot holds are a union of few nets:
/// passes of 1, 2, 4, 4, ... ended at 7 + 4k samples (115 = 64 + 32 + 16 + 2 + 1, five
/// nets), passes of 1, 1, 2, 4, 4, ... end at a multiple of 4 (116 = 64 + 32 + 16 + 4).
/// Each net leaves up to one sample's error in the share of a pixel an edge covers, and the
/// pixels along the Cornell light's edges hold a third of a time-budgeted render's squared
/// error.
fn next_pass(pass: u32, end: u64, took: Duration, pace: Duration) -> u32 {
    if took < pace {
        let doubled = (pass * 2).min(64);
        if end.is_multiple_of(doubled as u64) { doubled } else { pass }
    } else if took > pace * 4 {
        (pass / 2).max(1)
    } else {
        pass
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_cover_aligned_power_of_two_blocks_of_sample_indices() {
        // Fast passes, then slow ones, then fast again: every pass starts at a multiple of
        // its own size, which is a power of two.
        let (fast, slow) = (Duration::from_millis(10), Duration::from_millis(900));
        let mut timings = vec![fast; 12];
        timings.extend([slow; 3]);
        timings.extend([fast; 6]);
        for first in [0u64, 5, 64] {
            let (mut pass, mut start, mut sizes) = (1u32, first, Vec::new());
            for took in &timings {
                assert!(pass.is_power_of_two() && start.is_multiple_of(pass as u64), "{first}: {pass} at {start}");
                sizes.push(pass);
                start += pass as u64;
                pass = next_pass(pass, start, *took, INTERACTIVE_PASS);
            }
            assert_eq!(sizes.iter().max(), Some(&64), "{first}: {sizes:?}");
        }
    }

    #[test]
    fn a_batch_render_settles_on_passes_four_times_as_long_as_a_watched_one() {
        // At 10 ms per sample, passes double while shorter than the pace: a watched render
        // settles at 16 samples (160 ms), a batch render at 64 (640 ms).
        let settle = |pace: Duration| {
            let mut pass = 1u32;
            let mut end = 0u64;
            for _ in 0..40 {
                end += pass as u64;
                pass = next_pass(pass, end, Duration::from_millis(10) * pass, pace);
            }
            pass
        };
        assert_eq!(settle(INTERACTIVE_PASS), 16);
        assert_eq!(settle(BATCH_PASS), 64);
    }
}

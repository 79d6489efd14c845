//! The viewer's denoiser: Open Image Denoise (`film::denoise`) on a thread of its own, fed
//! the session's latest snapshot (its mean radiance, albedo and normal). The UI thread only
//! hands over a snapshot and later picks up the result, so it never waits; the snapshot is
//! one the session already published, so the accumulated data is never touched. A snapshot
//! is denoised again when the job changed, when its spp grew by `RERUN_GROWTH` since the last
//! one sent, and at a target's final image.

use crate::film::denoise::{available, denoise};
use crate::render::Snapshot;
use glam::Vec3;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, TryRecvError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Growth of the spp (a quarter more) after which a newer snapshot is denoised again.
pub const RERUN_GROWTH: f64 = 1.25;

/// A denoised snapshot.
pub struct Denoised {
    /// The snapshot it was computed from.
    pub source: Arc<Snapshot>,
    /// Row-major denoised radiance.
    pub image: Vec<Vec3>,
    /// How long the filter took.
    pub took: Duration,
}

/// The worker thread and its channels; dropping it lets the thread finish and joins it.
struct Worker {
    requests: Option<Sender<Arc<Snapshot>>>,
    results: Receiver<Result<Denoised, String>>,
    thread: Option<JoinHandle<()>>,
}

impl Worker {
    fn start() -> Result<Self, String> {
        let (requests, inbox) = std::sync::mpsc::channel::<Arc<Snapshot>>();
        let (outbox, results) = std::sync::mpsc::channel();
        let thread = std::thread::Builder::new()
            .name("lucent-denoise".into())
            .spawn(move || {
                for snap in inbox {
                    let start = Instant::now();
                    let result = denoise(&snap.mean, snap.aovs.as_ref(), snap.width, snap.height)
                        .map(|image| Denoised { source: snap, image, took: start.elapsed() });
                    if outbox.send(result).is_err() {
                        return;
                    }
                }
            })
            .map_err(|e| format!("cannot start the denoiser's thread: {e}"))?;
        Ok(Self { requests: Some(requests), results, thread: Some(thread) })
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        self.requests = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The Denoise toggle's state: the worker, what it is doing, and its last image.
#[derive(Default)]
pub struct Denoiser {
    /// Show the denoised image (the toggle).
    pub enabled: bool,
    worker: Option<Worker>,
    /// (generation, spp) of the snapshot being denoised, if one is.
    busy: Option<(u64, u32)>,
    /// (generation, spp) of the last snapshot sent.
    sent: Option<(u64, u32)>,
    latest: Option<Arc<Denoised>>,
    error: Option<String>,
}

impl Denoiser {
    /// Whether `snap` should be denoised, the last one sent being `sent`.
    fn due(sent: Option<(u64, u32)>, snap: &Snapshot) -> bool {
        match sent {
            None => true,
            Some((generation, spp)) => {
                generation != snap.generation
                    || (snap.done && spp != snap.spp)
                    || snap.spp as f64 >= RERUN_GROWTH * spp as f64
            }
        }
    }

    /// Takes a finished result, then hands `snap` (the latest snapshot) to the worker if the
    /// toggle is on, the worker is free and it is due. Never blocks. Returns whether a new
    /// result arrived.
    pub fn poll(&mut self, snap: Option<&Arc<Snapshot>>) -> bool {
        let mut arrived = false;
        if let Some(w) = &self.worker {
            match w.results.try_recv() {
                Ok(Ok(d)) => {
                    self.latest = Some(Arc::new(d));
                    self.error = None;
                    self.busy = None;
                    arrived = true;
                }
                Ok(Err(e)) => {
                    self.error = Some(e);
                    self.busy = None;
                    arrived = true;
                }
                Err(TryRecvError::Empty) => {}
                Err(TryRecvError::Disconnected) => {
                    self.error = Some("the denoiser's thread stopped".into());
                    self.busy = None;
                    self.worker = None;
                }
            }
        }
        let Some(snap) = snap.filter(|s| self.enabled && self.busy.is_none() && Self::due(self.sent, s)) else {
            return arrived;
        };
        if available().is_err() || (self.error.is_some() && self.sent.is_some_and(|s| s.0 == snap.generation)) {
            // Not installed, or it failed on this job already: no retry until the job changes.
            return arrived;
        }
        if self.worker.is_none() {
            match Worker::start() {
                Ok(w) => self.worker = Some(w),
                Err(e) => {
                    self.error = Some(e);
                    return arrived;
                }
            }
        }
        let key = (snap.generation, snap.spp);
        let sent = self.worker.as_ref().and_then(|w| w.requests.as_ref()).map(|r| r.send(Arc::clone(snap)));
        if sent.is_some_and(|r| r.is_ok()) {
            self.busy = Some(key);
            self.sent = Some(key);
        }
        arrived
    }

    /// The denoised image to show instead of `snap`'s mean: the toggle is on and the last
    /// result is of the same job and size.
    pub fn shown(&self, snap: &Snapshot) -> Option<&Arc<Denoised>> {
        self.latest.as_ref().filter(|d| {
            self.enabled
                && d.source.generation == snap.generation
                && (d.source.width, d.source.height) == (snap.width, snap.height)
        })
    }

    /// Which result the toggle shows, (generation, spp), to notice when it changes.
    pub fn shown_key(&self) -> Option<(u64, u32)> {
        self.latest.as_ref().filter(|_| self.enabled).map(|d| (d.source.generation, d.source.spp))
    }

    /// Whether the result for `snap` itself is ready (for a screenshot at a target).
    pub fn done_with(&self, snap: &Snapshot) -> bool {
        self.shown(snap).is_some_and(|d| d.source.spp == snap.spp)
    }

    /// Whether it failed on the current job (the screenshot then stops with the error).
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// One line for the panel: what to run to install it, the error, or what was denoised and how
    /// long it took.
    pub fn status(&self) -> String {
        if let Err(e) = available() {
            return e;
        }
        if let Some(e) = &self.error {
            return e.clone();
        }
        let last = self
            .latest
            .as_ref()
            .map(|d| format!("denoised at {} spp in {:.0} ms", d.source.spp, d.took.as_secs_f64() * 1e3));
        match (self.busy, last) {
            (Some((_, spp)), Some(last)) => format!("{last}; denoising {spp} spp"),
            (Some((_, spp)), None) => format!("denoising {spp} spp"),
            (None, Some(last)) => last,
            (None, None) if self.enabled => "waiting for an image".into(),
            (None, None) => "off".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snap(generation: u64, spp: u32, done: bool) -> Arc<Snapshot> {
        Arc::new(Snapshot {
            generation,
            width: 2,
            height: 1,
            mean: vec![Vec3::ONE; 2],
            variance: vec![Vec3::ZERO; 2],
            luminance_variance: Vec::new(),
            estimate: crate::film::adaptive::ErrorEstimate::Samples,
            aovs: None,
            spp,
            pixel_spp: Vec::new(),
            active: 2,
            elapsed: Duration::ZERO,
            samples: 2 * spp as u64,
            rays: 0,
            rejected: 0,
            done,
            film: None,
        })
    }

    #[test]
    fn it_reruns_when_the_job_changed_the_spp_grew_by_a_quarter_or_the_target_is_reached() {
        let sent = Some((1, 16));
        assert!(Denoiser::due(None, &snap(1, 1, false)), "nothing denoised yet");
        assert!(!Denoiser::due(sent, &snap(1, 19, false)), "19 < 1.25 x 16");
        assert!(Denoiser::due(sent, &snap(1, 20, false)));
        assert!(Denoiser::due(sent, &snap(2, 1, false)), "another job");
        assert!(Denoiser::due(sent, &snap(1, 17, true)), "the final image");
        assert!(!Denoiser::due(Some((1, 17)), &snap(1, 17, true)), "already sent");
    }

    #[test]
    fn off_it_sends_nothing_and_shows_nothing() {
        let mut denoiser = Denoiser::default();
        let s = snap(1, 4, false);
        assert!(!denoiser.poll(Some(&s)));
        assert!(denoiser.worker.is_none() && denoiser.shown(&s).is_none() && denoiser.shown_key().is_none());
    }

    #[test]
    fn on_it_denoises_where_the_library_is_found_and_otherwise_says_what_to_run() {
        let mut denoiser = Denoiser { enabled: true, ..Denoiser::default() };
        let s = snap(1, 4, true);
        denoiser.poll(Some(&s));
        match available() {
            Err(e) => {
                assert!(denoiser.worker.is_none() && denoiser.shown(&s).is_none());
                assert!(denoiser.status() == e && !e.contains('\n'), "{e}");
            }
            Ok(()) => assert!(denoiser.worker.is_some() && denoiser.busy.is_some(), "the snapshot was sent"),
        }
    }
}

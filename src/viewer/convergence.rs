//! The live convergence log: the estimated error of the current view against render time,
//! one curve per estimator settings on the same image, and the time still needed to reach a
//! target error.

use crate::integrator::Settings;
use crate::params::Group;
use crate::render::Snapshot;
use std::collections::VecDeque;

/// Earlier curves kept on the plot.
const KEPT: usize = 4;

/// One job's estimated relative error against time.
#[derive(Clone, Debug)]
pub struct Curve {
    /// Its number, counted from 1 since the image last changed (kept by the curves that
    /// replace it).
    pub number: u32,
    /// What rendered it (estimator and sampler).
    pub label: String,
    /// (seconds, mean relative standard error) per image.
    pub points: Vec<[f64; 2]>,
}

/// The current job's curve and the few before it.
#[derive(Default)]
pub struct ConvergenceLog {
    generation: Option<u64>,
    /// What the curves render (scene, edits, camera, size), as `record` was told.
    view: Option<u64>,
    /// Curves started so far.
    started: u32,
    /// The job being rendered.
    pub current: Option<Curve>,
    /// Earlier jobs, oldest first.
    pub previous: VecDeque<Curve>,
}

impl ConvergenceLog {
    /// Adds a full-resolution image of a job labelled `label` (its estimator settings)
    /// rendering image `view`. A new job on the same image keeps the finished curve (if it
    /// has at least two points) for comparison, one curve per label: the new one replaces
    /// a curve of its label, taking its number. A new job on another image (a camera move,
    /// an edit, another size) starts the plot over, since the earlier curves measured
    /// another image's error.
    pub fn record(&mut self, snap: &Snapshot, label: &str, view: u64) {
        if self.view != Some(view) {
            *self = Self { view: Some(view), ..Self::default() };
        }
        if self.generation != Some(snap.generation) {
            if let Some(done) = self.current.take().filter(|c| c.points.len() >= 2 || c.label == label) {
                self.previous.push_back(done);
            }
            let replaced = self.previous.iter().position(|c| c.label == label);
            let number = match replaced.and_then(|i| self.previous.remove(i)) {
                Some(old) => old.number,
                None => {
                    self.started += 1;
                    self.started
                }
            };
            if self.previous.len() > KEPT {
                self.previous.pop_front();
            }
            self.generation = Some(snap.generation);
            self.current = Some(Curve { number, label: label.into(), points: Vec::new() });
        }
        let (Some(curve), Some(error)) = (self.current.as_mut(), snap.relative_error()) else { return };
        let t = snap.elapsed.as_secs_f64();
        if error > 0.0 && error.is_finite() && t > 0.0 && curve.points.last().is_none_or(|p| p[0] < t) {
            curve.points.push([t, error]);
        }
    }

    /// Forgets every curve (another scene's errors are not comparable).
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// Seconds of rendering still needed for the error to reach `target`, if the error
    /// keeps falling as time^-1/2 from the latest point (as an unbiased estimator's does).
    pub fn time_to(&self, target: f64) -> Option<f64> {
        let [t, e] = *self.current.as_ref()?.points.last()?;
        Some(time_to_error(t, e, target))
    }
}

/// Seconds still needed to bring error `error`, reached after `seconds`, down to `target`
/// if it falls as time^-1/2 (0 if it is already there).
pub fn time_to_error(seconds: f64, error: f64, target: f64) -> f64 {
    if error <= target { 0.0 } else { seconds * (error / target).powi(2) - seconds }
}

/// A short label for the settings that make curves differ: every estimator setting of the
/// table that applies and differs from its default (seed and sample target aside).
pub fn label(s: &Settings) -> String {
    let defaults = Settings::default();
    let differences: Vec<String> = Settings::table()
        .iter()
        .filter(|p| matches!(p.group, Group::Estimator | Group::Convergence) && !matches!(p.name, "seed" | "spp"))
        .filter(|p| (p.shown)(s) && (p.get)(s) != (p.get)(&defaults))
        .map(|p| format!("{} {}", p.name, (p.get)(s)))
        .collect();
    if differences.is_empty() { "default estimator".into() } else { differences.join(", ") }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use std::time::Duration;

    fn snap(generation: u64, seconds: f64, error: f32) -> Snapshot {
        // One pixel of mean 1 whose variance of the mean gives the wanted relative error.
        Snapshot {
            generation,
            width: 1,
            height: 1,
            mean: vec![Vec3::ONE],
            variance: vec![Vec3::splat(error * error)],
            aovs: None,
            luminance_variance: Vec::new(),
            estimate: crate::film::adaptive::ErrorEstimate::Samples,
            spp: 2,
            pixel_spp: Vec::new(),
            active: 1,
            elapsed: Duration::from_secs_f64(seconds),
            samples: 1,
            rays: 1,
            rejected: 0,
            done: false,
            film: None,
        }
    }

    #[test]
    fn a_new_job_keeps_the_previous_curve_for_comparison() {
        let mut log = ConvergenceLog::default();
        for (t, e) in [(1.0, 0.1), (4.0, 0.05)] {
            log.record(&snap(1, t, e), "PT", 0);
        }
        log.record(&snap(2, 0.5, 0.2), "DRT", 0);
        assert_eq!(log.previous.len(), 1);
        assert_eq!(log.previous[0].label, "PT");
        assert_eq!(log.previous[0].points.len(), 2);
        assert_eq!(log.current.as_ref().unwrap().label, "DRT");
        for g in 3..10 {
            log.record(&snap(g, 1.0, 0.1), &format!("x{g}"), 0);
            log.record(&snap(g, 2.0, 0.07), &format!("x{g}"), 0);
        }
        assert_eq!(log.previous.len(), KEPT);
    }

    #[test]
    fn a_restart_on_the_same_settings_replaces_their_curve_and_another_image_starts_over() {
        let mut log = ConvergenceLog::default();
        log.record(&snap(1, 1.0, 0.1), "PT", 0);
        log.record(&snap(1, 2.0, 0.07), "PT", 0);
        log.record(&snap(2, 1.0, 0.1), "BDPT", 0);
        log.record(&snap(2, 2.0, 0.07), "BDPT", 0);
        // Back to PT on the same image: its curve is replaced, under its number.
        log.record(&snap(3, 0.5, 0.2), "PT", 0);
        let numbered = |c: &Curve| (c.number, c.label.clone());
        assert_eq!(log.previous.iter().map(numbered).collect::<Vec<_>>(), [(2, "BDPT".to_string())]);
        assert_eq!(log.current.as_ref().map(numbered), Some((1, "PT".to_string())));
        // A restart that does not get two points on the plot still keeps its number.
        log.record(&snap(4, 0.5, 0.2), "PT", 0);
        assert_eq!(log.current.as_ref().map(numbered), Some((1, "PT".to_string())));
        // Another image (the camera moved, a material was edited): the plot starts over.
        log.record(&snap(5, 0.5, 0.2), "PT", 1);
        assert!(log.previous.is_empty());
        assert_eq!(log.current.as_ref().map(numbered), Some((1, "PT".to_string())));
    }

    #[test]
    fn the_time_to_a_target_follows_the_inverse_square_root_law() {
        let mut log = ConvergenceLog::default();
        log.record(&snap(1, 2.0, 0.04), "PT", 0);
        let rel = log.current.as_ref().unwrap().points[0][1];
        // Halving the error takes four times the time: 3 x 2 s more.
        assert!((log.time_to(rel / 2.0).unwrap() - 6.0).abs() < 1e-9);
        assert_eq!(log.time_to(rel * 2.0), Some(0.0));
    }

    #[test]
    fn labels_name_what_differs_from_the_defaults() {
        assert_eq!(label(&Settings::default()), "default estimator");
        let s = Settings {
            light_sampling: crate::integrator::LightSampling::Explicit,
            branching: 4,
            seed: 9,
            ..Settings::default()
        };
        assert_eq!(label(&s), "lights explicit", "branching applies to DRT only, the seed to no curve");
        let drt = Settings { integrator: crate::integrator::Integrator::Distribution, ..s };
        assert_eq!(label(&drt), "integrator distribution, branching 4, lights explicit");
    }
}

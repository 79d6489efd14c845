//! Multiple importance sampling weights (Veach 1997, chapter 9) and the record of how a
//! path's last direction was sampled, which they need when the path finds a light.

use super::settings::{LightSampling, Settings};

/// Power heuristic with exponent 2 (Veach 1997, eq. 9.13): weight of the strategy with pdf `a`.
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// How the direction of the current ray was sampled at the last scattering vertex.
#[derive(Clone, Copy, Debug)]
pub struct Scattered {
    /// Solid-angle density of the direction (meaningless after a delta lobe).
    pub pdf: f32,
    /// It came from a delta lobe, which light sampling cannot find.
    pub specular: bool,
}

/// Weight of light found by a ray sampled as `last` (None for camera rays), whose light
/// sampling density would have been `light_pdf()`: 1 where light sampling could not have
/// found it (camera rays, delta lobes, light sampling off), 0 where it did and `explicit`
/// leaves it to light sampling alone, the power heuristic for MIS (textbook section 10.9).
pub fn emission_weight(settings: &Settings, last: Option<Scattered>, light_pdf: impl FnOnce() -> f32) -> f32 {
    match (settings.light_sampling, last) {
        (LightSampling::Off, _) | (_, None) => 1.0,
        (_, Some(s)) if s.specular => 1.0,
        (LightSampling::Explicit, Some(_)) => 0.0,
        (LightSampling::Mis, Some(s)) => power_heuristic(s.pdf, light_pdf()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0f32, 3.0f32), (0.2, 0.2), (5.0, 0.0)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
        }
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
    }

    #[test]
    fn light_after_a_delta_lobe_counts_in_full_in_every_mode() {
        let after_delta = Some(Scattered { pdf: 0.3, specular: true });
        let after_diffuse = Some(Scattered { pdf: 0.3, specular: false });
        for mode in [LightSampling::Off, LightSampling::Explicit, LightSampling::Mis] {
            let s = Settings { light_sampling: mode, ..Settings::default() };
            assert_eq!(emission_weight(&s, after_delta, || 0.3), 1.0);
            assert_eq!(emission_weight(&s, None, || 0.3), 1.0);
            let expected = match mode {
                LightSampling::Off => 1.0,
                LightSampling::Explicit => 0.0,
                LightSampling::Mis => 0.5,
            };
            assert_eq!(emission_weight(&s, after_diffuse, || 0.3), expected);
        }
    }
}

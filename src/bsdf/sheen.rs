//! KHR_materials_sheen: the "Charlie" distribution of Estevez and Kulla (2017) with
//! Ashikhmin's visibility term, and its directional albedo, tabulated offline
//! (`sheen_table.rs`) so that the layers under the sheen can be weighted by the energy it
//! leaves, without integrating it at the start of every scene with a sheen. That visibility
//! term is not energy conserving: a thin sheen (alpha 0.01) reflects 1.33 at cos theta 0.07.
//! The lobe is therefore divided by max(1, E(wo), E(wi)), which keeps it symmetric and its
//! albedo at most 1.

use crate::spectrum::Spectrum;
use glam::Vec3;
use std::f32::consts::{PI, TAU};

/// Smallest sheen alpha: below it the distribution is a grazing spike f32 cannot resolve.
pub const MIN_SHEEN_ALPHA: f32 = 1e-2;

/// Table resolution along cos theta_o and along sheen roughness.
pub const N: usize = 32;

/// A sheen lobe of colour `color` and width `alpha` (sheenRoughness^2).
#[derive(Clone, Copy, Debug)]
pub struct Sheen {
    /// Sheen colour.
    pub color: Spectrum,
    /// Width of the fibre distribution.
    pub alpha: f32,
}

/// Charlie distribution D(h) = (2 + 1/alpha) sin^(1/alpha) theta_h / (2 pi).
fn charlie(alpha: f32, h_z: f32) -> f32 {
    let inv = 1.0 / alpha.max(MIN_SHEEN_ALPHA);
    let sin2 = (1.0 - h_z * h_z).max(0.0);
    (2.0 + inv) * sin2.powf(0.5 * inv) / TAU
}

/// f |cos theta_i| of a white sheen lobe, both directions above the surface.
fn white_eval_cos(alpha: f32, wo: Vec3, wi: Vec3) -> f32 {
    let h = (wo + wi).normalize_or_zero();
    if h == Vec3::ZERO {
        return 0.0;
    }
    let visibility = 1.0 / (4.0 * (wi.z + wo.z - wi.z * wo.z));
    charlie(alpha, h.z) * visibility * wi.z
}

impl Sheen {
    /// f |cos theta_i| for wo, wi above the surface (normalised as described above).
    pub fn eval_cos(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        let norm = self.raw_albedo(wo.z).max(self.raw_albedo(wi.z)).max(1.0);
        self.color * (white_eval_cos(self.alpha, wo, wi) / norm)
    }

    /// Directional albedo of the normalised white lobe at cos theta_o = `mu` (at most 1).
    pub fn albedo(&self, mu: f32) -> f32 {
        self.raw_albedo(mu).min(1.0)
    }

    /// Directional albedo of the un-normalised white lobe.
    fn raw_albedo(&self, mu: f32) -> f32 {
        let t = &super::sheen_table::TABLE;
        let x = mu.clamp(0.0, 1.0) * (N - 1) as f32;
        let y = self.alpha.sqrt().clamp(0.0, 1.0) * (N - 1) as f32;
        let (i, j) = ((x as usize).min(N - 2), (y as usize).min(N - 2));
        let (fx, fy) = (x - i as f32, y - j as f32);
        let r0 = t[j][i] + (t[j][i + 1] - t[j][i]) * fx;
        let r1 = t[j + 1][i] + (t[j + 1][i + 1] - t[j + 1][i]) * fx;
        (r0 + (r1 - r0) * fy).max(0.0)
    }
}

/// Albedo of the white lobe by a midpoint rule over the incident hemisphere.
fn integrate(alpha: f32, mu: f32, n: usize) -> f32 {
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu.max(1e-3));
    let mut sum = 0.0f64;
    for a in 0..n {
        // Uniform in cos theta_i, so the measure is d(cos) d(phi).
        let cos_t = (a as f32 + 0.5) / n as f32;
        let sin_t = (1.0 - cos_t * cos_t).sqrt();
        for b in 0..2 * n {
            let phi = PI * (b as f32 + 0.5) / n as f32;
            let wi = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
            sum += white_eval_cos(alpha, wo, wi) as f64;
        }
    }
    (sum * TAU as f64 / (2 * n * n) as f64) as f32
}

/// The albedo table, one row per sqrt(alpha) node and one column per cos theta_o node (about
/// 0.3 s): how `sheen_table.rs` was computed (`cargo run --release --example sheen_table`).
pub fn compute_table() -> [[f32; N]; N] {
    let mut t = [[0.0; N]; N];
    for (j, row) in t.iter_mut().enumerate() {
        let r = j as f32 / (N - 1) as f32;
        for (i, e) in row.iter_mut().enumerate() {
            *e = integrate((r * r).max(MIN_SHEEN_ALPHA), i as f32 / (N - 1) as f32, 96);
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_the_integration_it_was_made_by() {
        assert_eq!(compute_table(), super::super::sheen_table::TABLE);
    }

    #[test]
    fn the_albedo_table_matches_finer_integration() {
        for (mu, r) in [(0.5f32, 0.5f32), (0.9, 1.0), (0.1, 0.3), (1.0, 0.7), (0.05, 0.1)] {
            let alpha = (r * r).max(MIN_SHEEN_ALPHA);
            let s = Sheen { color: Spectrum::ONE, alpha };
            let direct = integrate(alpha, mu, 400);
            let table = s.raw_albedo(mu);
            assert!((table - direct).abs() < 3e-2 * direct.max(0.3), "E({mu}, {r}): {table} vs {direct}");
        }
    }
}

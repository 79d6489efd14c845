//! Directional albedo of the single-scattering GGX lobe under Schlick's Fresnel, tabulated
//! per process, for energy compensation: layering a diffuse base under the lobe without
//! creating energy, and Kulla-Conty's multiple-scattering lobe.
//!
//! With F = f0 + (1 - f0) (1 - v.h)^5, the albedo E(mu, alpha, f0) is linear in f0:
//! E = f0 (A - B) + B, with A the albedo for F = 1 and B the albedo for F = (1 - v.h)^5.
//! Both are integrated by stratified VNDF sampling, where f cos / pdf = F G2 / G1, offline
//! (`albedo_table.rs`), so that no scene's start, nor every piece of a farm render, pays
//! for integrating them.

use super::microfacet::{Ggx, reflect};
use glam::{Vec2, Vec3};
use std::sync::OnceLock;

/// Table resolution along sqrt(cos theta_o). The square root puts nodes close together at
/// grazing angles, where Fresnel and masking change fast and linear interpolation between
/// sparse nodes would underestimate the layer's albedo.
pub const N: usize = 64;
/// Table resolution along roughness (sqrt alpha).
pub const NR: usize = 64;
/// Strata per axis of the quadrature at each node. Reflections below the horizon are cut
/// out of the integrand, and that edge makes the midpoint rule converge only as 1 / STRATA:
/// 16 strata left errors of 1% at roughness 0.5, 64 leave 0.2%.
const STRATA: usize = 64;
/// Smallest cos theta_o in the table (grazing rows are clamped to it).
const MU_MIN: f32 = 1e-3;

/// The A and B albedos along mu for one roughness, and their cosine-weighted averages.
struct Row {
    a: [f32; N],
    b: [f32; N],
    a_avg: f32,
    b_avg: f32,
}

fn mu_at(i: usize) -> f32 {
    (i as f32 / (N - 1) as f32).powi(2).max(MU_MIN)
}

fn roughness_at(j: usize) -> f32 {
    j as f32 / (NR - 1) as f32
}

/// E_avg = 2 int_0^1 E(mu) mu dmu = 4 int_0^1 E(x^2) x^3 dx, integrated exactly for the
/// interpolant (linear in x between nodes), so that weights built on it integrate to
/// exactly the energy the lobe leaves, whatever the table's own error.
fn average(row: &[f32; N]) -> f32 {
    let h = 1.0 / (N - 1) as f64;
    let mut s = 0.0;
    for i in 0..N - 1 {
        let (x0, x1) = (i as f64 * h, (i + 1) as f64 * h);
        let (e0, e1) = (row[i] as f64, row[i + 1] as f64);
        let slope = (e1 - e0) / h;
        // int_{x0}^{x1} (e0 + slope (x - x0)) 4 x^3 dx
        let c = e0 - slope * x0;
        s += c * (x1.powi(4) - x0.powi(4)) + slope * 0.8 * (x1.powi(5) - x0.powi(5));
    }
    s as f32
}

/// The A and B albedos along mu at roughness node `j`, by stratified VNDF sampling (about
/// 20 ms): how `albedo_table.rs` was computed (`cargo run --release --example albedo_table`).
pub fn compute_row(j: usize) -> ([f32; N], [f32; N]) {
    let r = roughness_at(j);
    let ggx = Ggx::isotropic((r * r).max(super::SMOOTH_ALPHA));
    let (mut a_row, mut b_row) = ([0.0; N], [0.0; N]);
    for i in 0..N {
        let mu = mu_at(i);
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let (mut a, mut b) = (0.0f64, 0.0f64);
        for k in 0..STRATA * STRATA {
            let u = Vec2::new((k % STRATA) as f32 + 0.5, (k / STRATA) as f32 + 0.5) / STRATA as f32;
            let h = ggx.sample_visible_normal(wo, u);
            let wi = reflect(wo, h);
            if wi.z <= 0.0 {
                continue;
            }
            let w = (ggx.g2(wo, wi) / ggx.g1(wo)) as f64;
            a += w;
            b += w * (1.0 - wo.dot(h).clamp(0.0, 1.0) as f64).powi(5);
        }
        let n = (STRATA * STRATA) as f64;
        a_row[i] = (a / n) as f32;
        b_row[i] = (b / n) as f32;
    }
    (a_row, b_row)
}

/// Row `j` of the tables computed offline, with its averages (taken on first use).
fn row(j: usize) -> &'static Row {
    static ROWS: [OnceLock<Row>; NR] = [const { OnceLock::new() }; NR];
    ROWS[j].get_or_init(|| {
        let (a, b) = (super::albedo_table::A[j], super::albedo_table::B[j]);
        Row { a_avg: average(&a), b_avg: average(&b), a, b }
    })
}

/// Linear interpolation weights of `x` in [0, 1] on an n-point grid.
fn cell(x: f32, n: usize) -> (usize, f32) {
    let s = x.clamp(0.0, 1.0) * (n - 1) as f32;
    let i = (s as usize).min(n - 2);
    (i, s - i as f32)
}

/// Albedo of the GGX lobe with Fresnel reflectance f0 (scalar) at cos theta_o = `mu`, for
/// perceptual roughness `roughness` (alpha = roughness^2).
pub fn ggx_albedo(mu: f32, roughness: f32, f0: f32) -> f32 {
    GgxAlbedo::new(mu, roughness).at(f0)
}

/// The two tabulated albedos at one cosine and roughness, A (f0 = 1) and B (f0 = 0), which
/// `ggx_albedo` blends by f0: read once, they give the albedo for every f0.
#[derive(Clone, Copy, Debug)]
pub struct GgxAlbedo {
    a: f32,
    b: f32,
}

impl GgxAlbedo {
    /// The tables at cos theta_o = `mu` for perceptual roughness `roughness`, interpolated.
    pub fn new(mu: f32, roughness: f32) -> Self {
        let (i, fi) = cell(mu.max(0.0).sqrt(), N);
        let (j, fj) = cell(roughness, NR);
        let (r0, r1) = (row(j), row(j + 1));
        let lerp = |x: &[f32; N]| x[i] + (x[i + 1] - x[i]) * fi;
        let a = lerp(&r0.a) + (lerp(&r1.a) - lerp(&r0.a)) * fj;
        let b = lerp(&r0.b) + (lerp(&r1.b) - lerp(&r0.b)) * fj;
        Self { a, b }
    }

    /// The albedo for Fresnel reflectance `f0`.
    pub fn at(self, f0: f32) -> f32 {
        (f0 * (self.a - self.b) + self.b).clamp(0.0, 1.0)
    }
}

/// Cosine-weighted hemispherical average of `ggx_albedo` over mu: 2 int E(mu) mu dmu.
pub fn ggx_average_albedo(roughness: f32, f0: f32) -> f32 {
    let (j, fj) = cell(roughness, NR);
    let (r0, r1) = (row(j), row(j + 1));
    let a = r0.a_avg + (r1.a_avg - r0.a_avg) * fj;
    let b = r0.b_avg + (r1.b_avg - r0.b_avg) * fj;
    (f0 * (a - b) + b).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// E by a midpoint rule over the incident hemisphere, independent of VNDF sampling.
    fn quadrature(mu: f32, roughness: f32, f0: f32) -> f32 {
        let ggx = Ggx::isotropic(roughness * roughness);
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let n = 300;
        let mut sum = 0.0f64;
        for i in 0..n {
            let cos_t = (i as f32 + 0.5) / n as f32;
            let sin_t = (1.0 - cos_t * cos_t).sqrt();
            for j in 0..n {
                let phi = std::f32::consts::TAU * (j as f32 + 0.5) / n as f32;
                let wi = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
                let h = (wo + wi).normalize();
                let f = f0 + (1.0 - f0) * (1.0 - wo.dot(h)).powi(5);
                let value = f * ggx.d(h) * ggx.g2(wo, wi) / (4.0 * mu);
                sum += value as f64 / (n * n) as f64 * std::f64::consts::TAU;
            }
        }
        sum as f32
    }

    #[test]
    fn the_tables_are_the_integration_they_were_made_by() {
        for j in 0..NR {
            assert_eq!(compute_row(j), (super::super::albedo_table::A[j], super::super::albedo_table::B[j]), "row {j}");
        }
    }

    #[test]
    fn the_tables_match_direct_integration_between_their_nodes() {
        for (mu, roughness, f0) in [(0.5f32, 0.5f32, 0.04f32), (0.9, 0.8, 1.0), (0.2, 0.3, 0.5), (1.0, 1.0, 1.0)] {
            let (table, direct) = (ggx_albedo(mu, roughness, f0), quadrature(mu, roughness, f0));
            assert!((table - direct).abs() < 5e-3, "E({mu}, {roughness}, {f0}): table {table}, direct {direct}");
        }
    }

    #[test]
    fn a_smooth_mirror_reflects_everything_and_f0_zero_only_at_grazing_angles() {
        assert!((ggx_albedo(0.7, 0.0, 1.0) - 1.0).abs() < 1e-3);
        assert!((ggx_average_albedo(0.0, 1.0) - 1.0).abs() < 2e-3);
        assert!(ggx_albedo(1.0, 0.5, 0.0) < 0.01);
        assert!((ggx_albedo(0.05, 0.0, 0.0) - 0.95f32.powi(5)).abs() < 0.01);
    }
}

//! Measured isotropic BRDFs in the MERL binary format (Matusik et al. 2003): 90 x 90 x 180
//! samples over (theta_half, theta_diff, phi_diff), looked up as the MERL reference code
//! does. Sampled by a one-sample mixture of cosine directions and half vectors drawn from
//! the table's own distribution over theta_half, so glossy measurements are not sampled
//! blindly and the weight stays bounded (at most 2 pi f) everywhere.

use crate::math::{distribution::Distribution1D, luminance, warp};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, PI};
use std::path::Path;

/// Table resolution: theta_half, theta_diff, phi_diff (folded to [0, pi) by reciprocity).
pub const THETA_HALF: usize = 90;
/// Samples of theta_diff.
pub const THETA_DIFF: usize = 90;
/// Samples of phi_diff.
pub const PHI_DIFF: usize = 180;
/// Scales from stored values to BRDF values per channel (MERL's reference code).
pub const SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];
const CELLS: usize = THETA_HALF * THETA_DIFF * PHI_DIFF;

/// Bytes of a MERL .binary file: three i32 dimensions, then three f64 per cell.
const FILE_BYTES: usize = 12 + 3 * CELLS * 8;

/// A loaded MERL BRDF with its half-vector sampling distribution.
#[derive(Debug)]
pub struct MerlTable {
    values: Vec<Vec3>,
    /// Density over x = sqrt(theta_half / (pi/2)), the table's own theta_half axis.
    half: Distribution1D,
    /// Directional albedo at normal incidence, clamped to [0, 1] (`albedo`).
    albedo: Vec3,
}

/// Cell indices of a direction pair, as MERL's `lookup_brdf_val` computes them.
fn cell(wo: Vec3, wi: Vec3) -> Option<usize> {
    let h = (wo + wi).normalize_or_zero();
    if h == Vec3::ZERO {
        return None;
    }
    // Rotate wi by -phi_h about z, then by -theta_h about y: wi in the half vector's frame.
    // Sines and cosines come from h itself and angles from atan2, which keep their accuracy
    // near theta = 0 where acos loses it.
    let r = h.x.hypot(h.y);
    let (c, s) = if r > 0.0 { (h.x / r, h.y / r) } else { (1.0, 0.0) };
    let t = Vec3::new(c * wi.x + s * wi.y, -s * wi.x + c * wi.y, wi.z);
    let d = Vec3::new(h.z * t.x - r * t.z, t.y, r * t.x + h.z * t.z);
    let theta_h = r.atan2(h.z);
    let theta_d = d.x.hypot(d.y).atan2(d.z);
    let mut phi_d = d.y.atan2(d.x);
    if phi_d < 0.0 {
        phi_d += PI;
    }
    let ih = ((theta_h / FRAC_PI_2).max(0.0).sqrt() * THETA_HALF as f32) as usize;
    let id = (theta_d / FRAC_PI_2 * THETA_DIFF as f32) as usize;
    let ip = (phi_d / PI * PHI_DIFF as f32) as usize;
    Some(ip.min(PHI_DIFF - 1) + PHI_DIFF * (id.min(THETA_DIFF - 1) + THETA_DIFF * ih.min(THETA_HALF - 1)))
}

impl MerlTable {
    /// Reads a MERL .binary file (a regular file of the table's size, checked before it is
    /// read); the error is one line.
    pub fn load(path: &Path) -> Result<Self, String> {
        let fail = |e: String| format!("cannot read measured BRDF {}: {e}", path.display());
        let size = crate::memory::regular_file_size(path, FILE_BYTES as u64).map_err(fail)?;
        let mut bytes = Vec::with_capacity(size as usize);
        std::fs::File::open(path)
            .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, size), &mut bytes))
            .map_err(|e| fail(e.to_string()))?;
        Self::read(&bytes).map_err(|e| format!("measured BRDF {}: {e}", path.display()))
    }

    /// Parses the MERL binary layout: three i32 dimensions, then all red, all green and all
    /// blue values as f64. Negative values (unmeasured) become 0.
    pub fn read(bytes: &[u8]) -> Result<Self, String> {
        let dims: Vec<i32> =
            bytes.chunks_exact(4).take(3).map(|b| i32::from_le_bytes(b.try_into().expect("4 bytes"))).collect();
        if dims != [THETA_HALF as i32, THETA_DIFF as i32, PHI_DIFF as i32] {
            return Err(format!("not a MERL BRDF: dimensions {dims:?}, expected [90, 90, 180]"));
        }
        let data = &bytes[12..];
        if data.len() != 3 * CELLS * 8 {
            return Err(format!("{} bytes of samples, expected {}", data.len(), 3 * CELLS * 8));
        }
        let channel = |c: usize, i: usize| {
            let at = (c * CELLS + i) * 8;
            let v = f64::from_le_bytes(data[at..at + 8].try_into().expect("8 bytes")) * SCALE[c];
            if v.is_finite() { v.max(0.0) as f32 } else { 0.0 }
        };
        let values: Vec<Vec3> = (0..CELLS).map(|i| Vec3::new(channel(0, i), channel(1, i), channel(2, i))).collect();
        // Half vectors in proportion to the table's mean luminance over each theta_half
        // row, times the Jacobian from x to solid angle (sin cos theta_h dtheta_h / dx).
        let func = (0..THETA_HALF)
            .map(|k| {
                let row = &values[k * THETA_DIFF * PHI_DIFF..(k + 1) * THETA_DIFF * PHI_DIFF];
                let mean = row.iter().map(|&v| luminance(v)).sum::<f32>() / row.len() as f32;
                let x = (k as f32 + 0.5) / THETA_HALF as f32;
                let theta_h = x * x * FRAC_PI_2;
                mean * theta_h.sin() * theta_h.cos() * x * PI
            })
            .collect();
        let mut table = Self { values, half: Distribution1D::new(func), albedo: Vec3::ZERO };
        table.albedo = table.normal_albedo();
        Ok(table)
    }

    /// Directional albedo seen from the normal, the integral of f cos over the hemisphere,
    /// by the midpoint rule on 32 x 32 cosine-distributed directions (f pi each).
    fn normal_albedo(&self) -> Vec3 {
        const N: usize = 32;
        let mut sum = Vec3::ZERO;
        for i in 0..N * N {
            let u = Vec2::new(((i % N) as f32 + 0.5) / N as f32, ((i / N) as f32 + 0.5) / N as f32);
            sum += self.eval(Vec3::Z, warp::cos_hemisphere(u)) * PI;
        }
        (sum / (N * N) as f32).clamp(Vec3::ZERO, Vec3::ONE)
    }

    /// Directional albedo at normal incidence in [0, 1]: the denoiser's albedo feature.
    pub fn albedo(&self) -> Vec3 {
        self.albedo
    }

    /// f(wo, wi) (no cosine); zero unless both are above the surface.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        cell(wo, wi).map_or(Vec3::ZERO, |i| self.values[i])
    }

    /// A direction for `wo` from uniforms `u_lobe` (which of the two strategies) and `u`.
    pub fn sample_direction(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        if u_lobe < 0.5 {
            return Some(warp::cos_hemisphere(u));
        }
        let (x, _, _) = self.half.sample(u.x);
        let theta_h = x * x * FRAC_PI_2;
        let phi_h = 2.0 * PI * u.y;
        let (st, ct) = theta_h.sin_cos();
        let h = Vec3::new(st * phi_h.cos(), st * phi_h.sin(), ct);
        let wi = 2.0 * wo.dot(h) * h - wo;
        (wi.z > 0.0).then_some(wi)
    }

    /// Solid-angle density of `sample_direction`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let cosine = warp::cos_hemisphere_pdf(wi.z);
        let h = (wo + wi).normalize_or_zero();
        let sin_h = h.x.hypot(h.y);
        let theta_h = sin_h.atan2(h.z);
        let x = (theta_h / FRAC_PI_2).sqrt();
        let half = if sin_h > 1e-7 && h != Vec3::ZERO {
            let k = ((x * THETA_HALF as f32) as usize).min(THETA_HALF - 1);
            // p(x) -> p(theta_h) = p(x) / (x pi) -> p(h) = p(theta_h) / (2 pi sin) -> p(wi) / (4 wo.h).
            self.half.density(k) / (x * PI) / (2.0 * PI * sin_h) / (4.0 * wo.dot(h).abs())
        } else {
            0.0
        };
        0.5 * (cosine + half)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookups_are_reciprocal_and_fold_phi_diff() {
        let wo = Vec3::new(0.3, -0.2, 0.9).normalize();
        let wi = Vec3::new(-0.5, 0.4, 0.7).normalize();
        assert_eq!(cell(wo, wi), cell(wi, wo));
        let h = Vec3::Z;
        let mirror = 2.0 * wo.dot(h) * h - wo;
        assert_eq!(cell(wo, mirror).unwrap() / PHI_DIFF / THETA_DIFF, 0, "a mirror pair has theta_half 0");
        assert!(MerlTable::read(&[0; 12]).unwrap_err().contains("not a MERL BRDF"));
        // A device or a folder is refused before a byte is read (/dev/zero never ends).
        for path in ["/dev/zero", "/"] {
            let err = MerlTable::load(Path::new(path)).unwrap_err();
            assert!(err.contains("not a regular file") && err.contains(path), "{err}");
        }
    }
}

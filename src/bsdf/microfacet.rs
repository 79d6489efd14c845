//! The GGX (Trowbridge-Reitz) microfacet distribution: D, height-correlated Smith masking,
//! and sampling of visible normals (Dupuy and Benyoub 2023, "Sampling Visible GGX Normals
//! with Spherical Caps"), in the local frame, with widths alpha_x along local x and alpha_y
//! along local y (anisotropic GGX: Heitz 2014, "Understanding the Masking-Shadowing
//! Function in Microfacet-Based BRDFs", eqs. 85-86; Kulla and Conty 2017). Isotropic lobes
//! (alpha_x == alpha_y) keep the isotropic formulas.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// GGX with widths alpha_x, alpha_y along the local x and y axes (glTF: alpha = roughness^2;
/// KHR_materials_anisotropy widens alpha_x, the anisotropy direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    /// Width of the distribution along local x.
    pub alpha_x: f32,
    /// Width of the distribution along local y.
    pub alpha_y: f32,
}

impl Ggx {
    /// The isotropic distribution of width `alpha`.
    pub fn isotropic(alpha: f32) -> Self {
        Self { alpha_x: alpha, alpha_y: alpha }
    }

    /// Whether both widths are equal (the isotropic formulas apply).
    #[inline]
    pub fn is_isotropic(&self) -> bool {
        self.alpha_x == self.alpha_y
    }

    /// Normal distribution D(h) for a unit half vector h: 1 / (pi ax ay ((hx/ax)^2 +
    /// (hy/ay)^2 + hz^2)^2).
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        if self.is_isotropic() {
            let a2 = self.alpha_x * self.alpha_x;
            let k = h.z * h.z * (a2 - 1.0) + 1.0;
            return a2 / (PI * k * k);
        }
        let (x, y) = (h.x / self.alpha_x, h.y / self.alpha_y);
        let k = x * x + y * y + h.z * h.z;
        1.0 / (PI * self.alpha_x * self.alpha_y * k * k)
    }

    /// Smith's Lambda(w) for GGX: (sqrt(1 + (ax^2 wx^2 + ay^2 wy^2) / wz^2) - 1) / 2.
    pub fn lambda(&self, w: Vec3) -> f32 {
        let z2 = w.z * w.z;
        let a2_tan2 = if self.is_isotropic() {
            self.alpha_x * self.alpha_x * ((1.0 - z2).max(0.0) / z2)
        } else {
            let (x, y) = (w.x * self.alpha_x, w.y * self.alpha_y);
            (x * x + y * y) / z2
        };
        0.5 * ((1.0 + a2_tan2).sqrt() - 1.0)
    }

    /// Smith masking G1(w).
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G2(wo, wi) = 1 / (1 + Lambda(wo) + Lambda(wi)).
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// A half vector distributed as the normals visible from `wo` (wo.z > 0).
    pub fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let wo_std = Vec3::new(wo.x * self.alpha_x, wo.y * self.alpha_y, wo.z).normalize();
        let phi = 2.0 * PI * u.x;
        let z = (1.0 - u.y) * (1.0 + wo_std.z) - wo_std.z;
        let sin_theta = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
        let cap = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), z);
        let h_std = cap + wo_std;
        Vec3::new(h_std.x * self.alpha_x, h_std.y * self.alpha_y, h_std.z.max(0.0)).normalize()
    }

    /// Pdf of the direction wi = reflect(wo, h) when h is sampled by
    /// `sample_visible_normal`, given d = D(h): G1(wo) D(h) / (4 cos theta_o).
    pub fn reflection_pdf(&self, wo: Vec3, d: f32) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        self.g1(wo) * d / (4.0 * wo.z)
    }

    /// Density of `sample_visible_normal` at half vector h, given d = D(h):
    /// G1(wo) D(h) max(0, wo.h) / cos theta_o.
    pub fn visible_normal_pdf(&self, wo: Vec3, h: Vec3, d: f32) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        self.g1(wo) * d * wo.dot(h).max(0.0) / wo.z
    }
}

/// Unpolarised Fresnel reflectance of a dielectric interface for light arriving at cosine
/// `cos_i` (negative: from the other side) with relative index `eta` = n_transmitted /
/// n_incident for light arriving from the positive side. 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let (mut cos_i, mut eta) = (cos_i.clamp(-1.0, 1.0), eta);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (parallel * parallel + perpendicular * perpendicular)
}

/// Refraction of `wo` (pointing away, on the side `h` faces) through a surface with normal
/// `h` and relative index `eta` = n_other / n_wo. None under total internal reflection.
pub fn refract(wo: Vec3, h: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = wo.dot(h);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 || cos_i <= 0.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wo / eta + (cos_i / eta - cos_t) * h)
}

/// Mirror reflection of `wo` about `h`.
pub fn reflect(wo: Vec3, h: Vec3) -> Vec3 {
    2.0 * wo.dot(h) * h - wo
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d_is_normalised_over_projected_area() {
        for alpha in [0.1f32, 0.5, 1.0] {
            let g = Ggx::isotropic(alpha);
            let n = 4000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let cos_t = (i as f32 + 0.5) / n as f32;
                let h = Vec3::new((1.0 - cos_t * cos_t).sqrt(), 0.0, cos_t);
                sum += (g.d(h) * cos_t) as f64 * 2.0 * PI as f64 / n as f64;
            }
            assert!((sum - 1.0).abs() < 2e-3, "alpha {alpha}: {sum}");
        }
    }
}

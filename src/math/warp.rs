//! Warps from the unit square to directions and points, each next to its pdf.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Cosine-weighted hemisphere direction around +z (Malley's method via the concentric
/// disk map, Shirley and Chiu 1997); pdf `cos_hemisphere_pdf`.
pub fn cos_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Pdf (solid angle) of `cos_hemisphere`: cos(theta) / pi above the plane, 0 below.
pub fn cos_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform hemisphere direction around +z; pdf `uniform_hemisphere_pdf`.
pub fn uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Pdf (solid angle) of `uniform_hemisphere`: 1 / (2 pi).
pub const UNIFORM_HEMISPHERE_PDF: f32 = 0.5 * FRAC_1_PI;

/// Uniform direction on the unit sphere.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of `uniform_sphere`: 1 / (4 pi).
pub const UNIFORM_SPHERE_PDF: f32 = 0.25 * FRAC_1_PI;

/// Concentric map of the unit square onto the unit disk (Shirley and Chiu 1997).
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Uniform barycentrics on a triangle (b0, b1, b2); the area pdf is 1 / area.
/// Uses the square-root warp (Turk 1990).
pub fn uniform_triangle(u: Vec2) -> [f32; 3] {
    let su = u.x.sqrt();
    let b1 = su * (1.0 - u.y);
    let b2 = su * u.y;
    [1.0 - su, b1, b2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warps_return_unit_directions_in_the_upper_hemisphere() {
        for i in 0..64 {
            for j in 0..64 {
                let u = Vec2::new(i as f32 / 63.0, j as f32 / 63.0);
                for d in [cos_hemisphere(u), uniform_hemisphere(u)] {
                    assert!((d.length() - 1.0).abs() < 1e-5 && d.z >= 0.0);
                }
                let b = uniform_triangle(u);
                assert!(b.iter().all(|&x| (0.0..=1.0).contains(&x)));
                assert!((b.iter().sum::<f32>() - 1.0).abs() < 1e-6);
            }
        }
    }
}

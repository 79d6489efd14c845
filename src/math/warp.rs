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

/// Concentric map of the unit square onto the unit disk (Shirley and Chiu 1997). The angle
/// is pi/4 times a ratio in [-1, 1], or pi/2 less that, so cos and sin come from
/// `sin_cos_quarter` on [-pi/4, pi/4], swapped in the second case: no libm `sincosf` call.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    if o.x.abs() > o.y.abs() {
        let (sin, cos) = sin_cos_quarter(std::f32::consts::FRAC_PI_4 * (o.y / o.x));
        o.x * Vec2::new(cos, sin)
    } else {
        let (sin, cos) = sin_cos_quarter(std::f32::consts::FRAC_PI_4 * (o.x / o.y));
        o.y * Vec2::new(sin, cos)
    }
}

/// sin and cos of x in [-pi/4, pi/4], by the minimax polynomials of Cephes's `sinf` and
/// `cosf` kernels (Moshier 1989), within 2 ulp of the exact values there.
#[inline]
fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let sin = x + x * z * (-1.666_665_5e-1 + z * (8.332_161e-3 + z * -1.951_529_6e-4));
    let cos = 1.0 - 0.5 * z + z * z * (4.166_664_6e-2 + z * (-1.388_731_6e-3 + z * 2.443_315_7e-5));
    (sin, cos)
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
    #[test]
    fn quarter_sin_cos_is_within_two_ulp() {
        let ulp = |x: f64| (x.abs() as f32).next_up() as f64 - x.abs() as f32 as f64;
        for i in -100_000..=100_000 {
            let x = i as f32 / 100_000.0 * std::f32::consts::FRAC_PI_4;
            let (s, c) = sin_cos_quarter(x);
            let (es, ec) = (x as f64).sin_cos();
            assert!((s as f64 - es).abs() <= 2.0 * ulp(es).max(f32::MIN_POSITIVE as f64), "sin {x}: {s} against {es}");
            assert!((c as f64 - ec).abs() <= 2.0 * ulp(ec), "cos {x}: {c} against {ec}");
        }
    }

    #[test]
    fn the_concentric_map_agrees_with_its_trigonometric_form() {
        use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};
        for i in 0..=200 {
            for j in 0..=200 {
                let u = Vec2::new(i as f32, j as f32) / 200.0;
                let o = 2.0 * u - Vec2::ONE;
                let want = if o == Vec2::ZERO {
                    Vec2::ZERO
                } else if o.x.abs() > o.y.abs() {
                    let t = FRAC_PI_4 * (o.y / o.x);
                    o.x * Vec2::new(t.cos(), t.sin())
                } else {
                    let t = FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y);
                    o.y * Vec2::new(t.cos(), t.sin())
                };
                let got = concentric_disk(u);
                assert!((got - want).abs().max_element() < 2e-7, "{u}: {got} against {want}");
                assert!(got.length_squared() <= 1.0 + 2e-7);
            }
        }
    }

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

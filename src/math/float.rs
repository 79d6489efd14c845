//! Floating-point error bounds and scale-aware ray origin offsets (pbrt-v4 section 6.8).

use glam::Vec3;

/// Bound on the relative error of `n` chained f32 operations: n eps / (1 - n eps),
/// eps being half the machine epsilon (Higham 2002; pbrt-v4's `gamma`).
pub const fn gamma(n: i32) -> f32 {
    let e = n as f32 * (f32::EPSILON * 0.5);
    e / (1.0 - e)
}

/// Absolute error bound of a point interpolated from a triangle's vertices with
/// barycentrics `b` (pbrt-v4's triangle intersection: gamma(7) * sum |b_i p_i|).
pub fn interpolation_error(b: [f32; 3], p: [Vec3; 3]) -> Vec3 {
    gamma(7) * ((b[0] * p[0]).abs() + (b[1] * p[1]).abs() + (b[2] * p[2]).abs())
}

/// Moves `p`, whose coordinates are uncertain by `error`, off its surface (normal `n`)
/// to the side of `w`, far enough that a ray leaving from it cannot re-hit the surface,
/// then rounds away from the surface (pbrt-v4's `OffsetRayOrigin`). The offset scales
/// with the magnitude of the coordinates: there is no fixed epsilon.
pub fn offset_ray_origin(p: Vec3, error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(error);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let mut po = p + offset;
    for i in 0..3 {
        if offset[i] > 0.0 {
            po[i] = po[i].next_up();
        } else if offset[i] < 0.0 {
            po[i] = po[i].next_down();
        }
    }
    po
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_leaves_the_plane_on_the_requested_side_at_any_scale() {
        for scale in [1e-4f32, 1.0, 1e4, 1e5] {
            let p = [Vec3::ZERO, Vec3::X, Vec3::Y].map(|v| v * scale + Vec3::splat(scale));
            let b = [0.2, 0.3, 0.5];
            let x = p[0] * b[0] + p[1] * b[1] + p[2] * b[2];
            let e = interpolation_error(b, p);
            let up = offset_ray_origin(x, e, Vec3::Z, Vec3::Z);
            let down = offset_ray_origin(x, e, Vec3::Z, -Vec3::Z);
            assert!(up.z > x.z && down.z < x.z, "scale {scale}");
            assert!((up.z - x.z) < 1e-5 * scale.max(1.0) * 4.0, "offset stays small at {scale}");
        }
    }
}

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
#[inline]
pub fn offset_ray_origin(p: Vec3, error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(error);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let po = p + offset;
    Vec3::new(step(po.x, offset.x), step(po.y, offset.y), step(po.z, offset.z))
}

/// The float next to `x` in the direction of `dir`'s sign, as `f32::next_up` / `next_down`
/// give it (`x` itself for a zero `dir`), without their branches, which the signs of ray
/// offsets mispredict. Floats are stepped in sign-magnitude order, where both zeros are 0.
#[inline]
fn step(x: f32, dir: f32) -> f32 {
    let bits = x.to_bits() as i32;
    let ordered = if bits < 0 { -(bits & 0x7fff_ffff) } else { bits };
    let next = ordered + (dir > 0.0) as i32 - (dir < 0.0) as i32;
    let stepped = f32::from_bits(if next < 0 { next.unsigned_abs() | 0x8000_0000 } else { next as u32 });
    if dir == 0.0 || x.is_nan() || stepped.is_nan() { x } else { stepped }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_is_next_up_and_next_down() {
        let mut specials = vec![0.0f32, -0.0, f32::MIN_POSITIVE, -f32::MIN_POSITIVE, f32::MAX, f32::MIN, 1.0, -1.0];
        specials.extend([f32::INFINITY, f32::NEG_INFINITY, f32::from_bits(1), f32::from_bits(0x8000_0001)]);
        let mut bits = 0x2545_f491u32;
        let random = (0..100_000).map(|_| {
            bits ^= bits << 13;
            bits ^= bits >> 17;
            bits ^= bits << 5;
            f32::from_bits(bits)
        });
        for x in specials.into_iter().chain(random).filter(|x| !x.is_nan()) {
            assert_eq!(step(x, 1.0), x.next_up(), "{x:e} up");
            assert_eq!(step(x, -2.0), x.next_down(), "{x:e} down");
            assert_eq!(step(x, 0.0).to_bits(), x.to_bits(), "{x:e} stays");
        }
    }

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

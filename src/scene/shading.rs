//! Rules that keep interpolated (and, later, mapped) shading normals safe: bending a normal
//! so that reflections stay above the true surface, and the shadow-terminator offset.

use glam::Vec3;

/// The shading normal `ns`, bent towards the geometric normal `ng` just enough that the
/// mirror reflection of `wo` about it leaves the surface at least at a height
/// `min(0.9 wo.ng, 0.01)` (the rule of Keller et al. 2017, "The Iray light transport
/// simulation and rendering system", also used by Cycles). All vectors are unit length and
/// on the side of `wo`: `wo.ng > 0` and `ns.ng > 0`. Afterwards `wo.ns > 0`, so the view
/// direction is never below the shading hemisphere (no black pixels), and only the rare
/// normals that would reflect below the surface change.
///
/// With `ns = x X + z ng` in the plane of `ns` and `ng`, the condition is
/// `2 (x wo_x + z wo_z) z - wo_z = t` with `x = sqrt(1 - z^2)`; squaring gives the quadratic
/// `4 a z^4 - 2 b z^2 + c = 0` in `z^2`, with `a = wo_x^2 + wo_z^2`, `b = 2 (a + wo_z t)`,
/// `c = (t + wo_z)^2`, of which one root satisfies the unsquared equation: the larger one
/// when `wo_x < 0`, the smaller one otherwise.
pub fn bend_normal(ng: Vec3, wo: Vec3, ns: Vec3) -> Vec3 {
    let wo_z = wo.dot(ng);
    let threshold = (0.9 * wo_z).min(0.01);
    let reflected = 2.0 * wo.dot(ns) * ns - wo;
    if reflected.dot(ng) >= threshold {
        return ns;
    }
    let x_axis = (ns - ns.dot(ng) * ng).normalize_or_zero();
    if x_axis == Vec3::ZERO {
        return ng;
    }
    let wo_x = wo.dot(x_axis);
    let a = wo_x * wo_x + wo_z * wo_z;
    let b = 2.0 * (a + wo_z * threshold);
    let c = (threshold + wo_z) * (threshold + wo_z);
    let root = (b * b - 4.0 * a * c).max(0.0).sqrt();
    let z2 = if wo_x < 0.0 { 0.25 * (b + root) / a } else { 0.25 * (b - root) / a };
    let z2 = z2.clamp(0.0, 1.0);
    ((1.0 - z2).sqrt() * x_axis + z2.sqrt() * ng).normalize_or(ng)
}

/// The shadow-terminator offset of Hanika (2021, "Hacking the shadow terminator", Ray
/// Tracing Gems II ch. 4): the displacement that lifts the point `p`, at barycentrics `b`
/// of a triangle with vertices `v` and unit vertex normals `n` (on the side rays leave
/// to), onto the smooth surface those normals describe. Each vertex contributes the part of
/// `p - v_i` below its tangent plane, weighted by `b_i`. It is zero on flat triangles and
/// where the surface is concave; on a coarse convex mesh it moves ray origins off the
/// facets, so that points the shading normals light are not shadowed by their own facets.
pub fn terminator_offset(p: Vec3, b: [f32; 3], v: &[Vec3; 3], n: &[Vec3; 3]) -> Vec3 {
    let mut lift = Vec3::ZERO;
    for i in 0..3 {
        let below = (p - v[i]).dot(n[i]).min(0.0);
        lift -= b[i] * below * n[i];
    }
    lift
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{frame::Frame, sampler::Sampler, warp};
    use glam::UVec2;

    #[test]
    fn bent_normals_keep_the_view_above_and_the_reflection_above_the_surface() {
        let mut s = Sampler::new(UVec2::ZERO, 0, 3);
        let ng = Vec3::new(0.3, 0.9, -0.2).normalize();
        let frame = Frame::from_normal(ng);
        let mut bent = 0;
        for _ in 0..100_000 {
            let wo = frame.to_world(warp::uniform_hemisphere(s.next_2d()));
            let ns = frame.to_world(warp::uniform_hemisphere(s.next_2d()));
            if wo.dot(ng) <= 1e-6 || ns.dot(ng) <= 1e-6 {
                continue;
            }
            let out = bend_normal(ng, wo, ns);
            assert!((out.length() - 1.0).abs() < 1e-4, "{out} not unit");
            assert!(out.dot(wo) > 0.0, "view below the bent normal: wo {wo}, ns {ns} -> {out}");
            let r = 2.0 * wo.dot(out) * out - wo;
            let t = (0.9 * wo.dot(ng)).min(0.01);
            assert!(r.dot(ng) >= t - 2e-3, "reflection below the surface: {}", r.dot(ng));
            bent += (out != ns) as u32;
            if out != ns {
                // Bent no further than needed: the reflection lands on the threshold.
                assert!((r.dot(ng) - t).abs() < 2e-3, "{} vs {t}", r.dot(ng));
            }
        }
        assert!(bent > 1000, "the test exercised the bending branch only {bent} times");
    }

    #[test]
    fn normals_that_reflect_above_the_surface_are_unchanged() {
        let ng = Vec3::Z;
        let ns = Vec3::new(0.1, 0.0, 1.0).normalize();
        let wo = Vec3::new(0.2, 0.1, 1.0).normalize();
        assert_eq!(bend_normal(ng, wo, ns), ns);
    }

    #[test]
    fn terminator_offset_is_zero_on_flat_triangles_and_lifts_convex_ones() {
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let b = [0.2, 0.3, 0.5];
        let p = v[0] * b[0] + v[1] * b[1] + v[2] * b[2];
        assert_eq!(terminator_offset(p, b, &v, &[Vec3::Z; 3]), Vec3::ZERO);
        // Normals splayed outwards, as on a sphere: the point is lifted along +z.
        let n = v.map(|q| (q - Vec3::new(1.0 / 3.0, 1.0 / 3.0, -1.0)).normalize());
        let lift = terminator_offset(p, b, &v, &n);
        assert!(lift.z > 0.0, "{lift}");
        // Normals tilted inwards (concave): no offset.
        let n = v.map(|q| (Vec3::new(1.0 / 3.0, 1.0 / 3.0, 1.0) - q).normalize());
        assert_eq!(terminator_offset(p, b, &v, &n), Vec3::ZERO);
    }
}

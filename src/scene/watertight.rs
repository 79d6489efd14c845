//! The watertight ray/triangle test of Woop, Benthin and Wald (JCGT 2013), for one
//! triangle and for four at a time over triangles stored as structure of arrays.

use glam::{BVec4A, Vec3, Vec4};

use super::geometry::Ray;

/// Per-ray precomputation: the ray is sheared onto +z so that edge functions of shared
/// edges agree exactly, and ties are resolved in f64, so no ray slips between adjacent
/// triangles.
pub(super) struct Watertight {
    o: Vec3,
    k: [usize; 3],
    shear: Vec3,
}

/// A triangle's edge functions and the numerator of its distance, before the sign test.
struct Edges {
    u: f32,
    v: f32,
    w: f32,
    /// The three vertices' sheared z coordinates, each times its edge function, summed.
    t_num: f32,
}

impl Watertight {
    pub(super) fn new(ray: &Ray) -> Self {
        let d = ray.d;
        // The two other axes in cyclic order after the dominant one, swapped when the ray
        // runs along its negative direction (keeping the winding); a table instead of `% 3`.
        const AXES: [[usize; 2]; 3] = [[1, 2], [2, 0], [0, 1]];
        // `min` tells the compiler the index is in range (no bounds checks below).
        let kz = d.abs().max_position().min(2);
        let dz = d.to_array()[kz];
        let [mut kx, mut ky] = AXES[kz];
        if dz < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let (dx, dy) = (d.to_array()[kx], d.to_array()[ky]);
        let shear = Vec3::new(dx / dz, dy / dz, 1.0 / dz);
        Self { o: ray.o, k: [kx, ky, kz], shear }
    }

    /// Distance parameter in (0, tmax) and barycentrics, or None.
    #[inline]
    pub(super) fn intersect(&self, p: &[Vec3; 3], tmax: f32) -> Option<(f32, [f32; 3])> {
        let [kx, ky, kz] = self.k;
        // Plain arrays, whose indices the assertion bounds: indexing a glam vector by a
        // runtime axis is a chain of compares and branches.
        assert!(kx < 3 && ky < 3 && kz < 3);
        let s = self.shear;
        let (a, b, c) = ((p[0] - self.o).to_array(), (p[1] - self.o).to_array(), (p[2] - self.o).to_array());
        let (ax, ay) = (a[kx] - s.x * a[kz], a[ky] - s.y * a[kz]);
        let (bx, by) = (b[kx] - s.x * b[kz], b[ky] - s.y * b[kz]);
        let (cx, cy) = (c[kx] - s.x * c[kz], c[ky] - s.y * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let d = |x1: f32, y1: f32, x2: f32, y2: f32| (x1 as f64 * y2 as f64 - y1 as f64 * x2 as f64) as f32;
            u = d(cx, cy, bx, by);
            v = d(ax, ay, cx, cy);
            w = d(bx, by, ax, ay);
        }
        let t_num = u * (s.z * a[kz]) + v * (s.z * b[kz]) + w * (s.z * c[kz]);
        Edges { u, v, w, t_num }.finish(tmax)
    }

    /// The test on the four triangles `i..i + 4` of `tris` whose bits are set in `lanes`,
    /// within (0, `tmax`): a bit mask of the lanes that hit and, per lane, the edge
    /// functions and the distance. The arithmetic is `finish`'s and the scalar test's,
    /// operation for operation, so a lane's result is bit-identical to `intersect`'s; lanes
    /// with an edge function of exactly zero are flagged in the mask's high nibble instead,
    /// for the scalar test, which resolves them in f64.
    #[inline]
    fn intersect4(&self, tris: &SoaTriangles, i: usize, lanes: u32, tmax: f32) -> (u32, [Vec4; 4]) {
        let [kx, ky, kz] = self.k;
        let o = self.o.to_array();
        assert!(kx < 3 && ky < 3 && kz < 3);
        let (sx, sy, sz) = (Vec4::splat(self.shear.x), Vec4::splat(self.shear.y), Vec4::splat(self.shear.z));
        let vertex = |v: usize| {
            let load = |axis: usize| Vec4::from_slice(&tris.c[v * 3 + axis][i..i + 4]) - Vec4::splat(o[axis]);
            let (x, y, z) = (load(kx), load(ky), load(kz));
            (x - sx * z, y - sy * z, sz * z)
        };
        let (ax, ay, az) = vertex(0);
        let (bx, by, bz) = vertex(1);
        let (cx, cy, cz) = vertex(2);
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        let exact = u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero);
        let negative = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
        let positive = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
        let outside = BVec4A::bitmask(negative & positive) & !BVec4A::bitmask(exact);
        let inside = !outside & lanes & 0xf;
        let flagged = BVec4A::bitmask(exact) & inside;
        // `finish` for every lane at once: the lanes that miss drop out without a branch each.
        let det = u + v + w;
        let t = (u * az + v * bz + w * cz) / det;
        let hit = BVec4A::bitmask(det.cmpne(zero) & t.cmpgt(zero) & t.cmplt(Vec4::splat(tmax)));
        (inside & hit & !flagged | flagged << 4, [u, v, w, t])
    }
}

impl Edges {
    /// The sign test, the distance in (0, tmax) and the barycentrics.
    #[inline]
    fn finish(self, tmax: f32) -> Option<(f32, [f32; 3])> {
        let Self { u, v, w, t_num } = self;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let t = t_num / det;
        if !(t > 0.0 && t < tmax) {
            return None;
        }
        Some((t, barycentrics(u, v, w)))
    }
}

/// The barycentrics of a hit from its edge functions, each over their sum.
#[inline]
fn barycentrics(u: f32, v: f32, w: f32) -> [f32; 3] {
    let inv = 1.0 / (u + v + w);
    [u * inv, v * inv, w * inv]
}

/// Triangle vertex coordinates as nine arrays, `c[3 * vertex + axis][triangle]`, padded
/// by three zeros so that four consecutive triangles load from any start.
pub(super) struct SoaTriangles {
    c: [Vec<f32>; 9],
}

impl SoaTriangles {
    pub(super) fn new(positions: &[[Vec3; 3]]) -> Self {
        // Sized exactly: collecting first and then padding grew each row to twice its
        // length (37 MB more for a million triangles, kept for the whole render).
        let c = std::array::from_fn(|k| {
            let mut a = Vec::with_capacity(positions.len() + 3);
            a.extend(positions.iter().map(|p| p[k / 3][k % 3]));
            a.extend([0.0; 3]);
            a
        });
        Self { c }
    }
}

/// Hits of a group of up to 32 triangles `base + bit` (the bits of `group`), in the order
/// the scalar traversal tests them (highest bit first), each as the triangle, its distance
/// and barycentrics: `visit` returns false to stop. `tmax` is read before each quadruple,
/// so hits beyond a closer one already found are dropped early; `visit` must still
/// compare, since a quadruple's hits all come against the bound at its start.
#[inline]
pub(super) fn intersect_group(
    wt: &Watertight,
    tris: &SoaTriangles,
    positions: &[[Vec3; 3]],
    base: u32,
    group: u32,
    tmax: impl Fn() -> f32,
    mut visit: impl FnMut(u32, f32, [f32; 3]) -> bool,
) {
    if group == 0 {
        return;
    }
    let (lo, hi) = (group.trailing_zeros(), 31 - group.leading_zeros());
    let mut start = lo + (hi - lo) / 4 * 4;
    loop {
        let lanes = (group >> start) & 0xf;
        if lanes != 0 {
            let i = (base + start) as usize;
            let (mask, [u, v, w, t]) = wt.intersect4(tris, i, lanes, tmax());
            let (u, v, w, t) = (u.to_array(), v.to_array(), w.to_array(), t.to_array());
            let mut pending = (mask | mask >> 4) & 0xf;
            while pending != 0 {
                let lane = (31 - pending.leading_zeros()) as usize;
                pending &= !(1 << lane);
                let tri = i + lane;
                let hit = if mask >> (lane + 4) & 1 != 0 {
                    wt.intersect(&positions[tri], tmax())
                } else {
                    Some((t[lane], barycentrics(u[lane], v[lane], w[lane])))
                };
                if let Some((t, b)) = hit
                    && !visit(tri as u32, t, b)
                {
                    return;
                }
            }
        }
        if start == lo {
            return;
        }
        start -= 4;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::RngCore;
    use rand_pcg::Pcg32;

    fn uniform(rng: &mut Pcg32) -> f32 {
        (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }

    #[test]
    fn four_at_a_time_matches_the_scalar_test_bit_for_bit() {
        let mut s = Pcg32::new(7, 1);
        let v = |s: &mut Pcg32| Vec3::new(uniform(s), uniform(s), uniform(s)) * 2.0 - 1.0;
        // Random triangles, then triangles sharing edges and vertices on a grid, where rays
        // through the grid's points give edge functions of exactly zero (lanes handed to
        // the scalar test).
        let mut positions: Vec<[Vec3; 3]> = (0..40).map(|_| [v(&mut s), v(&mut s), v(&mut s)]).collect();
        for y in 0..4 {
            for x in 0..4 {
                let p = |dx: i32, dy: i32| Vec3::new((x + dx) as f32 * 0.25, (y + dy) as f32 * 0.25, 0.5);
                positions.push([p(0, 0), p(1, 0), p(1, 1)]);
                positions.push([p(0, 0), p(1, 1), p(0, 1)]);
            }
        }
        let tris = SoaTriangles::new(&positions);
        let (mut hits, mut exact) = (0, 0);
        for r in 0..2000 {
            let ray = if r % 2 == 0 {
                Ray { o: v(&mut s) * 3.0, d: v(&mut s), tmax: f32::INFINITY }
            } else {
                let q = Vec3::new((r % 5) as f32 * 0.25, (r / 5 % 5) as f32 * 0.25, 0.5);
                let o = Vec3::new(q.x, q.y, 2.0);
                Ray { o, d: q - o, tmax: f32::INFINITY }
            };
            let wt = Watertight::new(&ray);
            let tmax = 1e30;
            let base = (r % 48) as u32;
            let group = (uniform(&mut s) * (1u32 << 24) as f32) as u32 | 1;
            let mut got = Vec::new();
            intersect_group(
                &wt,
                &tris,
                &positions,
                base,
                group,
                || tmax,
                |tri, t, b| {
                    got.push((tri, t, b));
                    true
                },
            );
            let want: Vec<_> = (0..24)
                .rev()
                .filter(|bit| group >> bit & 1 != 0)
                .filter_map(|bit| {
                    let tri = base + bit;
                    wt.intersect(&positions[tri as usize], tmax).map(|(t, b)| (tri, t, b))
                })
                .collect();
            assert_eq!(got.len(), want.len(), "ray {r}");
            for (g, w) in got.iter().zip(&want) {
                assert_eq!((g.0, g.1.to_bits()), (w.0, w.1.to_bits()), "ray {r}");
                assert_eq!(g.2.map(f32::to_bits), w.2.map(f32::to_bits), "ray {r}");
            }
            hits += want.len();
            exact += (r % 2 == 1 && !want.is_empty()) as usize;
        }
        assert!(hits > 500 && exact > 100, "the rays must hit, also on shared edges: {hits} {exact}");
    }

    #[test]
    fn rows_hold_the_triangles_and_their_padding_and_no_more() {
        let positions: Vec<[Vec3; 3]> = (0..1000).map(|i| [Vec3::splat(i as f32), Vec3::X, Vec3::Y]).collect();
        let soa = SoaTriangles::new(&positions);
        for (k, row) in soa.c.iter().enumerate() {
            assert_eq!((row.len(), row.capacity()), (1003, 1003), "row {k}");
            assert_eq!(row[999], positions[999][k / 3][k % 3]);
            assert_eq!(&row[1000..], &[0.0; 3]);
        }
    }
}

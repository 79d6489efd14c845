//! An eight-wide BVH with full-precision child boxes, its eight slab tests done at once
//! (Ernst and Greiner 2008, Wald et al. 2008: one ray against a wide node). The topology is
//! obvhs's compressed wide BVH (Ylitie et al. 2017); the boxes are recomputed exactly from the
//! primitives' boxes instead of dequantised, and the slab test is pbrt-v4's conservative one
//! (`Bounds3::IntersectP`, section 6.8.2: far distances scaled by 1 + 2 gamma(3)).

use glam::Vec3;
use obvhs::{aabb::Aabb, cwbvh::CwBvh};
use std::cell::Cell;

use crate::math::float::gamma;

/// Lanes per node.
const WIDTH: usize = 8;

/// Stack entries traversal keeps in place; deeper trees get a heap stack of `Wide::stack`.
const INLINE_STACK: usize = 64;

/// Eight child boxes and what each child is.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    /// `[min x, max x, min y, max y, min z, max z]`, one lane per child; empty slots hold
    /// the empty box (+inf, -inf), which no ray enters.
    planes: [[f32; WIDTH]; 6],
    /// An inner child's node index, or a leaf's primitives as bits above `first`.
    child: [u32; WIDTH],
    /// Bit i set: slot i is an inner node.
    inner: u32,
    /// The first primitive of the node's leaves.
    first: u32,
}

/// A stack entry: a node and the distance at which the ray enters its box.
#[derive(Clone, Copy, Default)]
struct Entry {
    node: u32,
    t: f32,
}

/// The BVH: nodes, the root first, over primitives in obvhs's order.
pub(super) struct Wide {
    nodes: Vec<Node>,
    /// The most stack entries a traversal can hold.
    stack: usize,
}

/// A ray prepared for slab tests: origin, reciprocal direction and, per axis, which of the
/// planes (min or max) the ray meets first.
pub(super) struct SlabRay {
    o: Vec3,
    inv: Vec3,
    near: [usize; 3],
}

impl SlabRay {
    /// Zero direction components get a reciprocal of 1e30 (finite, so no 0 x inf NaN), whose
    /// slab distances are beyond any scene unless the origin lies on the plane.
    pub(super) fn new(o: Vec3, d: Vec3) -> Self {
        let d = d + Vec3::ZERO;
        let limit = Vec3::splat(1e30);
        let inv = Vec3::select(d.cmpeq(Vec3::ZERO), limit, (Vec3::ONE / d).clamp(-limit, limit));
        let near = std::array::from_fn(|a| 2 * a + (inv[a] < 0.0) as usize);
        Self { o, inv, near }
    }
}

impl Wide {
    /// Rebuilds obvhs's CWBVH with exact child boxes: a leaf's box bounds its primitives'
    /// `boxes` (in obvhs's primitive order), an inner child's bounds its own children's.
    pub(super) fn new(bvh: &CwBvh, boxes: &[Aabb]) -> Self {
        if bvh.nodes.is_empty() {
            return Self { nodes: Vec::new(), stack: 0 };
        }
        let empty = [[f32::INFINITY; WIDTH], [f32::NEG_INFINITY; WIDTH]];
        let mut nodes: Vec<Node> = bvh
            .nodes
            .iter()
            .map(|n| Node {
                planes: [empty[0], empty[1], empty[0], empty[1], empty[0], empty[1]],
                child: [0; WIDTH],
                inner: 0,
                first: n.primitive_base_idx,
            })
            .collect();
        // Children come after their parents: fill the nodes from the last one backwards, so
        // that an inner child's box is known when its parent takes it.
        let mut bounds = vec![Aabb::INVALID; nodes.len()];
        for (n, cw) in bvh.nodes.iter().enumerate().rev() {
            let mut total = Aabb::INVALID;
            for (slot, &meta) in cw.child_meta.iter().enumerate() {
                let (child, b) = if cw.imask >> slot & 1 == 1 {
                    let index = cw.child_base_idx + (cw.imask as u32 & ((1 << slot) - 1)).count_ones();
                    assert!(index as usize > n, "CWBVH children follow their parents");
                    nodes[n].inner |= 1 << slot;
                    (index, bounds[index as usize])
                } else if meta != 0 {
                    let (bits, offset) = ((meta >> 5) as u32, (meta & 31) as u32);
                    let first = (cw.primitive_base_idx + offset) as usize;
                    let b = boxes[first..first + bits.count_ones() as usize]
                        .iter()
                        .fold(Aabb::INVALID, |acc, b| acc.union(b));
                    (bits << offset, b)
                } else {
                    continue;
                };
                nodes[n].child[slot] = child;
                for a in 0..3 {
                    nodes[n].planes[2 * a][slot] = b.min[a];
                    nodes[n].planes[2 * a + 1][slot] = b.max[a];
                }
                total = total.union(&b);
            }
            bounds[n] = total;
        }
        // The stack holds, at most, one entry per inner child hit but not entered along the
        // way down, plus the root's.
        let mut need = vec![0usize; nodes.len()];
        for n in (0..nodes.len()).rev() {
            let inner = nodes[n].inner;
            let below = (0..WIDTH).filter(|s| inner >> s & 1 == 1).map(|s| need[nodes[n].child[s] as usize]).max();
            need[n] = below.map_or(0, |b| b + inner.count_ones() as usize - 1);
        }
        Self { stack: need[0] + 1, nodes }
    }

    /// Bytes the nodes take.
    pub(super) fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
    }

    /// Visits the leaves whose boxes the ray enters within `tmax`, handing `leaves` each
    /// node's hit leaves at once, as a first primitive and a bit per primitive above it.
    /// `leaves` may lower `tmax` and returns false to stop. With `ordered`, inner nodes are
    /// entered nearest first, and skipped when `tmax` has dropped below their entry.
    #[inline]
    pub(super) fn traverse(
        &self,
        ray: &SlabRay,
        tmax: &Cell<f32>,
        ordered: bool,
        leaves: impl FnMut(u32, u32) -> bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let mut inline = [Entry::default(); INLINE_STACK];
        let mut heap = Vec::new();
        let stack = if self.stack <= INLINE_STACK {
            &mut inline[..]
        } else {
            heap.resize(self.stack, Entry::default());
            &mut heap[..]
        };
        self.walk(stack, ray, tmax, ordered, leaves);
    }

    /// `traverse` with a stack of at least `self.stack` entries.
    #[inline]
    fn walk(
        &self,
        stack: &mut [Entry],
        ray: &SlabRay,
        tmax: &Cell<f32>,
        ordered: bool,
        mut leaves: impl FnMut(u32, u32) -> bool,
    ) {
        stack[0] = Entry { node: 0, t: 0.0 };
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let Entry { node, t } = stack[len];
            if ordered && t > tmax.get() {
                continue;
            }
            let mut node = &self.nodes[node as usize];
            loop {
                let (hits, near) = slabs(node, ray, tmax.get());
                let (inner, leaf) = (hits & node.inner, hits & !node.inner);
                if leaf != 0 {
                    let group = bits(leaf).fold(0, |g, s| g | node.child[s]);
                    if !leaves(node.first, group) {
                        return;
                    }
                }
                if inner == 0 {
                    break;
                }
                // Go on into one inner child hit, the nearest if `ordered`, and push the
                // others, keeping the stack's top nearest.
                let mut children = bits(inner).map(|s| Entry { node: node.child[s], t: near[s] });
                let mut next = children.next().expect("an inner child was hit");
                let start = len;
                for mut e in children {
                    if ordered && e.t < next.t {
                        std::mem::swap(&mut e, &mut next);
                    }
                    stack[len] = e;
                    let mut k = len;
                    len += 1;
                    while ordered && k > start && stack[k - 1].t < stack[k].t {
                        stack.swap(k - 1, k);
                        k -= 1;
                    }
                }
                node = &self.nodes[next.node as usize];
            }
        }
    }
}

/// The positions of the bits set in `mask`, lowest first.
pub(super) fn bits(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        let s = mask.trailing_zeros();
        mask &= mask.wrapping_sub(1);
        (s < 32).then_some(s as usize)
    })
}

/// Bound on the relative rounding of a slab distance, (b - o) / d (pbrt-v4, section 6.8.2).
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// The slab test of the ray against the node's eight boxes within [0, `tmax`]: a bit per
/// box entered, and the distances at which the ray enters them.
#[cfg(target_feature = "avx")]
#[inline]
fn slabs(node: &Node, ray: &SlabRay, tmax: f32) -> (u32, [f32; WIDTH]) {
    use std::arch::x86_64::*;
    let (o, inv) = (ray.o.to_array(), ray.inv.to_array());
    let [nx, ny, nz] = ray.near;
    let mut out = [0.0; WIDTH];
    // SAFETY: the intrinsics need AVX, which this build has (the `cfg` above); the loads
    // and the store are of [f32; 8] arrays, 32 bytes, unaligned. Eight lanes at once
    // instead of two halves: the node test is most of traversal.
    let hit = unsafe {
        let dist = |axis: usize, row: usize| {
            let planes = _mm256_loadu_ps(node.planes[row].as_ptr());
            _mm256_mul_ps(_mm256_sub_ps(planes, _mm256_set1_ps(o[axis])), _mm256_set1_ps(inv[axis]))
        };
        let near =
            _mm256_max_ps(_mm256_max_ps(dist(0, nx), dist(1, ny)), _mm256_max_ps(dist(2, nz), _mm256_setzero_ps()));
        let far = _mm256_min_ps(_mm256_min_ps(dist(0, nx ^ 1), dist(1, ny ^ 1)), dist(2, nz ^ 1));
        let far = _mm256_min_ps(_mm256_mul_ps(far, _mm256_set1_ps(FAR_SCALE)), _mm256_set1_ps(tmax));
        _mm256_storeu_ps(out.as_mut_ptr(), near);
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
    };
    (hit, out)
}

/// `slabs` one lane at a time, for builds without AVX; the same operations in the same
/// order, so both give the same bits.
#[cfg(any(test, not(target_feature = "avx")))]
#[cfg_attr(all(test, target_feature = "avx"), allow(dead_code))]
fn slabs_portable(node: &Node, ray: &SlabRay, tmax: f32) -> (u32, [f32; WIDTH]) {
    let (o, inv) = (ray.o.to_array(), ray.inv.to_array());
    let max = |a: f32, b: f32| if a > b { a } else { b };
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let mut near = [0.0; WIDTH];
    let mut hit = 0;
    for (s, near) in near.iter_mut().enumerate() {
        let dist = |axis: usize, row: usize| (node.planes[row][s] - o[axis]) * inv[axis];
        let [nx, ny, nz] = ray.near;
        *near = max(max(dist(0, nx), dist(1, ny)), max(dist(2, nz), 0.0));
        let far = min(min(min(dist(0, nx ^ 1), dist(1, ny ^ 1)), dist(2, nz ^ 1)) * FAR_SCALE, tmax);
        hit |= ((*near <= far) as u32) << s;
    }
    (hit, near)
}

#[cfg(not(target_feature = "avx"))]
use slabs_portable as slabs;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::blas::build_bvh;
    use rand_core::RngCore;
    use rand_pcg::Pcg32;

    fn uniform(rng: &mut Pcg32) -> f32 {
        (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }

    fn point(rng: &mut Pcg32) -> Vec3 {
        Vec3::new(uniform(rng), uniform(rng), uniform(rng)) * 2.0 - 1.0
    }

    /// Random boxes (some flat, some degenerate to a point) and the wide BVH over them, built
    /// as the meshes' BVHs are.
    fn boxes(rng: &mut Pcg32, n: usize) -> (Vec<Aabb>, Wide) {
        let boxes: Vec<Aabb> = (0..n)
            .map(|i| {
                let c = point(rng) * 10.0;
                let mut e = (point(rng) + 1.0) * 0.3;
                e[i % 3] *= (i % 4 != 0) as u32 as f32;
                Aabb::new((c - e).into(), (c + e).into())
            })
            .collect();
        let (bvh, _) = build_bvh(&boxes);
        let ordered: Vec<Aabb> = bvh.primitive_indices.iter().map(|&i| boxes[i as usize]).collect();
        let wide = Wide::new(&bvh, &ordered);
        (ordered, wide)
    }

    /// pbrt-v4's slab test of one box in f64: whether the ray enters it within [0, tmax].
    fn enters(b: &Aabb, o: Vec3, d: Vec3, tmax: f32) -> Option<f64> {
        let (mut t0, mut t1) = (0.0f64, tmax as f64);
        for a in 0..3 {
            let inv = 1.0 / d[a] as f64;
            let (n, f) = ((b.min[a] as f64 - o[a] as f64) * inv, (b.max[a] as f64 - o[a] as f64) * inv);
            let (n, f) = if n > f { (f, n) } else { (n, f) };
            (t0, t1) = (t0.max(n), t1.min(f));
        }
        (t0 <= t1).then_some(t0)
    }

    #[test]
    fn node_tests_agree_and_are_conservative() {
        let mut rng = Pcg32::new(11, 5);
        let (_, wide) = boxes(&mut rng, 3000);
        let mut checked = 0;
        for r in 0..400 {
            let o = point(&mut rng) * 15.0;
            let mut d = point(&mut rng);
            // Axis-parallel rays, with zero and negative-zero components.
            if r % 5 == 0 {
                d = Vec3::new(d.x, 0.0, -0.0);
            }
            let ray = SlabRay::new(o, d);
            for node in &wide.nodes {
                let tmax = if r % 2 == 0 { f32::INFINITY } else { 12.0 };
                let (hit, near) = slabs(node, &ray, tmax);
                assert_eq!((hit, near.map(f32::to_bits)), {
                    let (h, n) = slabs_portable(node, &ray, tmax);
                    (h, n.map(f32::to_bits))
                });
                for s in 0..WIDTH {
                    let lo = Vec3::new(node.planes[0][s], node.planes[2][s], node.planes[4][s]);
                    let hi = Vec3::new(node.planes[1][s], node.planes[3][s], node.planes[5][s]);
                    if lo.x > hi.x || d.cmpeq(Vec3::ZERO).any() {
                        continue;
                    }
                    let exact = enters(&Aabb::new(lo.into(), hi.into()), o, d, tmax);
                    if exact.is_some() {
                        assert!(hit >> s & 1 == 1, "ray {r}: a box the ray enters is missed");
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    #[test]
    fn traversal_finds_every_box_on_the_ray() {
        let mut rng = Pcg32::new(3, 9);
        let (ordered, wide) = boxes(&mut rng, 5000);
        assert!(wide.stack > 1 && wide.nodes.len() > 100);
        for r in 0..300 {
            let (o, d) = (point(&mut rng) * 15.0, point(&mut rng));
            let tmax = if r % 2 == 0 { f32::INFINITY } else { 8.0 };
            let want: Vec<u32> =
                (0..ordered.len() as u32).filter(|&i| enters(&ordered[i as usize], o, d, tmax).is_some()).collect();
            let mut sets = Vec::new();
            for ordered_walk in [false, true] {
                let mut got = Vec::new();
                wide.traverse(&SlabRay::new(o, d), &Cell::new(tmax), ordered_walk, |first, group| {
                    got.extend((0..32).filter(|b| group >> b & 1 == 1).map(|b| first + b));
                    true
                });
                got.sort_unstable();
                assert!(got.windows(2).all(|w| w[0] < w[1]), "ray {r}: a leaf visited twice");
                // Every box the exact test enters is visited (with the others of its leaf).
                assert!(want.iter().all(|i| got.binary_search(i).is_ok()), "ray {r} ({ordered_walk})");
                sets.push(got);
            }
            assert_eq!(sets[0], sets[1], "ray {r}: without a bound, the order changes nothing");
        }
    }

    #[test]
    fn ordered_traversal_goes_nearest_first_and_skips_what_lies_beyond_the_bound() {
        let mut rng = Pcg32::new(8, 1);
        let (ordered, wide) = boxes(&mut rng, 5000);
        let mut visits = [0usize; 2];
        for r in 0..300 {
            let (o, d) = (point(&mut rng) * 15.0, point(&mut rng));
            for ordered_walk in [false, true] {
                // The bound drops to the nearest box entered so far, as a closest-hit
                // query's does: with `ordered`, nothing entered only beyond it is visited.
                let bound = Cell::new(f32::INFINITY);
                wide.traverse(&SlabRay::new(o, d), &bound, ordered_walk, |first, group| {
                    visits[ordered_walk as usize] += 1;
                    let group_boxes = || (0..32).filter(|b| group >> b & 1 == 1).map(|b| ordered[(first + b) as usize]);
                    let entries: Vec<f64> = group_boxes().filter_map(|b| enters(&b, o, d, f32::INFINITY)).collect();
                    if ordered_walk && bound.get() < f32::INFINITY {
                        // Each leaf handed over was entered before the bound; a leaf's box
                        // bounds its boxes (each of which the ray may enter only later), so
                        // the box around the whole group is entered before the bound.
                        let b = bound.get() as f64;
                        let around = group_boxes().fold(Aabb::INVALID, |a, x| a.union(&x));
                        let t = enters(&around, o, d, f32::INFINITY);
                        assert!(t.is_some_and(|t| t <= b * 1.001 + 1e-3), "ray {r}: visited past {b}");
                    }
                    let nearest = entries.into_iter().fold(f64::INFINITY, f64::min);
                    bound.set(bound.get().min(nearest as f32 * 1.0001 + 1e-4));
                    true
                });
            }
        }
        assert!(visits[1] * 10 < visits[0] * 8, "nearest first visits fewer leaves: {visits:?}");
    }
}

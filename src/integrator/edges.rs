//! The edges of emitters a camera sees, by their exact pixel coverage: a control variate
//! for the emission camera rays find (Lafortune and Willems 1994; in image space, Rousselle
//! et al. 2016). Where a pixel's square straddles the outline of a directly seen emitting
//! triangle of uniform radiance Le, a sample at film position u adds
//! `Le (coverage - [u inside the outline])`: its expectation over the pixel is zero, so the
//! estimate stays unbiased, and where nothing hides the emitter it cancels the coin toss of
//! which side of the edge u fell on. The outline is the triangle projected through the
//! pinhole (`RayGenerator::film_position`), a triangle on the film; its coverage of the
//! pixel is the area of their intersection (Sutherland and Hodgman 1974's clipping, then
//! the shoelace formula). Pixels inside an outline or outside it gain nothing and get no
//! entry, and neither do those where camera rays through the covered part find something
//! else first (`seen`): there the term would only add noise.

use crate::scene::{Scene, camera::RayGenerator};
use glam::{DVec2, DVec3, UVec2, Vec2, Vec3};

/// Most emitting triangles whose outlines are set up per view; a view with more seen
/// from the front gets no control variate (any subset would do, but the set-up's time
/// grows with their pixels).
const MAX_OUTLINES: usize = 1 << 16;

/// Most pixels the outlines' bounding boxes may hold together, per pixel of the film (plus
/// a fixed allowance): beyond that, no control variate, so that the set-up stays linear in
/// the film (each of those pixels costs a corner test, and an edge's pixels a clipping).
const MAX_BOX_PIXELS_PER_PIXEL: u64 = 4;

/// A projected emitting triangle: three edge functions, each non-negative inside, and its
/// linear RGB radiance.
#[derive(Clone, Copy, Debug)]
struct Outline {
    edges: [DVec3; 3],
    radiance: Vec3,
}

impl Outline {
    /// Whether film position `u` lies inside (edges included).
    fn contains(&self, u: DVec2) -> bool {
        self.edges.iter().all(|e| e.x * u.x + e.y * u.y + e.z >= 0.0)
    }
}

/// A pixel an outline partly covers.
#[derive(Clone, Copy, Debug)]
struct Entry {
    /// Pixel column.
    x: u32,
    /// Index into `outlines`.
    outline: u32,
    /// Fraction of the pixel inside the outline.
    coverage: f32,
}

/// The partly covered pixels of one view, row by row.
#[derive(Clone, Debug, Default)]
pub struct EmitterEdges {
    outlines: Vec<Outline>,
    /// Entries of row y: `entries[rows[y]..rows[y + 1]]`, by column.
    rows: Vec<u32>,
    entries: Vec<Entry>,
}

impl EmitterEdges {
    /// The outlines of `scene`'s emitting triangles of uniform radiance seen from the
    /// front through `rays` on a `width` x `height` film, wholly in front of the camera.
    pub fn new(scene: &Scene, rays: &RayGenerator, width: u32, height: u32) -> Self {
        if !scene.features.emissive {
            return Self::default();
        }
        let geometry = &scene.geometry;
        let mut outlines = Vec::new();
        let mut boxes = Vec::new();
        let mut box_pixels = 0u64;
        let last = DVec2::new(width as f64 - 1.0, height as f64 - 1.0);
        for (tri, material) in geometry.materials() {
            let Some(le) = scene.materials[material as usize].uniform_emission() else { continue };
            let radiance = le.to_rgb();
            if radiance.max_element() <= 0.0 {
                continue;
            }
            let p = geometry.positions(tri);
            // Camera rays see the front of an emitter where their direction opposes its normal.
            if geometry.attrs(tri).ng.dot(p[0] - rays.origin()) >= 0.0 {
                continue;
            }
            let [Some(a), Some(b), Some(c)] = p.map(|v| rays.film_position(v)) else { continue };
            let Some(edges) = edge_functions([a, b, c]) else { continue };
            // The pixels the outline's bounding box touches on the film.
            let lo = a.min(b).min(c).floor().max(DVec2::ZERO);
            let hi = a.max(b).max(c).floor().min(last);
            if lo.x > hi.x || lo.y > hi.y {
                continue;
            }
            if outlines.len() == MAX_OUTLINES {
                return Self::default();
            }
            let (lo, hi) = (lo.as_uvec2(), hi.as_uvec2());
            box_pixels += (hi - lo + UVec2::ONE).as_u64vec2().element_product();
            if box_pixels > MAX_BOX_PIXELS_PER_PIXEL * (width as u64 * height as u64) + (1 << 20) {
                return Self::default();
            }
            outlines.push(Outline { edges, radiance });
            boxes.push((lo, hi, tri));
        }
        let mut by_row: Vec<Vec<Entry>> = vec![Vec::new(); height as usize];
        for (index, (outline, (lo, hi, tri))) in outlines.iter().zip(boxes).enumerate() {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let (coverage, polygon) = clipped(outline, x as f64, y as f64);
                    if coverage > 0.0 && coverage < 1.0 && seen(scene, rays, tri, &polygon) {
                        by_row[y as usize].push(Entry { x, outline: index as u32, coverage: coverage as f32 });
                    }
                }
            }
        }
        let mut rows = Vec::with_capacity(height as usize + 1);
        let mut entries = Vec::new();
        rows.push(0);
        for mut row in by_row {
            row.sort_by_key(|e| e.x);
            entries.extend(row);
            rows.push(entries.len() as u32);
        }
        if entries.is_empty() {
            return Self::default();
        }
        Self { outlines, rows, entries }
    }

    /// The outlines that partly cover `pixel` (none outside the film).
    pub fn pixel(&self, pixel: UVec2) -> PixelEdges<'_> {
        let Some(range) = self.rows.get(pixel.y as usize..pixel.y as usize + 2) else {
            return PixelEdges { outlines: &[], entries: &[] };
        };
        let row = &self.entries[range[0] as usize..range[1] as usize];
        let start = row.partition_point(|e| e.x < pixel.x);
        let end = start + row[start..].partition_point(|e| e.x == pixel.x);
        PixelEdges { outlines: &self.outlines, entries: &row[start..end] }
    }
}

/// The outlines partly covering one pixel, looked up once for all its samples.
#[derive(Clone, Copy, Debug)]
pub struct PixelEdges<'a> {
    outlines: &'a [Outline],
    entries: &'a [Entry],
}

impl PixelEdges<'_> {
    /// No outline partly covers the pixel.
    pub const NONE: PixelEdges<'static> = PixelEdges { outlines: &[], entries: &[] };

    /// Whether no outline partly covers the pixel.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// What a sample of `pixel` at `offset` in it adds: for each outline, its radiance
    /// times (coverage - whether the sample lies inside). The position is taken exactly,
    /// in f64, so that the term's mean over the pixel is zero to the offsets' resolution
    /// even where the film's f32 positions round.
    pub fn correction(&self, pixel: UVec2, offset: Vec2) -> Vec3 {
        let u = pixel.as_dvec2() + offset.as_dvec2();
        self.entries.iter().fold(Vec3::ZERO, |sum, e| {
            let outline = &self.outlines[e.outline as usize];
            let inside = outline.contains(u) as u32 as f32;
            sum + outline.radiance * (e.coverage - inside)
        })
    }
}

/// The edge functions of the film triangle `q`, oriented to be non-negative inside; None
/// for a triangle of no area.
fn edge_functions(q: [DVec2; 3]) -> Option<[DVec3; 3]> {
    let area2 = (q[1] - q[0]).perp_dot(q[2] - q[0]);
    if area2 == 0.0 || !area2.is_finite() {
        return None;
    }
    let sign = area2.signum();
    Some(std::array::from_fn(|i| {
        let (a, b) = (q[i], q[(i + 1) % 3]);
        // (b - a) x (u - a) >= 0 on the inner side of a counter-clockwise triangle.
        let n = DVec2::new(a.y - b.y, b.x - a.x) * sign;
        DVec3::new(n.x, n.y, -n.dot(a))
    }))
}

/// The part of pixel [x, x + 1] x [y, y + 1] inside `outline`: its area, and its corners
/// where the outline's edges cross the pixel (none where all four corners lie outside one
/// edge or inside all three, whose area is 0 or 1 without clipping).
fn clipped(outline: &Outline, x: f64, y: f64) -> (f64, Vec<DVec2>) {
    let corners = [DVec2::new(x, y), DVec2::new(x + 1.0, y), DVec2::new(x + 1.0, y + 1.0), DVec2::new(x, y + 1.0)];
    let side = |e: &DVec3, c: DVec2| e.x * c.x + e.y * c.y + e.z;
    let mut all_inside = true;
    for e in &outline.edges {
        let inside = corners.iter().filter(|&&c| side(e, c) >= 0.0).count();
        if inside == 0 {
            return (0.0, Vec::new());
        }
        all_inside &= inside == 4;
    }
    if all_inside {
        return (1.0, Vec::new());
    }
    let mut polygon = corners.to_vec();
    for e in &outline.edges {
        polygon = clip(&polygon, |c| side(e, c));
        if polygon.len() < 3 {
            return (0.0, Vec::new());
        }
    }
    let twice: f64 = (0..polygon.len()).map(|i| polygon[i].perp_dot(polygon[(i + 1) % polygon.len()])).sum();
    ((0.5 * twice.abs()).clamp(0.0, 1.0), polygon)
}

/// Whether camera rays through the middle of `polygon` and through its corners (moved a
/// twentieth of the way to the middle) all meet emitting triangle `tri` first. Where they
/// do not, something hides the emitter there (an occluder, the glass of a bulb around a
/// filament), and the control variate would only add its noise to the pixel. Which pixels
/// get the term depends on the view alone, not on the samples: the estimate stays unbiased.
fn seen(scene: &Scene, rays: &RayGenerator, tri: u32, polygon: &[DVec2]) -> bool {
    let middle = polygon.iter().sum::<DVec2>() / polygon.len() as f64;
    std::iter::once(middle).chain(polygon.iter().map(|&c| c + (middle - c) * 0.05)).all(|p| {
        let ray = rays.ray(p.as_vec2());
        scene.intersect(&ray, true, true).is_some_and(|hit| hit.tri == tri)
    })
}

/// The part of convex `polygon` where `side` is non-negative (one Sutherland-Hodgman step).
fn clip(polygon: &[DVec2], side: impl Fn(DVec2) -> f64) -> Vec<DVec2> {
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for (i, &a) in polygon.iter().enumerate() {
        let b = polygon[(i + 1) % polygon.len()];
        let (sa, sb) = (side(a), side(b));
        if sa >= 0.0 {
            out.push(a);
        }
        if (sa >= 0.0) != (sb >= 0.0) {
            out.push(a + (b - a) * (sa / (sa - sb)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::RngCore;
    use rand_pcg::Pcg32;

    fn uniform(rng: &mut Pcg32) -> f64 {
        rng.next_u32() as f64 / 4294967296.0
    }

    fn outline(q: [DVec2; 3]) -> Outline {
        Outline { edges: edge_functions(q).expect("a triangle with area"), radiance: Vec3::ONE }
    }

    #[test]
    fn coverage_is_the_exact_area_of_the_pixel_inside() {
        // The triangle x >= 0, y >= 0, x + y <= 2, either way round.
        let corners = [DVec2::ZERO, DVec2::new(2.0, 0.0), DVec2::new(0.0, 2.0)];
        for q in [corners, [corners[0], corners[2], corners[1]]] {
            let o = outline(q);
            assert_eq!(clipped(&o, 0.0, 0.0).0, 1.0);
            assert!((clipped(&o, 1.0, 0.0).0 - 0.5).abs() < 1e-12);
            assert!((clipped(&o, 0.0, 1.0).0 - 0.5).abs() < 1e-12);
            assert_eq!(clipped(&o, 1.0, 1.0).0, 0.0, "touching at a corner only");
            assert_eq!(clipped(&o, 5.0, 0.0).0, 0.0);
        }
        // A thin sliver inside one pixel: its own area.
        let o = outline([DVec2::new(3.1, 7.2), DVec2::new(3.9, 7.3), DVec2::new(3.5, 7.9)]);
        let area = 0.5 * ((0.8 * 0.7) - (0.1 * 0.4));
        assert!((clipped(&o, 3.0, 7.0).0 - area).abs() < 1e-12);
    }

    /// The control variate's mean over a pixel is zero only if the coverage is the
    /// probability that a uniform point of the pixel lies inside: checked by counting
    /// 200,000 points per pixel for random triangles, to 5 binomial standard deviations.
    #[test]
    fn coverage_is_the_chance_that_a_uniform_point_of_the_pixel_lies_inside() {
        let mut rng = Pcg32::new(21, 3);
        let mut partial = 0;
        for _ in 0..40 {
            let q: [DVec2; 3] = std::array::from_fn(|_| DVec2::new(uniform(&mut rng), uniform(&mut rng)) * 4.0);
            let Some(edges) = edge_functions(q) else { continue };
            let o = Outline { edges, radiance: Vec3::ONE };
            let (x, y) = ((uniform(&mut rng) * 3.0).floor(), (uniform(&mut rng) * 3.0).floor());
            let p = clipped(&o, x, y).0;
            let n = 200_000;
            let inside = (0..n).filter(|_| o.contains(DVec2::new(x + uniform(&mut rng), y + uniform(&mut rng)))).count()
                as f64
                / n as f64;
            let sigma = (p * (1.0 - p) / n as f64).sqrt();
            assert!((inside - p).abs() <= 5.0 * sigma + 1e-9, "pixel ({x}, {y}): {inside} inside, coverage {p}");
            partial += (p > 0.0 && p < 1.0) as u32;
        }
        assert!(partial >= 10, "only {partial} partly covered pixels tested");
    }
}

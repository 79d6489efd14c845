//! Discrete and piecewise-constant distributions: Vose's alias table (choosing among many
//! lights in O(1)) and the 1D/2D piecewise-constant densities that importance-sample an
//! environment map by inverting their CDFs (which keeps a sample's stratification).

use glam::Vec2;

/// Vose's alias table: picks index i with probability w_i / sum(w) in constant time.
#[derive(Clone, Debug, Default)]
pub struct AliasTable {
    /// Per bin: probability of keeping the bin's own index, and the index it aliases to.
    bins: Vec<(f32, u32)>,
    pmf: Vec<f32>,
}

impl AliasTable {
    /// The table for non-negative finite weights; None if they sum to zero.
    pub fn new(weights: &[f64]) -> Option<Self> {
        let total: f64 = weights.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let n = weights.len();
        let pmf: Vec<f32> = weights.iter().map(|w| (w / total) as f32).collect();
        let mut scaled: Vec<f64> = weights.iter().map(|w| w / total * n as f64).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
        let mut bins = vec![(1.0f32, 0u32); n];
        for (i, bin) in bins.iter_mut().enumerate() {
            bin.1 = i as u32;
        }
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            bins[s] = (scaled[s] as f32, l as u32);
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What is left is 1 up to rounding: those bins keep their own index.
        for i in small.into_iter().chain(large) {
            bins[i] = (1.0, i as u32);
        }
        Some(Self { bins, pmf })
    }

    /// The index for uniform numbers `u` (x picks the bin, y decides between the bin and
    /// its alias), and its probability. Two numbers rather than one split in two: with
    /// millions of bins, the fraction left in one f32 would have only a few bits.
    pub fn sample(&self, u: Vec2) -> (usize, f32) {
        let n = self.bins.len();
        let bin = ((u.x * n as f32) as usize).min(n - 1);
        let (keep, alias) = self.bins[bin];
        let i = if u.y < keep { bin } else { alias as usize };
        (i, self.pmf[i])
    }

    /// Probability of index `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// Number of indices.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// Whether there is no index.
    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }
}

/// A piecewise-constant density on [0, 1) with `func.len()` equal pieces. A piece's density
/// is read off the CDF, the probability sampling gives it (rounding and all) times the
/// number of pieces: densities and samples agree exactly, and the function itself is not
/// kept (a 1024 x 512 environment map's importance sampling holds 2 MB less, and sampling
/// loads one array fewer).
#[derive(Clone, Debug)]
pub struct Distribution1D {
    cdf: Vec<f32>,
    integral: f32,
    /// Guide table (Chen and Asau 1974): entry j is the piece holding u = j / G, for G + 1
    /// entries with G about a quarter of the pieces, so that inverting the CDF searches a
    /// few neighbouring entries instead of bisecting the whole of it (a bisection's loads
    /// depend on each other).
    guide: Vec<u32>,
}

impl Distribution1D {
    /// The density proportional to the non-negative `func`; uniform if `func` is all zero.
    pub fn new(func: Vec<f32>) -> Self {
        let n = func.len().max(1);
        let mut cdf = Vec::with_capacity(n + 1);
        let mut running = 0.0f64;
        cdf.push(0.0);
        for &f in &func {
            running += f as f64 / n as f64;
            cdf.push(running as f32);
        }
        let integral = running as f32;
        if integral > 0.0 {
            cdf.iter_mut().for_each(|c| *c /= integral);
        } else {
            cdf.iter_mut().enumerate().for_each(|(i, c)| *c = i as f32 / n as f32);
        }
        *cdf.last_mut().expect("n + 1 entries") = 1.0;
        let g = cdf.len().div_ceil(4);
        let guide = (0..=g).map(|j| (cdf.partition_point(|&c| c <= j as f32 / g as f32) - 1) as u32).collect();
        Self { cdf, integral, guide }
    }

    /// The density's arrays, borrowed.
    fn view(&self) -> Piecewise<'_> {
        Piecewise { cdf: &self.cdf, guide: &self.guide }
    }

    /// Mean of the function over [0, 1).
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// The point for uniform `u`, its density, and its piece.
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        self.view().sample(u)
    }

    /// Density of piece `i`.
    pub fn density(&self, i: usize) -> f32 {
        self.view().density(i)
    }
}

/// A piecewise-constant density's arrays (`Distribution1D`'s fields), borrowed from one
/// density or from one row of a `Distribution2D`.
#[derive(Clone, Copy)]
struct Piecewise<'a> {
    cdf: &'a [f32],
    guide: &'a [u32],
}

impl Piecewise<'_> {
    /// The piece holding `u`: the last i with cdf[i] <= u, as bisecting the whole CDF finds
    /// it, searched between guide entries one bucket either side of u's (which rounding in
    /// u * G cannot move it past).
    fn piece(&self, u: f32) -> usize {
        let g = self.guide.len() - 1;
        let j = ((u * g as f32) as usize).min(g - 1);
        let lo = self.guide[j.saturating_sub(1)] as usize;
        let hi = (self.guide[(j + 2).min(g)] as usize + 1).min(self.cdf.len());
        lo + self.cdf[lo..hi].partition_point(|&c| c <= u) - 1
    }

    /// The point for uniform `u`, its density, and its piece.
    fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.cdf.len() - 1;
        let i = self.piece(u).min(n - 1);
        let width = self.cdf[i + 1] - self.cdf[i];
        let du = if width > 0.0 { (u - self.cdf[i]) / width } else { 0.0 };
        let x = ((i as f32 + du.clamp(0.0, 1.0)) / n as f32).min(1.0 - f32::EPSILON);
        (x, self.density(i), i)
    }

    /// Density of piece `i`: the probability of choosing it times the number of pieces.
    fn density(&self, i: usize) -> f32 {
        (self.cdf[i + 1] - self.cdf[i]) * (self.cdf.len() - 1) as f32
    }
}

/// A piecewise-constant density on [0, 1)^2 over a `width` x `height` grid: a marginal
/// density over rows and a conditional one within each row (pbrt's PiecewiseConstant2D).
/// The rows' arrays are stored end to end, each row at a fixed stride: finding a row's
/// numbers is arithmetic, not a load of its own arrays' addresses before theirs.
#[derive(Clone, Debug)]
pub struct Distribution2D {
    width: usize,
    /// Guide entries per row (the same for every row of one width).
    guides: usize,
    /// Per row, `Distribution1D`'s arrays: `width + 1` CDF entries and `guides` guide
    /// entries.
    cdf: Vec<f32>,
    guide: Vec<u32>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// The density proportional to `func` (row-major, `width` values per row).
    pub fn new(func: &[f32], width: usize) -> Self {
        let rows: Vec<Distribution1D> = func.chunks_exact(width).map(|r| Distribution1D::new(r.to_vec())).collect();
        let marginal = Distribution1D::new(rows.iter().map(Distribution1D::integral).collect());
        Self {
            width,
            guides: rows.first().map_or(0, |r| r.guide.len()),
            cdf: rows.iter().flat_map(|r| r.cdf.iter().copied()).collect(),
            guide: rows.iter().flat_map(|r| r.guide.iter().copied()).collect(),
            marginal,
        }
    }

    /// Row `r`'s conditional density.
    fn row(&self, r: usize) -> Piecewise<'_> {
        let (w, g) = (self.width, self.guides);
        Piecewise { cdf: &self.cdf[r * (w + 1)..(r + 1) * (w + 1)], guide: &self.guide[r * g..(r + 1) * g] }
    }

    /// The point for uniform `u` and its density.
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (y, pdf_row, row) = self.marginal.sample(u.y);
        let (x, pdf_x, _) = self.row(row).sample(u.x);
        (Vec2::new(x, y), pdf_row * pdf_x)
    }

    /// Density at `p`.
    pub fn pdf(&self, p: Vec2) -> f32 {
        let (w, h) = (self.width, self.marginal.cdf.len() - 1);
        let row = ((p.y * h as f32) as usize).min(h - 1);
        let col = ((p.x * w as f32) as usize).min(w - 1);
        self.marginal.density(row) * self.row(row).density(col)
    }

    /// Mean of the function over the unit square.
    pub fn integral(&self) -> f32 {
        self.marginal.integral()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform numbers in [0, 1) from a SplitMix64 stream starting at `state`.
    fn uniforms(mut state: u64) -> impl FnMut() -> f32 {
        move || {
            state = crate::math::sampler::mix64(state.wrapping_add(0x9e37_79b9_7f4a_7c15));
            (state >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    #[test]
    fn the_guide_table_finds_the_piece_bisection_finds() {
        let mut next = uniforms(0x2545_f491_4f6c_dd1d);
        for n in [1usize, 2, 3, 5, 17, 64, 1000] {
            // Zeros, spikes and smooth stretches, so that guide buckets hold many pieces or none.
            let func: Vec<f32> = (0..n)
                .map(|i| {
                    if i % 7 == 3 {
                        0.0
                    } else if i % 13 == 5 {
                        1e4
                    } else {
                        next()
                    }
                })
                .collect();
            let d = Distribution1D::new(func);
            let probes =
                d.cdf.clone().into_iter().chain([0.0, 1.0 - f32::EPSILON / 2.0]).chain((0..20_000).map(|_| next()));
            for u in probes.filter(|u| (0.0..1.0).contains(u)) {
                assert_eq!(d.view().piece(u), d.cdf.partition_point(|&c| c <= u) - 1, "n {n}, u {u}");
            }
        }
    }

    #[test]
    fn a_2d_densitys_rows_sample_as_their_own_1d_densities_do() {
        let mut next = uniforms(0x9e37_79b9_7f4a_7c15);
        for (w, h) in [(2usize, 1usize), (3, 5), (16, 8), (33, 7)] {
            let func: Vec<f32> = (0..w * h).map(|i| if i % 5 == 2 { 0.0 } else { next() }).collect();
            let d2 = Distribution2D::new(&func, w);
            let rows: Vec<Distribution1D> = func.chunks_exact(w).map(|r| Distribution1D::new(r.to_vec())).collect();
            let marginal = Distribution1D::new(rows.iter().map(Distribution1D::integral).collect());
            for _ in 0..2_000 {
                let u = Vec2::new(next(), next());
                let (y, pdf_y, row) = marginal.sample(u.y);
                let (x, pdf_x, col) = rows[row].sample(u.x);
                assert_eq!(d2.sample(u), (Vec2::new(x, y), pdf_y * pdf_x), "{w}x{h} at {u}");
                let p = Vec2::new((col as f32 + 0.5) / w as f32, (row as f32 + 0.5) / h as f32);
                assert_eq!(d2.pdf(p), marginal.density(row) * rows[row].density(col), "{w}x{h} at {p}");
            }
        }
    }

    #[test]
    fn the_alias_table_picks_each_index_exactly_in_proportion() {
        let weights = [1.0, 0.0, 3.0, 0.5, 2.5, 1e-3];
        let table = AliasTable::new(&weights).unwrap();
        // Over a grid of midpoints, the share of each index is its probability up to the
        // grid's resolution (the table is exact, not merely unbiased).
        let (nx, ny) = (weights.len() * 64, 4096);
        let mut counts = [0usize; 6];
        for i in 0..nx {
            for j in 0..ny {
                let u = Vec2::new((i as f32 + 0.5) / nx as f32, (j as f32 + 0.5) / ny as f32);
                counts[table.sample(u).0] += 1;
            }
        }
        let total: f64 = weights.iter().sum();
        for (i, &c) in counts.iter().enumerate() {
            let share = c as f64 / (nx * ny) as f64;
            assert!((share - weights[i] / total).abs() < 2.0 / ny as f64, "{i}: {share}");
            assert!((table.pmf(i) as f64 - weights[i] / total).abs() < 1e-7);
        }
        assert_eq!(counts[1], 0, "zero weight is never picked");
        assert!(AliasTable::new(&[0.0, 0.0]).is_none());
    }

    #[test]
    fn piecewise_constant_sampling_inverts_the_cdf() {
        let d = Distribution1D::new(vec![0.0, 1.0, 3.0, 0.0]);
        assert_eq!(d.integral(), 1.0);
        let (x, pdf, i) = d.sample(0.5);
        assert_eq!(i, 2);
        assert!((x - (0.5 + 1.0 / 3.0 * 0.25)).abs() < 1e-6, "{x}");
        assert_eq!(pdf, 3.0);
        assert_eq!(d.sample(0.0).2, 1, "a piece of zero density is never returned");
        let flat = Distribution1D::new(vec![0.0; 4]);
        assert_eq!(flat.sample(0.3).1, 1.0);

        let d2 = Distribution2D::new(&[1.0, 0.0, 2.0, 5.0], 2);
        assert_eq!(d2.integral(), 2.0);
        for u in [Vec2::new(0.1, 0.2), Vec2::new(0.7, 0.9), Vec2::new(0.5, 0.05)] {
            let (p, pdf) = d2.sample(u);
            assert!((d2.pdf(p) - pdf).abs() < 1e-6, "{p}: {pdf} vs {}", d2.pdf(p));
        }
        assert_eq!(d2.pdf(Vec2::new(0.75, 0.25)), 0.0);
        assert_eq!(d2.pdf(Vec2::new(0.75, 0.75)), 2.5);
    }
}

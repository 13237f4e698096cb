//! Piecewise-constant distributions in one and two dimensions, sampled by inverting their
//! distribution functions (pbrt-v4 Sec. A.1 and A.5): what the environment light draws its
//! directions from. The inversion starts from a guide table (the cutpoint method of Chen and
//! Asau 1974) instead of a binary search: the same segment for every `u`, so samples stay
//! monotone in `u` (an alias table would break the stratification), at O(1) expected cost.
//!
//! Each segment's distribution function, value and guide entry lie side by side (`Cell`), and a
//! 2-D table keeps all its rows in one array: a sample reads one or two cache lines of its row
//! instead of three arrays behind a per-row header, which made it memory-bound.

/// One segment of a table: the distribution function at its start, its value, and the guide
/// entry of the `u` cell of the same index.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cell {
    /// Distribution function at k / n, from 0 to 1 (f64: long tables of small values would
    /// lose their increments in f32). A table of n segments has n + 1 cells; the last holds
    /// the function's 1 alone.
    cdf: f64,
    /// The (non-negative) segment value.
    func: f32,
    /// `guide`: the last `k` with `cdf[k] <= j / n`, where the search for `u` in
    /// `[j / n, (j + 1) / n)` starts (j the cell's index).
    guide: u32,
}

/// The cells of a table of `func` (cleaned: negative or non-finite values count as 0; all
/// zero: uniform) and its integral.
fn cells(func: &[f32]) -> (Vec<Cell>, f64) {
    assert!(!func.is_empty(), "a distribution needs at least one segment");
    let func: Vec<f32> = func.iter().map(|&f| if f.is_finite() && f > 0.0 { f } else { 0.0 }).collect();
    let n = func.len() as f64;
    let mut cdf = Vec::with_capacity(func.len() + 1);
    let mut sum = 0.0f64;
    cdf.push(0.0);
    for &f in &func {
        sum += f as f64 / n;
        cdf.push(sum);
    }
    let integral = sum;
    if integral > 0.0 {
        cdf.iter_mut().for_each(|c| *c /= integral);
    } else {
        cdf.iter_mut().enumerate().for_each(|(k, c)| *c = k as f64 / n);
    }
    *cdf.last_mut().expect("n + 1 entries") = 1.0;
    let mut cells: Vec<Cell> = cdf.iter().map(|&cdf| Cell { cdf, func: 0.0, guide: 0 }).collect();
    let mut k = 0usize;
    for j in 0..func.len() {
        let at = j as f64 / n;
        while k + 1 < func.len() && cdf[k + 1] <= at {
            k += 1;
        }
        cells[j].func = func[j];
        cells[j].guide = k as u32;
    }
    (cells, integral)
}

/// A table's cells (n + 1 of them) and integral, borrowed: what sampling reads.
#[derive(Clone, Copy, Debug)]
struct Table<'a> {
    cells: &'a [Cell],
    integral: f64,
}

impl Table<'_> {
    fn len(&self) -> usize {
        self.cells.len() - 1
    }

    /// The last `k < n` with `cdf[k] <= u` (`u` in [0, 1]): the guide's entry for `u`'s
    /// cell, then a short walk, which also mends a cell index that rounding put one off.
    #[cfg(test)]
    fn segment_of(&self, u: f64) -> usize {
        self.segment_from(u, self.guide_of(u))
    }

    /// The guide's entry for `u` (where `segment_of` starts its walk).
    #[inline]
    fn guide_of(&self, u: f64) -> usize {
        let n = self.len();
        self.cells[((u * n as f64) as usize).min(n - 1)].guide as usize
    }

    /// `segment_of(u)` from the guide's entry `k` for `u`.
    #[inline]
    fn segment_from(&self, u: f64, mut k: usize) -> usize {
        let (n, c) = (self.len(), self.cells);
        while k > 0 && c[k].cdf > u {
            k -= 1;
        }
        while k + 1 < n && c[k + 1].cdf <= u {
            k += 1;
        }
        k
    }

    #[inline]
    fn pdf_of(&self, k: usize) -> f32 {
        if self.integral > 0.0 {
            (self.cells[k].func as f64 / self.integral) as f32
        } else {
            1.0
        }
    }

    #[inline]
    fn sample(&self, u: f32) -> (f32, f32, usize) {
        let u = (u as f64).clamp(0.0, 1.0);
        self.sample_from(u, self.guide_of(u))
    }

    /// `sample` for `u` (in [0, 1], as f64) from the guide's entry `guide` for it.
    #[inline]
    fn sample_from(&self, u: f64, guide: usize) -> (f32, f32, usize) {
        let (n, c) = (self.len(), self.cells);
        let mass = |k: usize| c[k + 1].cdf - c[k].cdf;
        // The last k with cdf[k] <= u, among segments of positive mass.
        let mut k = self.segment_from(u, guide);
        while k > 0 && mass(k) <= 0.0 {
            k -= 1;
        }
        while k + 1 < n && mass(k) <= 0.0 {
            k += 1;
        }
        let m = mass(k);
        let t = if m > 0.0 { ((u - c[k].cdf) / m).clamp(0.0, 1.0) } else { 0.5 };
        // Kept strictly below 1 (f32 rounding of (n - 1 + t) / n can reach it).
        let x = (((k as f64 + t) / n as f64) as f32).min(1.0 - f32::EPSILON / 2.0);
        (x, self.pdf_of(k), k)
    }
}

/// A piecewise-constant density on [0, 1) with `n` equal segments.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    cells: Vec<Cell>,
    /// The integral of `func` over [0, 1).
    integral: f64,
}

impl Distribution1D {
    /// A distribution proportional to `func`: negative or non-finite values count as 0, and
    /// an all-zero table becomes uniform (so that sampling is always defined; callers that
    /// care check `integral`).
    pub fn new(func: &[f32]) -> Self {
        let (cells, integral) = cells(func);
        Distribution1D { cells, integral }
    }

    fn table(&self) -> Table<'_> {
        Table { cells: &self.cells, integral: self.integral }
    }

    pub fn len(&self) -> usize {
        self.cells.len() - 1
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The integral of the (cleaned) function over [0, 1).
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Density at segment `k`.
    #[inline]
    pub fn pdf_of(&self, k: usize) -> f32 {
        self.table().pdf_of(k)
    }

    /// Maps `u` in [0, 1) to (x in [0, 1), its density, its segment). Monotone in `u`, so
    /// stratified values stay stratified. Never lands in a segment of zero density.
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        self.table().sample(u)
    }
}

/// A piecewise-constant density on [0, 1)^2 over a `width` x `height` grid: a marginal
/// distribution over rows and one conditional distribution per row, the rows' cells in one
/// array (`width + 1` per row).
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    width: usize,
    rows: Vec<Cell>,
    row_integrals: Vec<f64>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// `func` is row-major, `height` rows of `width` values.
    pub fn new(func: &[f32], width: usize, height: usize) -> Self {
        assert!(width > 0 && height > 0 && func.len() == width * height, "a {width} x {height} table");
        let mut rows = Vec::with_capacity((width + 1) * height);
        let mut row_integrals = Vec::with_capacity(height);
        for row in func.chunks_exact(width) {
            let (c, integral) = cells(row);
            rows.extend(c);
            row_integrals.push(integral);
        }
        let marginal = Distribution1D::new(&row_integrals.iter().map(|&i| i as f32).collect::<Vec<_>>());
        Distribution2D { width, rows, row_integrals, marginal }
    }

    fn row(&self, r: usize) -> Table<'_> {
        let w = self.width + 1;
        Table { cells: &self.rows[r * w..(r + 1) * w], integral: self.row_integrals[r] }
    }

    /// The integral of the table over [0, 1)^2.
    pub fn integral(&self) -> f64 {
        self.marginal.integral()
    }

    /// Maps `u` to a point (x, y) in [0, 1)^2 and its density.
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> ([f32; 2], f32) {
        let (y, pdf_y, row) = self.marginal.sample(u[1]);
        let (x, pdf_x, _) = self.row(row).sample(u[0]);
        ([x, y], pdf_x * pdf_y)
    }

    /// `sample` of each of `us`, the same numbers, with the points' reads of the rows' cells
    /// issued together: on a large map each is a cache miss, and one point's wait then
    /// overlaps the others' instead of following it.
    #[inline]
    pub fn sample_many<const N: usize>(&self, us: &[[f32; 2]; N]) -> [([f32; 2], f32); N] {
        let ys = us.map(|u| self.marginal.sample(u[1]));
        let xs = us.map(|u| (u[0] as f64).clamp(0.0, 1.0));
        let guides: [usize; N] = std::array::from_fn(|i| self.row(ys[i].2).guide_of(xs[i]));
        for i in 0..N {
            prefetch(&self.row(ys[i].2).cells[guides[i]]);
        }
        std::array::from_fn(|i| {
            let (y, pdf_y, row) = ys[i];
            let (x, pdf_x, _) = self.row(row).sample_from(xs[i], guides[i]);
            ([x, y], pdf_x * pdf_y)
        })
    }

    /// The row and column of the cell holding point `p`.
    #[inline]
    fn cell_of(&self, p: [f32; 2]) -> (usize, usize) {
        let (h, w) = (self.row_integrals.len(), self.width);
        (((p[1] * h as f32) as usize).min(h - 1), ((p[0] * w as f32) as usize).min(w - 1))
    }

    /// Density at point (x, y) in [0, 1)^2.
    #[inline]
    pub fn pdf(&self, p: [f32; 2]) -> f32 {
        let (row, col) = self.cell_of(p);
        self.marginal.pdf_of(row) * self.row(row).pdf_of(col)
    }

    /// Asks for the memory `pdf(p)` reads, for a `pdf` call soon after.
    #[inline]
    pub fn prefetch_pdf(&self, p: [f32; 2]) {
        let (row, col) = self.cell_of(p);
        prefetch(&self.row(row).cells[col]);
    }
}

/// Asks the CPU to bring `x`'s cache line in (a hint: no effect on any value).
#[inline(always)]
pub(crate) fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing architecturally and cannot fault; `x` is a valid reference.
    #[allow(unused_unsafe)]
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(x as *const T as *const i8)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::test_rng::Rng;

    /// The guided search finds the segment a binary search finds, for every `u` that matters:
    /// the table's own steps, their f64 neighbours and random values, on tables with zero runs,
    /// a single spike, a huge dynamic range and one segment.
    #[test]
    fn the_guide_table_finds_the_binary_searchs_segment() {
        let mut rng = Rng(7);
        let mut spike = vec![0.0f32; 1000];
        spike[613] = 1.0;
        let tables: Vec<Vec<f32>> = vec![
            vec![0.0, 1.0, 3.0, 0.0, 4.0],
            vec![2.0],
            spike,
            (0..777).map(|k| if k % 5 < 2 { 0.0 } else { (k as f32 * 0.37).sin().abs() }).collect(),
            (0..512).map(|k| 10f32.powi((k % 40) - 20)).collect(),
            (0..300).map(|_| rng.f()).collect(),
        ];
        for func in &tables {
            let d = Distribution1D::new(func);
            let cdf: Vec<f64> = d.cells.iter().map(|c| c.cdf).collect();
            let binary = |u: f64| cdf.partition_point(|&c| c <= u).saturating_sub(1).min(d.len() - 1);
            let mut us: Vec<f64> = vec![0.0, 1.0, f64::EPSILON, 1.0 - f64::EPSILON];
            for &c in &cdf {
                us.extend([c, c.next_down(), c.next_up()].into_iter().filter(|u| (0.0..=1.0).contains(u)));
            }
            us.extend((0..20_000).map(|_| rng.f() as f64));
            us.extend((0..=d.len()).map(|j| j as f64 / d.len() as f64));
            for u in us {
                assert_eq!(d.table().segment_of(u), binary(u), "u = {u:e} on a table of {}", d.len());
            }
        }
    }

    #[test]
    fn samples_follow_the_table_and_the_density_integrates_to_one() {
        let func = [0.0, 1.0, 3.0, 0.0, 4.0];
        let d = Distribution1D::new(&func);
        assert!((d.integral() - 8.0 / 5.0).abs() < 1e-12);
        let integral: f64 = (0..5).map(|k| d.pdf_of(k) as f64 / 5.0).sum();
        assert!((integral - 1.0).abs() < 1e-6);
        // Stratified u: each segment receives its share of the mass, none lands on a zero.
        let n = 8000;
        let mut counts = [0usize; 5];
        for i in 0..n {
            let (x, pdf, k) = d.sample((i as f32 + 0.5) / n as f32);
            assert_eq!(k, (x * 5.0) as usize);
            assert!(pdf > 0.0 && func[k] > 0.0, "sampled a zero segment {k}");
            counts[k] += 1;
        }
        for k in 0..5 {
            let expected = func[k] as f64 / 8.0 * n as f64;
            assert!((counts[k] as f64 - expected).abs() <= 1.0, "segment {k}: {} vs {expected}", counts[k]);
        }
    }

    #[test]
    fn sampling_is_monotone_and_stays_inside_the_unit_interval() {
        let d = Distribution1D::new(&[1e-30, 5.0, 1e-30, 2.0]);
        let mut last = -1.0f32;
        for i in 0..=1000 {
            let u = (i as f32 / 1000.0).min(1.0 - f32::EPSILON / 2.0);
            let (x, _, _) = d.sample(u);
            assert!((0.0..1.0).contains(&x) && x >= last, "u {u} x {x} last {last}");
            last = x;
        }
        assert!(d.sample(1.0).0 < 1.0);
    }

    #[test]
    fn a_table_of_zeros_or_junk_gives_the_uniform_density() {
        for func in [[0.0f32; 4], [f32::NAN, -1.0, f32::NEG_INFINITY, 0.0]] {
            let d = Distribution1D::new(&func);
            assert_eq!(d.integral(), 0.0);
            for k in 0..4 {
                assert_eq!(d.pdf_of(k), 1.0);
            }
            let (x, pdf, k) = d.sample(0.6);
            assert!((x - 0.6).abs() < 1e-6 && pdf == 1.0 && k == 2);
        }
    }

    #[test]
    fn the_2d_density_matches_its_samples_and_integrates_to_one() {
        let (w, h) = (6, 4);
        let func: Vec<f32> = (0..w * h).map(|i| ((i * 7) % 5) as f32).collect();
        let d = Distribution2D::new(&func, w, h);
        let total: f32 = func.iter().sum();
        let mut integral = 0.0f64;
        for r in 0..h {
            for c in 0..w {
                let p = d.pdf([(c as f32 + 0.5) / w as f32, (r as f32 + 0.5) / h as f32]);
                // The density of a cell is its share of the table times the cell count.
                assert!((p - func[r * w + c] / total * (w * h) as f32).abs() < 1e-5);
                integral += p as f64 / (w * h) as f64;
            }
        }
        assert!((integral - 1.0).abs() < 1e-6);
        // A stratified grid of u lands in each cell in proportion to its value, with the
        // density `pdf` reports there.
        let n = 200;
        let mut counts = vec![0usize; w * h];
        for i in 0..n {
            for j in 0..n {
                let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
                let (p, pdf) = d.sample(u);
                let cell = ((p[1] * h as f32) as usize) * w + (p[0] * w as f32) as usize;
                assert!(func[cell] > 0.0);
                assert!((pdf - d.pdf(p)).abs() < 1e-5);
                counts[cell] += 1;
            }
        }
        for cell in 0..w * h {
            let expected = func[cell] / total * (n * n) as f32;
            assert!((counts[cell] as f32 - expected).abs() <= 0.02 * (n * n) as f32, "cell {cell}");
        }
    }
}

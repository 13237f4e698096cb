//! The cross-bilateral gather of Tokuyoshi 2015 (Eq. 1): each pixel's value becomes the
//! weighted mean of its neighbours' with `W(i, j) = f(s_i, s_j) w_z(i, j) w_omega(i, j)`, a
//! screen-space Gaussian f times the depth weight (Eq. 3) times the directional weight, either
//! lobe-aware (Eq. 12) or the normal-aware baseline (Eq. 4). The three factors are added as
//! logarithms, one exponential per neighbour. Pixels whose guides carry ASG lobes (`LobeShape::Asg`)
//! are compared by Eq. 13 instead of Eq. 12 where both lobes are high-frequency.
//!
//! The screen-space kernel's width is the centre pixel's own (`Guide::sigma_px`), so a caller
//! can narrow it pass by pass (the stream's consistency) or take it from a frequency analysis
//! (AAF's per-pixel widths). Two gathers: the full 2-D one the paper defines, whose weight
//! sums drive the adaptive re-render of Fig. 16, and a separable approximation (a horizontal
//! then a vertical 1-D gather with the same weights, as the AAF filters do), the default for
//! its cost: 2 (2r + 1) neighbours per pixel instead of (2r + 1)^2. Rows run in parallel; the
//! result does not depend on the thread count.
use super::asg::AsgLobe;
use super::sg::Sg;
use super::weights::{ln_depth_weight, ln_lobe_weight, ln_normal_weight};
use glam::DVec3;
use rayon::prelude::*;

/// What the filter knows of one pixel: its G-buffer lobe and depth, and its kernel as a centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guide {
    /// A valid hit that has a value to contribute; invalid pixels pass through and feed no one.
    pub valid: bool,
    /// Distance from the camera (Eq. 3's z).
    pub depth: f64,
    /// The shading normal (the normal-aware weight's guide).
    pub normal: DVec3,
    /// The smoothed lobe (Eq. 10) of the component being filtered (the lobe-aware guide).
    pub lobe: Sg,
    /// The same lobe as a smoothed ASG, where the options ask for Eq. 13 (`LobeShape::Asg`).
    /// None for a low-frequency one, which Eq. 12 compares.
    pub asg: Option<AsgLobe>,
    /// Standard deviation of the screen-space kernel f, in pixels, when this pixel is a
    /// centre; 0 keeps its value.
    pub sigma_px: f64,
}

/// The directional weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Similarity {
    /// Eq. 12 with power beta.
    Lobe { beta: f64 },
    /// Eq. 4 with variance sigma_n^2.
    Normal { sigma_n2: f64 },
}

/// Which gather runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gather {
    /// Every neighbour in the (2r + 1)^2 square (Eq. 1 as written).
    Full,
    /// A horizontal, then a vertical 1-D gather.
    Separable,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BilateralOptions {
    pub similarity: Similarity,
    /// Eq. 3's variance relative to the centre's depth squared.
    pub sigma_z2_relative: f64,
    /// The kernel radius is ceil(3 sigma_px), capped here (the paper times 8 and 16 px).
    pub max_radius: usize,
    pub gather: Gather,
}

/// The filtered image and, per pixel, the sum of its weights (the denominator of Eq. 1; at
/// least 1 for a filtered centre, whose own weight is 1; for the separable gather, that of
/// its vertical pass).
pub struct Filtered {
    pub values: Vec<[f64; 3]>,
    pub weight_sums: Vec<f64>,
    /// Non-finite input values, replaced by 0 before filtering (methods.md §0.2).
    pub non_finite: usize,
}

impl Similarity {
    /// ln of the directional weight of neighbour `j` for centre `c`.
    pub(crate) fn ln_weight(&self, c: &Guide, j: &Guide) -> f64 {
        match *self {
            Similarity::Lobe { beta } => match (&c.asg, &j.asg) {
                (Some(a), Some(b)) => a.ln_weight(b, beta),
                _ => None,
            }
            .unwrap_or_else(|| ln_lobe_weight(&c.lobe, &j.lobe, beta)),
            Similarity::Normal { sigma_n2 } => ln_normal_weight(c.normal, j.normal, sigma_n2),
        }
    }
}

/// Kernel radius in pixels of a centre.
fn radius(g: &Guide, o: &BilateralOptions) -> usize {
    if !(g.valid && g.sigma_px > 0.0) {
        return 0;
    }
    ((3.0 * g.sigma_px).ceil() as usize).clamp(1, o.max_radius)
}

/// Filters `values` (row-major, `width` wide, one per guide).
pub fn filter(guides: &[Guide], width: usize, values: &[[f64; 3]], o: &BilateralOptions) -> Filtered {
    filter_counted(guides, width, values, None, o)
}

/// `filter` of values that are means of `counts` samples each: neighbour j's weight is
/// multiplied by `counts[j] / counts[i]`, so that Eq. 1 averages samples rather than pixels.
/// Where every count is equal this is `filter` exactly; where they differ (a pass the deadline
/// cut leaves some pixels with twice, or after the preview sixteen times, the samples of
/// others) a pixel of few samples takes its value mostly from better-sampled neighbours instead
/// of passing its noise on.
pub fn filter_counted(
    guides: &[Guide],
    width: usize,
    values: &[[f64; 3]],
    counts: Option<&[f64]>,
    o: &BilateralOptions,
) -> Filtered {
    filtered(guides, width, values, counts, o, None)
}

/// `filter_counted` that a render's cancellation stops: None once `cancelled()` is true (the
/// rows not begun by then are left out, and the frame they were for is thrown away), so that
/// a cancelled render does not wait for a wide gather to end. (A closure, not the pipeline's
/// token: the pipeline's job holds this module's options.)
pub fn filter_counted_until(
    guides: &[Guide],
    width: usize,
    values: &[[f64; 3]],
    counts: Option<&[f64]>,
    o: &BilateralOptions,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<Filtered> {
    let f = filtered(guides, width, values, counts, o, Some(cancelled));
    (!cancelled()).then_some(f)
}

fn filtered(
    guides: &[Guide],
    width: usize,
    values: &[[f64; 3]],
    counts: Option<&[f64]>,
    o: &BilateralOptions,
    cancelled: Option<&(dyn Fn() -> bool + Sync)>,
) -> Filtered {
    assert_eq!(guides.len(), values.len(), "one guide per value");
    assert!(counts.is_none_or(|c| c.len() == values.len()), "one count per value");
    let height = guides.len().checked_div(width).unwrap_or(0);
    let mut non_finite = 0;
    let clean: Vec<[f64; 3]> = values
        .iter()
        .map(|v| {
            if v.iter().all(|x| x.is_finite()) {
                *v
            } else {
                non_finite += 1;
                [0.0; 3]
            }
        })
        .collect();
    let image = Image { guides, width, height, o, counts, cancelled };
    let (values, weight_sums) = match o.gather {
        Gather::Full => image.pass(&clean, |x, y, r| image.square(x, y, r)),
        Gather::Separable => {
            let (across, _) = image.pass(&clean, |x, y, r| image.line(x, y, r, true));
            image.pass(&across, |x, y, r| image.line(x, y, r, false))
        }
    };
    Filtered { values, weight_sums, non_finite }
}

struct Image<'a> {
    guides: &'a [Guide],
    width: usize,
    height: usize,
    o: &'a BilateralOptions,
    counts: Option<&'a [f64]>,
    /// Asked before each row: once true, the rows left are zeros.
    cancelled: Option<&'a (dyn Fn() -> bool + Sync)>,
}

impl Image<'_> {
    /// One gather over every pixel: `neighbours(x, y, r)` lists the (index, squared pixel
    /// distance) pairs a centre gathers from.
    fn pass<I: Iterator<Item = (usize, f64)>>(
        &self,
        values: &[[f64; 3]],
        neighbours: impl Fn(usize, usize, usize) -> I + Sync,
    ) -> (Vec<[f64; 3]>, Vec<f64>) {
        let rows: Vec<Vec<([f64; 3], f64)>> = (0..self.height)
            .into_par_iter()
            .map(|y| {
                if self.cancelled.is_some_and(|c| c()) {
                    return vec![([0.0; 3], 0.0); self.width];
                }
                (0..self.width).map(|x| self.gather(values, x, y, &neighbours)).collect()
            })
            .collect();
        rows.into_iter().flatten().unzip()
    }

    fn gather<I: Iterator<Item = (usize, f64)>>(
        &self,
        values: &[[f64; 3]],
        x: usize,
        y: usize,
        neighbours: &impl Fn(usize, usize, usize) -> I,
    ) -> ([f64; 3], f64) {
        let i = y * self.width + x;
        let c = &self.guides[i];
        let r = radius(c, self.o);
        if r == 0 {
            return (values[i], if c.valid { 1.0 } else { 0.0 });
        }
        let inv_2s2 = 1.0 / (2.0 * c.sigma_px * c.sigma_px);
        // Relative to the centre's count, so that equal counts multiply by exactly 1.
        let relative = |j: usize| self.counts.map_or(1.0, |n| if n[i] > 0.0 { n[j] / n[i] } else { 1.0 });
        let sigma_z2 = self.o.sigma_z2_relative * c.depth * c.depth;
        let (mut sum, mut wsum) = ([0.0f64; 3], 0.0f64);
        for (j, d2) in neighbours(x, y, r) {
            let g = &self.guides[j];
            if !g.valid {
                continue;
            }
            let w = if j == i {
                1.0
            } else {
                (-d2 * inv_2s2 + ln_depth_weight(c.depth, g.depth, sigma_z2) + self.o.similarity.ln_weight(c, g)).exp()
                    * relative(j)
            };
            if w > 0.0 {
                for k in 0..3 {
                    sum[k] += w * values[j][k];
                }
                wsum += w;
            }
        }
        (sum.map(|s| s / wsum), wsum)
    }

    fn square(&self, x: usize, y: usize, r: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let (w, h) = (self.width, self.height);
        (y.saturating_sub(r)..=(y + r).min(h - 1)).flat_map(move |yy| {
            (x.saturating_sub(r)..=(x + r).min(w - 1)).map(move |xx| {
                let (dx, dy) = (xx as f64 - x as f64, yy as f64 - y as f64);
                (yy * w + xx, dx * dx + dy * dy)
            })
        })
    }

    fn line(&self, x: usize, y: usize, r: usize, across: bool) -> impl Iterator<Item = (usize, f64)> + '_ {
        let w = self.width;
        let (at, len) = if across { (x, w) } else { (y, self.height) };
        (at.saturating_sub(r)..=(at + r).min(len - 1)).map(move |k| {
            let d = k as f64 - at as f64;
            (if across { y * w + k } else { k * w + x }, d * d)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::lobe_aware::lobe::{diffuse, specular};
    use crate::methods::lobe_aware::options::LobeOptions;
    use crate::render::material::GlossyModel;

    fn opts(similarity: Similarity) -> BilateralOptions {
        BilateralOptions { similarity, sigma_z2_relative: 0.01, max_radius: 16, gather: Gather::Full }
    }

    fn separable(similarity: Similarity) -> BilateralOptions {
        BilateralOptions { gather: Gather::Separable, ..opts(similarity) }
    }

    fn flat(w: usize, h: usize, sigma_px: f64) -> Vec<Guide> {
        vec![Guide { valid: true, depth: 4.0, normal: DVec3::Z, lobe: diffuse(DVec3::Z), asg: None, sigma_px }; w * h]
    }

    #[test]
    fn a_constant_image_stays_constant_and_identical_guides_give_a_gaussian_blur() {
        let (w, h) = (21, 13);
        let guides = flat(w, h, 2.0);
        let c = vec![[0.25, 1.0, 3.0]; w * h];
        for s in [Similarity::Lobe { beta: 20.0 }, Similarity::Normal { sigma_n2: 0.01 }] {
            let out = filter(&guides, w, &c, &opts(s));
            let sep = filter(&guides, w, &c, &separable(s));
            assert!(sep.values.iter().all(|v| (v[0] - 0.25).abs() < 1e-12 && (v[2] - 3.0).abs() < 1e-12));
            assert!(out.values.iter().all(|v| (v[0] - 0.25).abs() < 1e-12 && (v[2] - 3.0).abs() < 1e-12));
            assert!(out.weight_sums.iter().all(|&s| s >= 1.0));
        }
        // One bright pixel: the output is the normalised screen-space Gaussian around it, and
        // the separable gather of a Gaussian is exact (on a frame wide enough that no window
        // is cut).
        let (w, h) = (31, 25);
        let guides = flat(w, h, 2.0);
        let mut v = vec![[0.0; 3]; w * h];
        v[12 * w + 15] = [1.0; 3];
        let g = |dx: f64, dy: f64| (-(dx * dx + dy * dy) / 8.0).exp();
        let norm: f64 = (-6..=6).flat_map(|dy| (-6..=6).map(move |dx| g(dx as f64, dy as f64))).sum();
        for o in [opts(Similarity::Lobe { beta: 20.0 }), separable(Similarity::Lobe { beta: 20.0 })] {
            let out = filter(&guides, w, &v, &o);
            for (x, y) in [(17, 12), (13, 14)] {
                let got = out.values[y * w + x][0];
                let want = g(x as f64 - 15.0, y as f64 - 12.0) / norm;
                assert!((got - want).abs() < 1e-12, "{:?} ({x}, {y}): {got} vs {want}", o.gather);
            }
        }
    }

    /// Two glossy halves of one plane, Blinn-Phong exponents 10 and 10,000, with different
    /// light: the normals agree, so the normal-aware weight blurs across the edge; the lobes
    /// differ, so the lobe-aware weight keeps the halves apart (Tokuyoshi's Fig. 5 and 7).
    #[test]
    fn lobe_aware_weights_keep_an_edge_of_glossiness_that_normal_aware_blur() {
        let (w, h) = (24, 8);
        let psi = DVec3::new(0.3, 0.0, 1.0).normalize();
        let lo = LobeOptions::default();
        let mut guides = flat(w, h, 3.0);
        let mut values = vec![[0.0; 3]; w * h];
        for y in 0..h {
            for x in 0..w {
                let m = if x < w / 2 { 10.0 } else { 10_000.0 };
                guides[y * w + x].lobe = specular(GlossyModel::BlinnPhong, m, DVec3::Z, psi, &lo).smoothed(100.0);
                values[y * w + x] = if x < w / 2 { [1.0; 3] } else { [5.0; 3] };
            }
        }
        let edge = 4 * w + w / 2 - 1;
        for make in [opts, separable] {
            let lobe = filter(&guides, w, &values, &make(Similarity::Lobe { beta: 20.0 }));
            let normal = filter(&guides, w, &values, &make(Similarity::Normal { sigma_n2: 0.01 }));
            assert!((lobe.values[edge][0] - 1.0).abs() < 0.01, "lobe-aware: {}", lobe.values[edge][0]);
            assert!(normal.values[edge][0] > 1.5, "normal-aware: {}", normal.values[edge][0]);
        }
    }

    /// A live token changes nothing; a tripped one gives no image, whichever the gather.
    #[test]
    fn a_cancelled_gather_gives_no_image() {
        let (w, h) = (12, 9);
        let guides = flat(w, h, 2.0);
        let values: Vec<[f64; 3]> = (0..w * h).map(|i| [(i % 7) as f64, 1.0, (i % 3) as f64]).collect();
        let (live, tripped) = (|| false, || true);
        for make in [opts, separable] {
            let o = make(Similarity::Lobe { beta: 20.0 });
            let whole = filter_counted(&guides, w, &values, None, &o);
            let until = filter_counted_until(&guides, w, &values, None, &o, &live).expect("not cancelled");
            assert_eq!((until.values, until.weight_sums), (whole.values, whole.weight_sums));
            assert!(filter_counted_until(&guides, w, &values, None, &o, &tripped).is_none());
        }
    }

    #[test]
    fn invalid_pixels_pass_through_and_feed_no_one_and_non_finite_values_are_dropped() {
        let (w, h) = (9, 9);
        let mut guides = flat(w, h, 2.0);
        let mut values = vec![[1.0; 3]; w * h];
        guides[40].valid = false;
        values[40] = [100.0; 3];
        values[41] = [f64::NAN, 1.0, 1.0];
        for make in [opts, separable] {
            let out = filter(&guides, w, &values, &make(Similarity::Lobe { beta: 20.0 }));
            assert_eq!(out.values[40], [100.0; 3]);
            assert_eq!(out.non_finite, 1);
            assert!(out
                .values
                .iter()
                .enumerate()
                .all(|(i, v)| i == 40 || v.iter().all(|x| x.is_finite() && *x <= 1.0)));
        }
        // Zero width keeps the value.
        let mut g = flat(w, h, 0.0);
        g[3].sigma_px = 0.0;
        let kept = filter(&g, w, &values, &opts(Similarity::Normal { sigma_n2: 0.01 }));
        assert_eq!(kept.values[3], values[3]);
    }

    /// Sample counts weigh the means: equal counts change nothing, bit for bit; a pixel of one
    /// sample among pixels of sixteen takes 16/17 of a neighbour's value where the two have
    /// equal weights, while without counts it keeps half its own.
    #[test]
    fn counts_weigh_the_pixels_means_by_their_samples() {
        let (w, h) = (9, 1);
        let guides = flat(w, h, 0.6);
        let values: Vec<[f64; 3]> = (0..w).map(|x| [if x == 4 { 17.0 } else { 0.0 }, x as f64, 1.0]).collect();
        for gather in [Gather::Full, Gather::Separable] {
            let o = BilateralOptions { gather, ..opts(Similarity::Lobe { beta: 20.0 }) };
            let equal = vec![16.0; w];
            let plain = filter(&guides, w, &values, &o);
            let same = filter_counted(&guides, w, &values, Some(&equal), &o);
            assert_eq!(plain.values, same.values, "{gather:?}");
            let mut counts = equal.clone();
            counts[4] = 1.0;
            let counted = filter_counted(&guides, w, &values, Some(&counts), &o);
            // Pixel 4's neighbours at distance 1 weigh exp(-1 / (2 0.36)) = 0.249 each; at
            // distance 2, 0.004.
            let n = |d: f64| (-d * d / 0.72f64).exp();
            let (own, near) = (1.0, 16.0 * (2.0 * n(1.0) + 2.0 * n(2.0)));
            let want = 17.0 * own / (own + near);
            assert!((counted.values[4][0] - want).abs() < 1e-9, "{gather:?}: {} vs {want}", counted.values[4][0]);
            let uncounted = 17.0 / (1.0 + 2.0 * n(1.0) + 2.0 * n(2.0));
            assert!((plain.values[4][0] - uncounted).abs() < 1e-9, "{gather:?}: {}", plain.values[4][0]);
            // Its neighbour of sixteen samples gives it a sixteenth of the weight.
            let want3 = 17.0 * n(1.0) / 16.0 / (1.0 + n(1.0) + n(1.0) / 16.0 + 2.0 * n(2.0));
            assert!((counted.values[3][0] - want3).abs() < 1e-9, "{gather:?}: {} vs {want3}", counted.values[3][0]);
        }
    }

    #[test]
    fn the_result_does_not_depend_on_the_thread_count() {
        let (w, h) = (31, 17);
        let mut guides = flat(w, h, 2.5);
        let mut values = vec![[0.0; 3]; w * h];
        for (i, (g, v)) in guides.iter_mut().zip(values.iter_mut()).enumerate() {
            g.depth = 3.0 + (i % 7) as f64 * 0.1;
            g.lobe = Sg::new(DVec3::new((i % 5) as f64 * 0.1, 0.0, 1.0), 5.0 + (i % 3) as f64);
            *v = [(i % 11) as f64, 1.0, 0.5];
        }
        let o = opts(Similarity::Lobe { beta: 13.1 });
        let one =
            rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| filter(&guides, w, &values, &o));
        let two =
            rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap().install(|| filter(&guides, w, &values, &o));
        assert_eq!(one.values, two.values);
    }
}

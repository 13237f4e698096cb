//! Per-pixel sample counts in proportion to each pixel's noise, shared by the methods that
//! adapt them (`auto` in direct light, `bandwidth`).
//!
//! At a fixed total N, the image's summed variance sum_p sigma_p^2 / n_p is least for
//! n_p ∝ sigma_p (a Lagrange multiplier), sigma_p the standard deviation of one sample of pixel
//! p. A share of every pass stays uniform, so that every pixel's count grows without bound
//! (consistency) and noise the sigmas do not see is still sampled everywhere. The counts are
//! totals per pixel after a pass; a pass traces them in sweeps over the image (`rounds`), so
//! that one the deadline cuts leaves every pixel a like fraction of its way.
use rayon::prelude::*;

/// How a pass's samples are shared out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Proportional {
    /// The share of each pass given in proportion to sigma; the rest is uniform.
    pub share: f64,
    /// The uniform part's floor in samples per pixel (at most the pass's mean).
    pub min_spp: u32,
    /// No pixel gets more than this times the pass's mean.
    pub max_ratio: f64,
}

impl Proportional {
    /// The count every pixel reaches in a pass of mean `target`: `1 - share` of it, and at
    /// least `min_spp` (at most `target`), so that no pixel's sigma rests on fewer samples than
    /// that: one sample shows no variance of its own, and a pixel the estimate misses would get
    /// no more.
    pub fn uniform_share(&self, target: u32) -> u32 {
        let share = ((1.0 - self.share.clamp(0.0, 1.0)) * target as f64).round() as u32;
        share.max(self.min_spp.min(target))
    }

    /// The samples each pixel should have after a pass of mean `target`: the uniform share plus
    /// its share of the rest in proportion to `sigma`, at most `max_ratio` times `target` (what
    /// that cuts off is spread over the other pixels), and never fewer than `taken`. None where
    /// no pixel has noise (or a sigma is not finite in sum).
    pub fn counts(&self, sigma: &[f64], target: u32, taken: &[u32]) -> Option<Vec<u32>> {
        // A sequential sum: the counts must not depend on the thread count.
        let total: f64 = sigma.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let (t, n) = (target as f64, sigma.len() as f64);
        let (base, cap) = (self.uniform_share(target) as f64, self.max_ratio.max(1.0) * t);
        let want: Vec<f64> = sigma.par_iter().map(|s| (base + (t - base) * n * s / total).min(cap)).collect();
        // What the cap cut off goes evenly to the pixels under it, so that the pass keeps its total.
        let under = want.iter().filter(|&&x| x < cap).count();
        let spare = (n * t - want.iter().sum::<f64>()).max(0.0) / under.max(1) as f64;
        let want: Vec<f64> = want.par_iter().map(|&x| if x < cap { x + spare } else { x }).collect();
        let counts = whole_counts(&want, (n * t).round());
        Some(counts.par_iter().zip(taken).map(|(&c, &k)| c.max(k)).collect())
    }
}

/// Whole counts for the real ones `want`, summing to `total` where `want` does: each rounded
/// down, and what that leaves given one each to the pixels with the largest fractional parts
/// (ties to the lower index). Rounding each to nearest could leave the pass's mean under its
/// target, and a render halted at that mean would then never reach it.
pub fn whole_counts(want: &[f64], total: f64) -> Vec<u32> {
    let mut counts: Vec<u32> = want.par_iter().map(|&x| x.max(0.0).floor().min(u32::MAX as f64) as u32).collect();
    let sum: f64 = counts.iter().map(|&c| c as f64).sum();
    let short = (total - sum).max(0.0).min(want.len() as f64) as usize;
    if short > 0 {
        let mut order: Vec<usize> = (0..want.len()).collect();
        let frac: Vec<f64> = want.par_iter().map(|&x| x - x.floor()).collect();
        // A total order (fraction, then index), so the first `short` pixels in it are one set
        // whichever way they are found; a selection finds them without sorting the image.
        let before = |a: &usize, b: &usize| frac[*b].total_cmp(&frac[*a]).then(a.cmp(b));
        if short < order.len() {
            order.select_nth_unstable_by(short, before);
        }
        for &p in &order[..short] {
            counts[p] = counts[p].saturating_add(1);
        }
    }
    counts
}

/// Per pixel, the square root of the one-sample variances `own` averaged over the pixels
/// within `radius` of it, a square of side 2 `radius` + 1 clipped at the border (None, a pixel
/// with too few samples to show a variance, counts as none). A pixel's own few samples are a
/// noisy estimate, and the neighbourhood's average also reaches the pixels beside an edge.
pub fn pooled_sigmas(width: usize, own: &[Option<f64>], radius: usize) -> Vec<f64> {
    let (w, n) = (width.max(1), own.len());
    (0..n)
        .into_par_iter()
        .map(|p| {
            let (mut v, mut k) = (0.0, 0u32);
            for q in window(w, n / w, p, radius) {
                if let Some(x) = own[q] {
                    v += x;
                    k += 1;
                }
            }
            if k > 0 && v.is_finite() {
                (v / k as f64).sqrt()
            } else {
                0.0
            }
        })
        .collect()
}

/// The pixels of the (2 `radius` + 1)^2 window around pixel `p` of a `width` x `height` image,
/// clipped at its border, row by row.
pub fn window(width: usize, height: usize, p: usize, radius: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (p % width.max(1), p / width.max(1));
    (y.saturating_sub(radius)..(y + radius + 1).min(height))
        .flat_map(move |qy| (x.saturating_sub(radius)..(x + radius + 1).min(width)).map(move |qx| qy * width + qx))
}

/// Sweeps over the image per pass.
pub const ROUNDS: u32 = 4;

/// The counts a pass from `before` to `target` samples per pixel sweeps the image up to: about
/// equal steps, `ROUNDS` of them at most (fewer when the pass adds fewer samples), the last
/// one `target`. The error of a mean over the image goes as the mean of 1 / n over its pixels,
/// which for a given number of samples is least when the counts are equal, so a pass the
/// deadline cuts should leave them within a round of each other. Where nothing but a
/// cancellation can stop the pass (`can_cut` false: no deadline), one sweep straight to
/// `target`: the same samples (each sample's numbers depend on its index alone), in packets of
/// a pixel's whole share rather than a sample or two.
pub fn rounds(before: u32, target: u32, can_cut: bool) -> Vec<u32> {
    if !can_cut {
        return vec![target];
    }
    let step = target.saturating_sub(before).div_ceil(ROUNDS).max(1);
    let mut out: Vec<u32> = (1..ROUNDS).map(|k| before.saturating_add(k * step)).filter(|&c| c < target).collect();
    out.push(target);
    out
}

/// Sweeps over the image of a pass's adaptive extras. Finer than the even part's: the extras
/// are most of a pass, and a quarter of pass 2's (4 to 16 spp on average) costs as much as
/// three samples per pixel, most of a preview budget, so with four sweeps the deadline fell
/// inside the first and the rows below that point (a room's floor and its shadows) had none. A
/// sweep reads the counts of the pixels it leaves alone, which costs little against a sample.
pub const EXTRA_ROUNDS: u32 = 16;

/// The count pixel p is traced up to in sweep `k` (1 to `EXTRA_ROUNDS`) of a pass's adaptive
/// extras, from the uniform share `base` to its own `count`: each pixel a like fraction of its
/// own way.
pub fn extras_round(base: u32, count: u32, k: u32) -> u32 {
    (base + (count.saturating_sub(base) as u64 * k.min(EXTRA_ROUNDS) as u64).div_ceil(EXTRA_ROUNDS as u64) as u32)
        .min(count)
}

/// The sweeps `k` of a pass's adaptive extras (`extras_round`): all `EXTRA_ROUNDS` where a
/// deadline can cut the pass, else the last alone, every pixel straight to its count (as in
/// `rounds`).
pub fn extra_rounds(can_cut: bool) -> std::ops::RangeInclusive<u32> {
    if can_cut {
        1..=EXTRA_ROUNDS
    } else {
        EXTRA_ROUNDS..=EXTRA_ROUNDS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn half() -> Proportional {
        Proportional { share: 0.5, min_spp: 0, max_ratio: 8.0 }
    }

    #[test]
    fn passes_sweep_the_image_in_rounds_of_about_equal_steps() {
        assert_eq!(rounds(16, 64, true), [28, 40, 52, 64]);
        assert_eq!(rounds(4, 16, true), [7, 10, 13, 16]);
        assert_eq!(rounds(1, 4, true), [2, 3, 4]);
        assert_eq!(rounds(0, 1, true), [1]);
        assert_eq!(rounds(64, 64, true), [64], "a pass that adds nothing");
        assert_eq!(rounds(16, 64, false), [64], "no deadline: one sweep");
        assert_eq!(rounds(u32::MAX - 2, u32::MAX, true), [u32::MAX - 1, u32::MAX]);
        // The extras: a sixteenth of each pixel's way per sweep (rounded up), the last sweep
        // its count.
        let sweeps = |base, count| (1..=EXTRA_ROUNDS).map(|k| extras_round(base, count, k)).collect::<Vec<_>>();
        assert_eq!(sweeps(4, 36), (1..=16).map(|k| 4 + 2 * k).collect::<Vec<_>>());
        assert_eq!(sweeps(4, 12)[..4], [5, 5, 6, 6]);
        assert_eq!(sweeps(4, 5), [5; 16]);
        assert_eq!(extras_round(4, 4, 1), 4, "a pixel with no extras");
        assert_eq!(extras_round(0, u32::MAX, EXTRA_ROUNDS), u32::MAX, "no overflow");
    }

    /// Four pixels, one noisy: it gets the adaptive half of the four pixels' samples on top of
    /// its uniform half, the others the uniform half; the total is kept.
    #[test]
    fn the_adaptive_share_goes_to_the_noisy_pixels_and_the_total_is_kept() {
        let taken = [16; 4];
        assert_eq!(half().counts(&[0.0, 1.0, 0.0, 0.0], 64, &taken).unwrap(), [32, 32 + 128, 32, 32]);
        assert_eq!(half().counts(&[1.0, 1.0, 0.0, 0.0], 64, &taken).unwrap(), [96, 96, 32, 32]);
        // No noise, or a sigma that is not finite: no adaptive counts.
        assert!(half().counts(&[0.0; 4], 64, &taken).is_none());
        assert!(half().counts(&[f64::INFINITY, 0.0, 0.0, 0.0], 64, &taken).is_none());
    }

    /// A pixel held at the cap gives what it would have had beyond it to the others.
    #[test]
    fn what_the_cap_cuts_off_goes_to_the_other_pixels() {
        let p = Proportional { max_ratio: 2.0, ..half() };
        // 160 capped at 128; the 32 cut off shared by three pixels: 32 + 32 / 3 each, whole
        // counts that keep the total of 256.
        assert_eq!(p.counts(&[0.0, 1.0, 0.0, 0.0], 64, &[16; 4]).unwrap(), [43, 128, 43, 42]);
    }

    /// A pixel never loses samples it has: a count below what it holds is raised to it.
    #[test]
    fn no_pixel_falls_below_the_samples_it_has() {
        assert_eq!(half().counts(&[1.0, 0.0], 256, &[64, 500]).unwrap(), [384, 500]);
    }

    /// The counts of a pass sum to exactly its total for any sigmas (a mean under the target
    /// would keep a render halted at that mean from ever stopping), whatever the fractions.
    #[test]
    fn counts_sum_to_the_pass_total() {
        use crate::render::test_rng::Rng;
        let mut rng = Rng(5);
        for case in 0..50 {
            let n = 1 + case * 7;
            let sigma: Vec<f64> = (0..n).map(|_| if rng.f() < 0.3 { 0.0 } else { rng.f() as f64 }).collect();
            for target in [4, 16, 64, 1000] {
                let p = Proportional { min_spp: case as u32 % 7, ..half() };
                if let Some(t) = p.counts(&sigma, target, &vec![1; n]) {
                    assert_eq!(t.iter().map(|&c| c as u64).sum::<u64>(), target as u64 * n as u64, "case {case}");
                }
            }
        }
        assert_eq!(whole_counts(&[1.5, 2.5, 3.0], 7.0), [2, 2, 3]);
        assert_eq!(whole_counts(&[0.2, 0.7, 0.1], 1.0), [0, 1, 0]);
    }

    /// The uniform share: `1 - share` of the pass, never fewer than `min_spp` samples, and
    /// never more than the pass's mean.
    #[test]
    fn the_uniform_share_has_a_floor() {
        let p = Proportional { share: 0.9, min_spp: 4, max_ratio: 8.0 };
        let shares: Vec<u32> = [2, 4, 16, 64, 256].iter().map(|&t| p.uniform_share(t)).collect();
        assert_eq!(shares, [2, 4, 4, 6, 26]);
        assert_eq!(Proportional { share: 1.0, min_spp: 0, ..p }.uniform_share(1 << 20), 0);
    }

    /// A pixel's pooled sigma is the square root of the variances around it averaged, pixels
    /// without a variance counting as none; none anywhere gives 0, not NaN.
    #[test]
    fn pooled_sigmas_average_the_neighbourhood_s_variances() {
        let own = [Some(4.0 / 3.0), Some(0.0), Some(0.0), None, Some(0.0)];
        let s = pooled_sigmas(5, &own, 1);
        let expect = [(4.0f64 / 3.0 / 2.0).sqrt(), (4.0f64 / 9.0).sqrt(), 0.0, 0.0, 0.0];
        for (a, b) in s.iter().zip(expect) {
            assert!((a - b).abs() < 1e-12, "{s:?}");
        }
        assert_eq!(pooled_sigmas(2, &[None, None], 1), [0.0, 0.0]);
        assert_eq!(pooled_sigmas(2, &[Some(f64::INFINITY), Some(1.0)], 0), [0.0, 1.0]);
    }
}

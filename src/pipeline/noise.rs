//! The render's own estimate of its error, behind the noise-target halt (`Halt::target_error`),
//! for every method alike: from the difference between consecutive frames.
//!
//! Frame k+1 holds frame k's samples plus new ones. For a pixel whose unbiased estimate goes
//! from n to n' samples, the difference D = f_k - f_{k+1} has variance s^2 (1/n - 1/n'), while
//! frame k+1's own error has s^2 / n'. So its squared error is D^2 n / (n' - n): for a doubling
//! of samples, just D^2. A filtered method's error also holds bias, which shrinks as its
//! filter narrows from pass to pass; the difference sees that change too (for a bias that
//! halves per pass, D equals the newer frame's bias). A pixel that got no new samples counts
//! with D^2 alone.
//!
//! A bias that shrinks more slowly than that is seen only in part (a filter narrowing by
//! 4^(-1/6) per pass, as `auto`'s does, shows D = 0.59 of the newer bias), so a filtered frame
//! that carries its unfiltered mean U also measures its bias directly: with F the filtered
//! frame, E[(F - U)^2] = E[(F - truth)^2] + Var U - 2 Cov(F, U), where Var U comes from the
//! unfiltered frames' difference as above and the covariance (the pixel's own samples' share
//! of its filtered value) is at least 0. So mean((F - U)^2) - mean(Var U) is at most F's squared
//! error, and close to it where the bias dominates, which is where the difference falls short;
//! the estimate is the larger of the two.
//!
//! The relative RMSE is sqrt(mean over pixels and channels of the squared error) divided by the
//! mean over pixels and channels of the newer frame: one number for the image, stable where
//! the image is dark (unlike a per-pixel relative error). `wedge bench noise` checks it against
//! the true error on built-in scenes (BENCHMARKS.md).
use super::frame::Frame;

/// A filtered frame whose mean filter width is above this fraction of the previous frame's
/// has no estimate: with the same filter, the difference sees the variance fall but not the
/// bias, which stays.
pub const NARROWING: f64 = 0.8;

/// What the estimate keeps of a frame: its colour, unfiltered mean, spp map and mean filter
/// width.
struct Kept {
    color: Vec<[f32; 3]>,
    unfiltered: Option<Vec<[f32; 3]>>,
    spp: Vec<f32>,
    width: Option<f64>,
}

/// Keeps the previous frame to compare the next one with.
#[derive(Default)]
pub struct ErrorEstimate {
    previous: Option<Kept>,
}

impl ErrorEstimate {
    /// The estimated relative RMSE of `frame`, remembering `frame` for the next call. None for
    /// the first frame, for a filtered frame whose filter did not narrow since the previous
    /// one (`NARROWING`), or for an image that changed but whose mean is not positive; 0 for a
    /// frame that did not change.
    pub fn update(&mut self, frame: &Frame) -> Option<f64> {
        let width = mean_filter_width(frame);
        let estimate = self.previous.as_ref().and_then(|k| {
            let narrowed = match (k.width, width) {
                (Some(before), Some(now)) => now <= NARROWING * before,
                _ => true,
            };
            let change = relative_error(&k.color, &k.spp, frame).filter(|&e| narrowed || e == 0.0)?;
            let bias = k.unfiltered.as_deref().and_then(|u| relative_bias(u, &k.spp, frame));
            Some(change.max(bias.unwrap_or(0.0)))
        });
        self.previous = Some(Kept {
            color: frame.color.clone(),
            unfiltered: frame.unfiltered.clone(),
            spp: frame.spp.clone(),
            width,
        });
        estimate
    }
}

/// The mean of a filtered frame's filter-width map over the pixels it filters; None for an
/// unfiltered frame (or one that filters nothing).
fn mean_filter_width(frame: &Frame) -> Option<f64> {
    let w = frame.filter_width.as_ref()?;
    let (sum, n) = w.iter().filter(|&&x| x > 0.0).fold((0.0f64, 0usize), |(s, n), &x| (s + x as f64, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// The estimated relative RMSE of `next`, which adds samples to the frame of `color` and `spp`.
pub fn relative_error(color: &[[f32; 3]], spp: &[f32], next: &Frame) -> Option<f64> {
    if color.len() != next.color.len() || color.is_empty() {
        return None;
    }
    let (mut sq, mut sum) = (0.0f64, 0.0f64);
    for (p, (a, b)) in color.iter().zip(&next.color).enumerate() {
        let weight = variance_weight(spp, next, p);
        for c in 0..3 {
            let d = (a[c] - b[c]) as f64;
            sq += d * d * weight;
            sum += b[c] as f64;
        }
    }
    let values = (color.len() * 3) as f64;
    let mean = sum / values;
    let rmse = (sq / values).sqrt();
    if rmse == 0.0 {
        // Nothing changed (a black image, or no new samples): no error left to see.
        return Some(0.0);
    }
    (mean > 0.0 && rmse.is_finite()).then(|| rmse / mean)
}

/// The weight that turns pixel `p`'s squared change between a frame of `spp` samples and `next`
/// into the variance of the newer one: n0 / (n1 - n0), or 1 where it got no new samples.
fn variance_weight(spp: &[f32], next: &Frame, p: usize) -> f64 {
    let (n0, n1) = (spp.get(p).copied().unwrap_or(0.0) as f64, next.spp.get(p).copied().unwrap_or(0.0) as f64);
    if n1 > n0 && n0 > 0.0 {
        n0 / (n1 - n0)
    } else {
        1.0
    }
}

/// A lower bound on the relative RMSE of the filtered frame `next` from its distance to its own
/// unfiltered mean, less that mean's variance (seen in its change since the previous frame's
/// unfiltered mean `unfiltered`, of `spp` samples); None when `next` has no unfiltered mean, or
/// its mean is not positive.
fn relative_bias(unfiltered: &[[f32; 3]], spp: &[f32], next: &Frame) -> Option<f64> {
    let u1 = next.unfiltered.as_deref()?;
    if unfiltered.len() != u1.len() || u1.len() != next.color.len() || u1.is_empty() {
        return None;
    }
    let (mut sq, mut sum) = (0.0f64, 0.0f64);
    for (p, ((u0, u1), f)) in unfiltered.iter().zip(u1).zip(&next.color).enumerate() {
        let weight = variance_weight(spp, next, p);
        for c in 0..3 {
            let (d, e) = ((f[c] - u1[c]) as f64, (u0[c] - u1[c]) as f64);
            sq += d * d - e * e * weight;
            sum += f[c] as f64;
        }
    }
    let values = (u1.len() * 3) as f64;
    let mean = sum / values;
    let rmse = (sq.max(0.0) / values).sqrt();
    (mean > 0.0 && rmse.is_finite()).then(|| rmse / mean)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::test_rng::Rng;

    /// A standard normal deviate (Box-Muller).
    fn normal(rng: &mut Rng) -> f64 {
        let (u, v) = (1.0 - rng.f() as f64, rng.f() as f64);
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }

    /// Frames of nested Monte Carlo means of a known image with known noise: the estimate of
    /// each frame's error must match its true error.
    fn nested_frames(counts: &[u32], sigma: f64, seed: u64) -> (Vec<Frame>, Vec<f64>) {
        let (w, h) = (64usize, 48usize);
        let truth: Vec<f64> = (0..w * h).map(|p| 0.2 + 0.6 * (p % w) as f64 / w as f64).collect();
        let mut rng = Rng(seed | 1);
        let mut sums = vec![0.0f64; w * h];
        let (mut taken, mut frames, mut errors) = (0u32, Vec::new(), Vec::new());
        for &n in counts {
            for (p, s) in sums.iter_mut().enumerate() {
                for _ in taken..n {
                    *s += truth[p] + sigma * normal(&mut rng);
                }
            }
            taken = n;
            let color: Vec<[f32; 3]> = sums.iter().map(|s| [(s / n as f64) as f32; 3]).collect();
            let sq: f64 = color.iter().zip(&truth).map(|(c, t)| (c[0] as f64 - t).powi(2)).sum::<f64>();
            let mean: f64 = truth.iter().sum::<f64>() / truth.len() as f64;
            errors.push((sq / truth.len() as f64).sqrt() / mean);
            frames.push(Frame {
                width: w as u32,
                height: h as u32,
                color,
                spp: vec![n as f32; w * h],
                ..Frame::default()
            });
        }
        (frames, errors)
    }

    #[test]
    fn the_estimate_matches_the_true_error_of_nested_monte_carlo_frames() {
        // Doubling, and uneven steps (1 -> 9 is the AAF family's first two passes).
        for counts in [&[1u32, 2, 4, 8, 16][..], &[1, 9, 18, 72]] {
            let (frames, truth) = nested_frames(counts, 0.3, 7);
            let mut est = ErrorEstimate::default();
            assert_eq!(est.update(&frames[0]), None, "the first frame has nothing to compare with");
            for (f, t) in frames[1..].iter().zip(&truth[1..]) {
                let e = est.update(f).unwrap();
                assert!((e / t - 1.0).abs() < 0.1, "counts {counts:?}: estimate {e}, true {t}");
            }
        }
    }

    #[test]
    fn a_filter_that_did_not_narrow_gives_no_estimate() {
        let frame = |value: f32, width: f32| Frame {
            width: 4,
            height: 4,
            color: vec![[value; 3]; 16],
            spp: vec![4.0; 16],
            filter_width: Some(vec![width; 16]),
            ..Frame::default()
        };
        let mut est = ErrorEstimate::default();
        est.update(&frame(0.5, 4.0));
        assert_eq!(est.update(&frame(0.49, 4.0)), None, "same width: the bias is unseen");
        assert!(est.update(&frame(0.48, 2.0)).is_some(), "halved width");
    }

    #[test]
    fn a_halving_bias_is_seen_as_the_newer_frames_bias() {
        let (w, h) = (16u32, 16u32);
        let frame = |bias: f32| Frame {
            width: w,
            height: h,
            color: vec![[0.5 + bias; 3]; (w * h) as usize],
            spp: vec![4.0; (w * h) as usize],
            ..Frame::default()
        };
        let mut est = ErrorEstimate::default();
        est.update(&frame(0.04));
        let e = est.update(&frame(0.02)).unwrap();
        assert!((e - 0.02 / 0.52).abs() < 1e-6, "{e}");
    }

    #[test]
    fn a_black_image_has_converged_and_one_that_turns_black_has_no_relative_error() {
        let black = Frame { width: 2, height: 1, color: vec![[0.0; 3]; 2], spp: vec![1.0; 2], ..Frame::default() };
        let mut est = ErrorEstimate::default();
        est.update(&black);
        assert_eq!(est.update(&black), Some(0.0));
        let grey = Frame { color: vec![[0.5; 3]; 2], ..black.clone() };
        est.update(&grey);
        assert_eq!(est.update(&Frame { spp: vec![2.0; 2], ..black }), None);
    }

    /// A filter whose bias shrinks by 4^(-1/3) per pass (its width by 4^(-1/6), `auto`'s
    /// narrowing) over fourfold samples: the frame difference sees a third of the bias, which
    /// dominates; the distance to the unfiltered mean sees all of it. The estimate must match
    /// the true error, where the difference alone falls short by more than 2x.
    #[test]
    fn a_slowly_shrinking_bias_is_measured_against_the_unfiltered_mean() {
        let counts = [16u32, 64, 256, 1024];
        let (raw, _) = nested_frames(&counts, 0.3, 11);
        let (w, h) = (raw[0].width as usize, raw[0].height as usize);
        let truth: Vec<f64> = (0..w * h).map(|p| 0.2 + 0.6 * (p % w) as f64 / w as f64).collect();
        let mut est = ErrorEstimate::default();
        let mut change_only = ErrorEstimate::default();
        for (k, frame) in raw.iter().enumerate() {
            let shrink = 4f64.powf(-(k as f64) / 3.0);
            // A smooth bias, and a tenth of the pixel's own noise (its share of the filter).
            let filtered: Vec<[f32; 3]> = (0..w * h)
                .map(|p| {
                    let bias = 0.05 * shrink * (1.0 + ((p / w) as f64 / h as f64));
                    let noise = frame.color[p][0] as f64 - truth[p];
                    [(truth[p] + bias + 0.1 * noise) as f32; 3]
                })
                .collect();
            let sq: f64 = filtered.iter().zip(&truth).map(|(c, t)| (c[0] as f64 - t).powi(2)).sum();
            let mean = filtered.iter().map(|c| c[0] as f64).sum::<f64>() / truth.len() as f64;
            let true_error = (sq / truth.len() as f64).sqrt() / mean;
            let width = Some(vec![4.0 * 4f32.powf(-(k as f32) / 6.0); w * h]);
            let f = Frame {
                color: filtered.clone(),
                unfiltered: Some(frame.color.clone()),
                filter_width: width.clone(),
                ..frame.clone()
            };
            let plain = Frame { color: filtered, filter_width: width, ..frame.clone() };
            let (e, e_change) = (est.update(&f), change_only.update(&plain));
            if k == 0 {
                continue;
            }
            let (e, e_change) = (e.unwrap(), e_change.unwrap());
            assert!((e / true_error - 1.0).abs() < 0.15, "pass {k}: estimate {e}, true {true_error}");
            assert!(true_error / e_change > 2.0, "pass {k}: the change alone sees {e_change} of {true_error}");
        }
    }
}

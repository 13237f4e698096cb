//! Where a filter's bias outgrows the noise it removes: the frame leans on each pixel's own
//! unfiltered mean there (methods.md §5.3).
//!
//! The filters narrow as n^(-1/6), so their bias shrinks slowly while an unfiltered pixel's
//! variance falls as 1/n: past some count the pixel's own mean is the better estimate, first
//! where the light changes within a kernel's reach: the creases of a room, whose incident light
//! falls off into the corner while the filter averages it with the open surface, and pixels that
//! straddle two surfaces. There the frame takes `F + a (U - F)`, F filtered and U unfiltered,
//! with the weight that minimises the expected squared error of the mix when F carries a bias b
//! and U a variance v: a = b^2 / (b^2 + v). The expected squared difference (F - U)^2 is
//! b^2 + v; one pixel's reading of it is too noisy (a weight drawn from noise alone puts back
//! the noise the filter removed), so b^2 is read off the 3 x 3 neighbourhood, a bias being
//! shared by neighbours and noise not, less `TRUST` times their mean variance. As the samples
//! grow every weight tends to 1 where the filter is biased, so the stream still converges to
//! the ground truth.
use rayon::prelude::*;

/// How many times the neighbourhood's variance its squared differences must exceed before a
/// bias is read off them.
const TRUST: f64 = 1.5;

/// Per pixel, the weight a. `composed` holds (F, U) per pixel, row-major `width` wide;
/// `variance[p]` is U's variance summed over the channels (infinite: too few samples to tell;
/// the pixel is neither mixed nor read). One weight for the three channels, so that the mix
/// does not shift the colour; a NaN anywhere gives 0.
pub(super) fn pooled_weights(width: usize, composed: &[([f64; 3], [f64; 3])], variance: &[f64]) -> Vec<f64> {
    let w = width.max(1);
    let h = composed.len() / w;
    // Each pixel's squared difference, once (None: not read).
    let readable: Vec<Option<(f64, f64)>> = (composed.par_iter().zip(variance))
        .map(|(&(f, u), &v)| {
            let d2: f64 = (0..3).map(|c| (f[c] - u[c]).powi(2)).sum();
            (v.is_finite() && v >= 0.0 && d2.is_finite()).then_some((d2, v))
        })
        .collect();
    (0..composed.len())
        .into_par_iter()
        .map(|p| {
            let v = variance[p];
            if !(v.is_finite() && v >= 0.0) {
                return 0.0;
            }
            let (mut d2, mut vs, mut k) = (0.0f64, 0.0f64, 0u32);
            for (dq, vq) in super::window(w, h, p, 1).filter_map(|q| readable[q]) {
                d2 += dq;
                vs += vq;
                k += 1;
            }
            let bias2 = if k > 0 { ((d2 - TRUST * vs) / k as f64).max(0.0) } else { 0.0 };
            if bias2 + v > 0.0 && composed[p].1.iter().all(|c| c.is_finite()) {
                bias2 / (bias2 + v)
            } else {
                0.0
            }
        })
        .collect()
}

/// `f + a (u - f)` per channel (f where a is 0, so that a non-finite u never leaks in).
pub(super) fn mix(f: [f64; 3], u: [f64; 3], a: f64) -> [f64; 3] {
    if a > 0.0 {
        [0, 1, 2].map(|c| f[c] + a * (u[c] - f[c]))
    } else {
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn weights(w: usize, composed: &[([f64; 3], [f64; 3])], v: f64) -> Vec<f64> {
        pooled_weights(w, composed, &vec![v; composed.len()])
    }

    #[test]
    fn the_weight_follows_the_bias_against_the_variance() {
        // A 4 x 3 image whose filtered value is 1 above its mean everywhere: d^2 = 3.
        let img = vec![([2.0; 3], [1.0; 3]); 12];
        // v = 1: b^2 = 3 - 1.5 = 1.5, a = 1.5 / 2.5.
        assert!(weights(4, &img, 1.0).iter().all(|&a| (a - 0.6).abs() < 1e-12));
        // Noise at the level of the difference: the filter is kept.
        assert!(weights(4, &img, 2.0).iter().all(|&a| a == 0.0));
        // No noise left: the pixel's own mean.
        assert!(weights(4, &img, 0.0).iter().all(|&a| a == 1.0));
        // Too few samples to tell: the filter.
        assert!(weights(4, &img, f64::INFINITY).iter().all(|&a| a == 0.0));
        assert_eq!(mix([2.0; 3], [1.0; 3], 0.6), [1.4; 3]);
    }

    /// One pixel's difference alone is read at a ninth of its size (its neighbourhood shows
    /// no bias); a bias along a row, as along a crease, at a third (three of nine pixels agree,
    /// two of six at the image's border).
    #[test]
    fn the_bias_is_read_off_the_neighbourhood() {
        let (w, h) = (5, 5);
        let mut img = vec![([1.0; 3], [1.0; 3]); w * h];
        img[12].0 = [4.0; 3]; // d^2 = 27 at the centre only
        let a = weights(w, &img, 0.0);
        assert_eq!(a[12], 1.0, "no noise: any bias is trusted");
        let a = weights(w, &img, 1.0);
        // Centre: b^2 = (27 - 1.5 * 9) / 9 = 1.5, a = 0.6. Its neighbours read the same bias
        // but have none of their own to mix (F = U there).
        assert!((a[12] - 0.6).abs() < 1e-12, "{}", a[12]);
        // A row of biased pixels (row 2): in the interior b^2 = (3 * 27 - 13.5) / 9 = 7.5.
        let mut img = vec![([1.0; 3], [1.0; 3]); w * h];
        for x in 0..w {
            img[2 * w + x].0 = [4.0; 3];
        }
        let a = weights(w, &img, 1.0);
        assert!((a[2 * w + 2] - 7.5 / 8.5).abs() < 1e-12, "{}", a[2 * w + 2]);
        // At the image's border the window is clipped: 2 of 6 pixels biased.
        assert!((a[2 * w] - 7.5 / 8.5).abs() < 1e-12, "{}", a[2 * w]);
        // NaN in a neighbour is skipped; in the pixel itself, no mix.
        img[2 * w + 1].1 = [f64::NAN; 3];
        let a = weights(w, &img, 1.0);
        assert_eq!(a[2 * w + 1], 0.0);
        assert!(a[2 * w + 2] > 0.0 && a[2 * w + 2].is_finite());
    }

    /// Over many draws of U around a filtered image with a biased crease: the mix is far below
    /// F's error where the bias dominates, and where the noise dominates it stays near F's (the
    /// noise let through where the neighbourhood's differences look like a bias is a small part
    /// of U's). A Monte Carlo check with a fixed seed.
    #[test]
    fn the_mix_beats_a_dominant_bias_and_keeps_the_filter_against_noise() {
        use crate::render::test_rng::Rng;
        let mut rng = Rng(21);
        let (w, h) = (16, 16);
        let truth = 1.0f64;
        for (bias, sd) in [(0.5f64, 0.05f64), (0.1, 0.1), (0.02, 0.2)] {
            // The bias on the crease (row 8), the filter exact elsewhere.
            let f: Vec<[f64; 3]> =
                (0..w * h).map(|p| if p / w == 8 { [truth + bias; 3] } else { [truth; 3] }).collect();
            let (mut e_mix, mut e_u, mut e_f) = (0.0, 0.0, 0.0);
            for _ in 0..200 {
                let composed: Vec<([f64; 3], [f64; 3])> = f
                    .iter()
                    .map(|&fp| {
                        let u = [0; 3].map(|_| {
                            let (a, b) = (rng.f().max(1e-7) as f64, rng.f() as f64);
                            truth + sd * (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
                        });
                        (fp, u)
                    })
                    .collect();
                let a = weights(w, &composed, 3.0 * sd * sd);
                for (p, &(fp, u)) in composed.iter().enumerate() {
                    let se = |x: [f64; 3]| x.iter().map(|c| (c - truth).powi(2)).sum::<f64>();
                    e_mix += se(mix(fp, u, a[p]));
                    e_u += se(u);
                    e_f += se(fp);
                }
            }
            assert!(e_mix <= e_f.min(e_u) + 0.05 * e_u, "bias {bias}, sd {sd}: mix {e_mix}, F {e_f}, U {e_u}");
            if bias > 5.0 * sd {
                assert!(e_mix < 0.5 * e_f, "bias {bias}: mix {e_mix}, F {e_f}");
            }
        }
    }
}

//! `auto`'s per-pixel sample counts once the image has enough samples to tell where its noise is
//! (methods.md §5.1): part of each pass's samples goes where one sample of the shadowed direct
//! light varies most, the penumbrae.
//!
//! At a fixed total N, the sum of the pixels' variances sum_p sigma_p^2 / n_p is least for
//! n_p ∝ sigma_p (a Lagrange multiplier), sigma_p the standard deviation of one sample. Mehta
//! 2012 Eq. 21 also puts its samples in the penumbrae, but it asks for more than a preview budget
//! has; this keeps each pass's total. A share of every pass stays uniform, so that every pixel's
//! count grows without bound (consistency) and noise the estimate does not see (indirect light,
//! antialiasing) is still sampled everywhere.
use super::options::AutoOptions;
use super::sample::{LightSums, PixelSums};
use crate::methods::aaf_shadows::ratio;
use crate::pipeline::film::mean;
use rayon::prelude::*;

/// The standard deviation of one sample of a pixel's shadowed diffuse direct light, summed over
/// its rectangular lights: r sqrt(v (1 - v)) per light and channel, v = A / B the visibility
/// (binary per shadow ray, so its variance is v (1 - v) where the integrand u is constant over
/// the light) and r the exact unshadowed light. Channels are averaged.
pub(super) fn direct_light_sigma(lights: &[LightSums]) -> f64 {
    let var: f64 = lights
        .iter()
        .map(|ls| {
            let (r, v) = (mean(ls.r, ls.r_n), ratio(ls.a, ls.b));
            (0..3).map(|c| r[c] * r[c] * (v[c] * (1.0 - v[c])).clamp(0.0, 0.25)).sum::<f64>() / 3.0
        })
        .sum();
    if var.is_finite() {
        var.sqrt()
    } else {
        0.0
    }
}

/// The samples each pixel should have after a pass whose mean is `target`, or None while the
/// counts stay uniform (below `opts.adaptive_from_spp`, or no pixel with shadow noise). Each
/// pixel gets `1 - adaptive_share` of `target`, plus its share of the rest in proportion to
/// its sigma, at most `adaptive_max_ratio` times `target` (what that cuts off is spread over the
/// other pixels), and never fewer than it has.
///
/// Only for direct light (`bounces` 0): sigma sees the shadows' noise alone, and with indirect
/// light, whose noise it misses, taking samples from the rest of the image for the penumbrae made
/// `cornell` (3 bounces) worse at 256 spp (BENCHMARKS.md, "Noise target").
pub(super) fn adaptive_targets(
    opts: &AutoOptions,
    target: u32,
    bounces: u32,
    sums: &[PixelSums],
    light_sums: &[LightSums],
    lights: usize,
) -> Option<Vec<u32>> {
    if opts.adaptive_from_spp == 0 || target < opts.adaptive_from_spp || lights == 0 || bounces > 0 {
        return None;
    }
    let sigma: Vec<f64> = light_sums.par_chunks(lights).map(direct_light_sigma).collect();
    // A sequential sum: the counts must not depend on the thread count.
    let total: f64 = sigma.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let share = opts.adaptive_share.clamp(0.0, 1.0);
    let (t, n) = (target as f64, sigma.len() as f64);
    let cap = opts.adaptive_max_ratio.max(1.0) * t;
    let want: Vec<f64> = sigma.par_iter().map(|s| ((1.0 - share) * t + share * t * n * s / total).min(cap)).collect();
    // What the cap cut off goes evenly to the pixels under it, so that the pass keeps its total.
    let under = want.iter().filter(|&&x| x < cap).count();
    let spare = (n * t - want.iter().sum::<f64>()).max(0.0) / under.max(1) as f64;
    Some(
        want.par_iter()
            .zip(sums)
            .map(|(&x, px)| {
                let x = if x < cap { x + spare } else { x };
                (x.round().min(u32::MAX as f64) as u32).max(px.taken)
            })
            .collect(),
    )
}

/// The count every pixel reaches in an adaptive pass of mean `target`, the uniform share.
pub(super) fn uniform_share(opts: &AutoOptions, target: u32) -> u32 {
    ((1.0 - opts.adaptive_share.clamp(0.0, 1.0)) * target as f64).round() as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn light(a: f64, b: f64, r: f64) -> LightSums {
        LightSums { a: [a; 3], b: [b; 3], r: [r; 3], r_n: 1, ..LightSums::default() }
    }

    #[test]
    fn sigma_is_that_of_a_binary_visibility_times_the_unshadowed_light() {
        // Half the light seen: r sqrt(1/4) = r / 2; fully lit and fully shadowed: no noise.
        assert!((direct_light_sigma(&[light(5.0, 10.0, 0.8)]) - 0.4).abs() < 1e-12);
        assert_eq!(direct_light_sigma(&[light(10.0, 10.0, 0.8)]), 0.0);
        assert_eq!(direct_light_sigma(&[light(0.0, 10.0, 0.8)]), 0.0);
        // Two lights: their variances add.
        let two = direct_light_sigma(&[light(5.0, 10.0, 0.8), light(2.0, 10.0, 0.6)]);
        assert!((two - (0.16f64 + 0.36 * 0.16).sqrt()).abs() < 1e-12);
        // Nothing sampled yet (b = 0 reads as lit) and a non-finite r give no noise, not NaN.
        assert_eq!(direct_light_sigma(&[light(0.0, 0.0, 1.0)]), 0.0);
        assert_eq!(direct_light_sigma(&[light(5.0, 10.0, f64::INFINITY)]), 0.0);
    }

    /// Four pixels, one in a penumbra: it gets the adaptive half of the four pixels' samples
    /// on top of its uniform half, the others the uniform half; the total is kept.
    #[test]
    fn the_adaptive_share_goes_to_the_noisy_pixels_and_the_total_is_kept() {
        let opts = AutoOptions::default();
        let sums = vec![PixelSums { taken: 16, ..PixelSums::default() }; 4];
        let lights = [light(10.0, 10.0, 1.0), light(5.0, 10.0, 1.0), light(0.0, 10.0, 1.0), light(10.0, 10.0, 1.0)];
        let t = adaptive_targets(&opts, 64, 0, &sums, &lights, 1).expect("adaptive at 64 spp");
        assert_eq!(t, [32, (32.0 + 0.5 * 64.0 * 4.0f64).min(opts.adaptive_max_ratio * 64.0) as u32, 32, 32]);
        // Spread over two noisy pixels, nothing is capped and the total is exactly 4 x 64.
        let lights = [light(5.0, 10.0, 1.0), light(5.0, 10.0, 1.0), light(0.0, 10.0, 1.0), light(10.0, 10.0, 1.0)];
        let t = adaptive_targets(&opts, 64, 0, &sums, &lights, 1).unwrap();
        assert_eq!(t, [96, 96, 32, 32]);
        assert_eq!(t.iter().sum::<u32>(), 4 * 64);
        assert!(t.iter().all(|&n| n >= uniform_share(&opts, 64)) && uniform_share(&opts, 64) == 32);
    }

    /// A pixel held at the cap gives what it would have had beyond it to the others.
    #[test]
    fn what_the_cap_cuts_off_goes_to_the_other_pixels() {
        let opts = AutoOptions { adaptive_max_ratio: 2.0, ..AutoOptions::default() };
        let sums = vec![PixelSums { taken: 16, ..PixelSums::default() }; 4];
        let lights = [light(10.0, 10.0, 1.0), light(5.0, 10.0, 1.0), light(0.0, 10.0, 1.0), light(10.0, 10.0, 1.0)];
        let t = adaptive_targets(&opts, 64, 0, &sums, &lights, 1).unwrap();
        // 160 capped at 128; the 32 cut off shared by three pixels: 32 + 32 / 3 each.
        assert_eq!(t, [43, 128, 43, 43]);
    }

    #[test]
    fn counts_stay_uniform_below_the_threshold_without_shadow_noise_with_bounces_and_when_off() {
        let mut opts = AutoOptions::default();
        let sums = vec![PixelSums::default(); 2];
        let noisy = [light(5.0, 10.0, 1.0), light(10.0, 10.0, 1.0)];
        assert!(adaptive_targets(&opts, opts.adaptive_from_spp / 2, 0, &sums, &noisy, 1).is_none());
        assert!(adaptive_targets(&opts, 256, 0, &sums, &[light(10.0, 10.0, 1.0); 2], 1).is_none());
        assert!(adaptive_targets(&opts, 256, 0, &sums, &[], 0).is_none());
        // With indirect light, whose noise sigma does not see.
        assert!(adaptive_targets(&opts, 256, 1, &sums, &noisy, 1).is_none());
        assert!(adaptive_targets(&opts, 256, 0, &sums, &noisy, 1).is_some());
        opts.adaptive_from_spp = 0;
        assert!(adaptive_targets(&opts, 256, 0, &sums, &noisy, 1).is_none());
    }

    /// A pixel never loses samples it has: a count below what it holds is raised to it.
    #[test]
    fn no_pixel_falls_below_the_samples_it_has() {
        let opts = AutoOptions::default();
        let mut sums = vec![PixelSums { taken: 64, ..PixelSums::default() }; 2];
        sums[1].taken = 500;
        let t = adaptive_targets(&opts, 256, 0, &sums, &[light(5.0, 10.0, 1.0), light(10.0, 10.0, 1.0)], 1).unwrap();
        assert_eq!(t, [(128.0f64 + 256.0).min(opts.adaptive_max_ratio * 256.0) as u32, 500]);
    }
}

//! `auto`'s per-pixel sample counts from its second pass on (methods.md §5.1): most of each
//! pass's samples go where one sample of the shadowed direct light varies most, the penumbrae and
//! the edges of objects. Each pixel's visibility variance is read off the shadow rays of its
//! neighbourhood, so that one sample per pixel already shows where the penumbrae lie, and its
//! own samples' variance shows the rest.
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
use crate::pipeline::allocation;
use crate::pipeline::film::mean;
use rayon::prelude::*;

/// The standard deviation of one sample of a pixel's shadowed diffuse direct light, summed over
/// its rectangular lights: r sqrt(v (1 - v)) per light and channel, v the visibility (binary per
/// shadow ray, so its variance is v (1 - v) where the integrand u is constant over the light)
/// and r the pixel's exact unshadowed light. Channels are averaged. `pooled(l)` gives light l's
/// sums (A, B) over the pixel's neighbourhood, v = A / B: a pixel's own few samples would see
/// no variance at all (one sample's v is 0 or 1), while a neighbourhood that holds both lit and
/// occluded rays marks a penumbra from the first sample on.
pub(super) fn direct_light_sigma(lights: &[LightSums], pooled: &dyn Fn(usize) -> ([f64; 3], [f64; 3])) -> f64 {
    let var: f64 = lights
        .iter()
        .enumerate()
        .map(|(l, ls)| {
            let (a, b) = pooled(l);
            let (r, v) = (mean(ls.r, ls.r_n), ratio(a, b));
            (0..3).map(|c| r[c] * r[c] * (v[c] * (1.0 - v[c])).clamp(0.0, 0.25)).sum::<f64>() / 3.0
        })
        .sum();
    if var.is_finite() {
        var.sqrt()
    } else {
        0.0
    }
}

/// Per pixel, `direct_light_sigma` with the visibility pooled over the (2 `radius` + 1)^2 pixels
/// around it (clipped at the image's border). Pixel-major `light_sums`, `lights` per pixel.
pub(super) fn pooled_sigmas(width: usize, radius: usize, light_sums: &[LightSums], lights: usize) -> Vec<f64> {
    let (w, n) = (width.max(1), light_sums.len() / lights.max(1));
    (0..n)
        .into_par_iter()
        .map(|p| {
            let pooled = |l: usize| {
                let (mut a, mut b) = ([0.0f64; 3], [0.0f64; 3]);
                for q in super::window(w, n / w, p, radius) {
                    let s = &light_sums[q * lights + l];
                    for c in 0..3 {
                        a[c] += s.a[c];
                        b[c] += s.b[c];
                    }
                }
                (a, b)
            };
            direct_light_sigma(&light_sums[p * lights..(p + 1) * lights], &pooled)
        })
        .collect()
}

/// Per pixel, the standard deviation of one sample's direct light as `auto` estimates it
/// (`PixelSums::y`), its variance averaged over the 3 x 3 pixels around it (clipped at the
/// border; pixels with fewer than two such samples count as none).
pub(super) fn measured_sigmas(width: usize, sums: &[PixelSums]) -> Vec<f64> {
    let own: Vec<Option<f64>> = sums.par_iter().map(|s| s.direct_variance()).collect();
    allocation::pooled_sigmas(width, &own, 1)
}

/// The samples each pixel should have after a pass whose mean is `target`, or None while the
/// counts stay uniform (below `opts.adaptive_from_spp`, or no pixel with noise). Each pixel gets
/// the uniform share (`allocation::Proportional::uniform_share`), plus its share of the rest in proportion to its sigma
/// (the larger of the shadow rays' and, with `adaptive_measured`, its samples'), at most
/// `adaptive_max_ratio` times `target` (what that cuts off is spread over the other pixels),
/// and never fewer than it has.
///
/// Only for direct light (`bounces` 0): sigma sees the direct light's noise alone, and with
/// indirect light, whose noise it misses, taking samples from the rest of the image for the
/// penumbrae made `cornell` (3 bounces) worse at 256 spp (BENCHMARKS.md, "Noise target").
pub(super) fn adaptive_targets(
    opts: &AutoOptions,
    target: u32,
    bounces: u32,
    width: usize,
    sums: &[PixelSums],
    light_sums: &[LightSums],
    lights: usize,
) -> Option<Vec<u32>> {
    if opts.adaptive_from_spp == 0 || target < opts.adaptive_from_spp || lights == 0 || bounces > 0 {
        return None;
    }
    let mut sigma = pooled_sigmas(width, opts.adaptive_radius, light_sums, lights);
    if opts.adaptive_measured {
        let measured = measured_sigmas(width, sums);
        sigma.par_iter_mut().zip(&measured).for_each(|(s, m)| *s = s.max(*m));
    }
    let taken: Vec<u32> = sums.par_iter().map(|px| px.taken).collect();
    opts.proportional().counts(&sigma, target, &taken)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn light(a: f64, b: f64, r: f64) -> LightSums {
        LightSums { a: [a; 3], b: [b; 3], r: [r; 3], r_n: 1, ..LightSums::default() }
    }

    /// `direct_light_sigma` of a pixel's own samples.
    fn own_sigma(lights: &[LightSums]) -> f64 {
        direct_light_sigma(lights, &|l| (lights[l].a, lights[l].b))
    }

    /// Half of each pass adaptive, from the shadow rays alone, with no floor, as the hand
    /// counts below (`the_uniform_share_...` tests the defaults' floor, `a_silhouette_...` the
    /// measured sigma).
    fn half_opts() -> AutoOptions {
        AutoOptions { adaptive_share: 0.5, adaptive_min_spp: 0, adaptive_measured: false, ..AutoOptions::default() }
    }

    /// `half_opts` with each pixel's own samples (no neighbourhood).
    fn own_opts() -> AutoOptions {
        AutoOptions { adaptive_radius: 0, ..half_opts() }
    }

    #[test]
    fn sigma_is_that_of_a_binary_visibility_times_the_unshadowed_light() {
        // Half the light seen: r sqrt(1/4) = r / 2; fully lit and fully shadowed: no noise.
        assert!((own_sigma(&[light(5.0, 10.0, 0.8)]) - 0.4).abs() < 1e-12);
        assert_eq!(own_sigma(&[light(10.0, 10.0, 0.8)]), 0.0);
        assert_eq!(own_sigma(&[light(0.0, 10.0, 0.8)]), 0.0);
        // Two lights: their variances add.
        let two = own_sigma(&[light(5.0, 10.0, 0.8), light(2.0, 10.0, 0.6)]);
        assert!((two - (0.16f64 + 0.36 * 0.16).sqrt()).abs() < 1e-12);
        // Nothing sampled yet (b = 0 reads as lit) and a non-finite r give no noise, not NaN.
        assert_eq!(own_sigma(&[light(0.0, 0.0, 1.0)]), 0.0);
        assert_eq!(own_sigma(&[light(5.0, 10.0, f64::INFINITY)]), 0.0);
    }

    /// After one sample per pixel each pixel's own visibility is 0 or 1 and shows no variance;
    /// pooled over a neighbourhood, the pixels near the shadow's edge show it, the ones whose
    /// neighbourhood lies wholly on one side do not, and the border clips the window.
    #[test]
    fn a_neighbourhood_shows_a_penumbra_after_one_sample() {
        let (w, h) = (5, 4);
        // Columns 0-1 occluded, 2-4 lit; r = 0.8 everywhere.
        let sums: Vec<LightSums> =
            (0..w * h).map(|p| if p % w < 2 { light(0.0, 1.0, 0.8) } else { light(1.0, 1.0, 0.8) }).collect();
        assert!(pooled_sigmas(w, 0, &sums, 1).iter().all(|&s| s == 0.0));
        let s = pooled_sigmas(w, 1, &sums, 1);
        for y in 0..h {
            let row = &s[y * w..(y + 1) * w];
            // Column 1 sees columns 0-2 (v = 1/3), column 2 sees 1-3 (v = 2/3): the same v (1 - v).
            let edge = 0.8 * (2.0f64 / 9.0).sqrt();
            assert!((row[1] - edge).abs() < 1e-12 && (row[2] - edge).abs() < 1e-12, "row {y}: {row:?}");
            assert_eq!((row[0], row[4]), (0.0, 0.0), "row {y}: a window on one side of the edge");
            // Column 3 sees 2-4 only: lit.
            assert_eq!(row[3], 0.0);
        }
        // Two lights: the pooled variances add, each light's from its own sums.
        let two: Vec<LightSums> = sums.iter().flat_map(|&s| [s, light(1.0, 2.0, 0.5)]).collect();
        let s2 = pooled_sigmas(w, 1, &two, 2);
        assert!((s2[1] - (0.64f64 * 2.0 / 9.0 + 0.25 * 0.25).sqrt()).abs() < 1e-12);
        // And the counts follow: with the pass's mean at 4, the edge columns get the most.
        let px = vec![PixelSums { taken: 1, ..PixelSums::default() }; w * h];
        let opts = AutoOptions { adaptive_radius: 1, ..half_opts() };
        let t = adaptive_targets(&opts, 4, 0, w, &px, &sums, 1).expect("adaptive from 4 spp");
        assert_eq!((t[0], t[1], t[2], t[3]), (2, 7, 7, 2), "{t:?}");
        assert_eq!(t.iter().sum::<u32>(), 4 * (w * h) as u32);
    }

    /// Four pixels, one in a penumbra: it gets the adaptive half of the four pixels' samples
    /// on top of its uniform half, the others the uniform half; the total is kept.
    #[test]
    fn the_adaptive_share_goes_to_the_noisy_pixels_and_the_total_is_kept() {
        let opts = own_opts();
        let sums = vec![PixelSums { taken: 16, ..PixelSums::default() }; 4];
        let lights = [light(10.0, 10.0, 1.0), light(5.0, 10.0, 1.0), light(0.0, 10.0, 1.0), light(10.0, 10.0, 1.0)];
        let t = adaptive_targets(&opts, 64, 0, 4, &sums, &lights, 1).expect("adaptive at 64 spp");
        assert_eq!(t, [32, (32.0 + 0.5 * 64.0 * 4.0f64).min(opts.adaptive_max_ratio * 64.0) as u32, 32, 32]);
        // Spread over two noisy pixels, nothing is capped and the total is exactly 4 x 64.
        let lights = [light(5.0, 10.0, 1.0), light(5.0, 10.0, 1.0), light(0.0, 10.0, 1.0), light(10.0, 10.0, 1.0)];
        let t = adaptive_targets(&opts, 64, 0, 4, &sums, &lights, 1).unwrap();
        assert_eq!(t, [96, 96, 32, 32]);
        assert_eq!(t.iter().sum::<u32>(), 4 * 64);
        assert!(
            t.iter().all(|&n| n >= opts.proportional().uniform_share(64))
                && opts.proportional().uniform_share(64) == 32
        );
    }

    /// The counts of a pass sum to exactly its total for any sigmas (a mean under the target
    /// would keep a render halted at that mean from ever stopping), whatever the fractions.
    #[test]
    fn counts_sum_to_the_pass_total() {
        use crate::render::test_rng::Rng;
        let mut rng = Rng(5);
        for case in 0..50 {
            let n = 1 + case * 7;
            let sums = vec![PixelSums { taken: 1, ..PixelSums::default() }; n];
            let lights: Vec<LightSums> =
                (0..n).map(|_| light((10.0 * rng.f() as f64).floor(), 10.0, rng.f() as f64)).collect();
            for target in [4, 16, 64, 1000] {
                let opts = AutoOptions { adaptive_radius: case % 3, adaptive_min_spp: case as u32 % 7, ..half_opts() };
                if let Some(t) = adaptive_targets(&opts, target, 0, 1 + case % 5, &sums, &lights, 1) {
                    assert_eq!(t.iter().map(|&c| c as u64).sum::<u64>(), target as u64 * n as u64, "case {case}");
                }
            }
        }
    }

    /// A pixel held at the cap gives what it would have had beyond it to the others.
    #[test]
    fn what_the_cap_cuts_off_goes_to_the_other_pixels() {
        let opts = AutoOptions { adaptive_max_ratio: 2.0, ..own_opts() };
        let sums = vec![PixelSums { taken: 16, ..PixelSums::default() }; 4];
        let lights = [light(10.0, 10.0, 1.0), light(5.0, 10.0, 1.0), light(0.0, 10.0, 1.0), light(10.0, 10.0, 1.0)];
        let t = adaptive_targets(&opts, 64, 0, 4, &sums, &lights, 1).unwrap();
        // 160 capped at 128; the 32 cut off shared by three pixels: 32 + 32 / 3 each, whole
        // counts that keep the total of 256.
        assert_eq!(t, [43, 128, 43, 42]);
    }

    #[test]
    fn counts_stay_uniform_below_the_threshold_without_shadow_noise_with_bounces_and_when_off() {
        let mut opts = own_opts();
        let sums = vec![PixelSums::default(); 2];
        let noisy = [light(5.0, 10.0, 1.0), light(10.0, 10.0, 1.0)];
        assert!(adaptive_targets(&opts, opts.adaptive_from_spp / 2, 0, 2, &sums, &noisy, 1).is_none());
        assert!(adaptive_targets(&opts, 256, 0, 2, &sums, &[light(10.0, 10.0, 1.0); 2], 1).is_none());
        assert!(adaptive_targets(&opts, 256, 0, 2, &sums, &[], 0).is_none());
        // With indirect light, whose noise sigma does not see.
        assert!(adaptive_targets(&opts, 256, 1, 2, &sums, &noisy, 1).is_none());
        assert!(adaptive_targets(&opts, 256, 0, 2, &sums, &noisy, 1).is_some());
        opts.adaptive_from_spp = 0;
        assert!(adaptive_targets(&opts, 256, 0, 2, &sums, &noisy, 1).is_none());
    }

    /// A pixel never loses samples it has: a count below what it holds is raised to it.
    #[test]
    fn no_pixel_falls_below_the_samples_it_has() {
        let opts = own_opts();
        let mut sums = vec![PixelSums { taken: 64, ..PixelSums::default() }; 2];
        sums[1].taken = 500;
        let t = adaptive_targets(&opts, 256, 0, 2, &sums, &[light(5.0, 10.0, 1.0), light(10.0, 10.0, 1.0)], 1).unwrap();
        assert_eq!(t, [(128.0f64 + 256.0).min(opts.adaptive_max_ratio * 256.0) as u32, 500]);
    }
    /// The defaults' uniform share: a tenth of the pass, but never fewer than
    /// `adaptive_min_spp` samples, and never more than the pass's mean.
    #[test]
    fn the_uniform_share_has_a_floor() {
        let opts = AutoOptions::default();
        assert_eq!((opts.adaptive_share, opts.adaptive_min_spp), (0.9, 4), "the defaults this test is written for");
        assert_eq!(opts.proportional().uniform_share(2), 2);
        assert_eq!(opts.proportional().uniform_share(4), 4);
        assert_eq!(opts.proportional().uniform_share(16), 4);
        assert_eq!(opts.proportional().uniform_share(64), 6);
        assert_eq!(opts.proportional().uniform_share(256), 26);
        // The floor holds in the counts: the noise-free pixels keep it, the noisy one takes the rest.
        let sums = vec![PixelSums { taken: 4, ..PixelSums::default() }; 4];
        let lights = [light(10.0, 10.0, 1.0), light(5.0, 10.0, 1.0), light(0.0, 10.0, 1.0), light(10.0, 10.0, 1.0)];
        let own = AutoOptions { adaptive_radius: 0, adaptive_measured: false, ..opts };
        assert_eq!(adaptive_targets(&own, 16, 0, 4, &sums, &lights, 1).unwrap(), [4, 52, 4, 4]);
        let all = AutoOptions { adaptive_share: 1.0, adaptive_min_spp: 0, ..own };
        assert_eq!(all.proportional().uniform_share(1 << 20), 0);
    }

    /// A pixel's measured sigma is the square root of its one-sample variance of y averaged over
    /// its 3 x 3 window, pixels with fewer than two samples of y counting as none.
    #[test]
    fn the_measured_sigma_averages_the_neighbourhood_s_variances() {
        // Samples y of values {0, 2} (variance 4/3 at n = 3, unbiased) and {1, 1, 1} (none).
        let noisy = PixelSums { y: 2.0, y2: 4.0, y_n: 3, ..PixelSums::default() };
        let flat = PixelSums { y: 3.0, y2: 3.0, y_n: 3, ..PixelSums::default() };
        let one = PixelSums { y: 5.0, y2: 25.0, y_n: 1, ..PixelSums::default() };
        assert!((noisy.direct_variance().unwrap() - 4.0 / 3.0).abs() < 1e-12);
        assert_eq!(flat.direct_variance(), Some(0.0));
        assert_eq!(one.direct_variance(), None);
        // A row of five: noisy, flat, flat, one, flat.
        let s = measured_sigmas(5, &[noisy, flat, flat, one, flat]);
        let expect = [(4.0f64 / 3.0 / 2.0).sqrt(), (4.0f64 / 9.0).sqrt(), 0.0, 0.0, 0.0];
        for (a, b) in s.iter().zip(expect) {
            assert!((a - b).abs() < 1e-12, "{s:?}");
        }
        // No samples anywhere: no noise, not NaN.
        assert_eq!(measured_sigmas(2, &[one, one]), [0.0, 0.0]);
    }

    /// A pixel whose shadow rays see no penumbra but whose own samples vary (an object's edge
    /// across it) gets the adaptive samples when the measured sigma is on, and none when off.
    #[test]
    fn a_silhouette_the_shadow_rays_do_not_see_gets_samples() {
        // Every pixel's four samples of y are 1, 1, 1, 1; the centre's 0, 0, 2, 2.
        let flat = PixelSums { taken: 4, y: 4.0, y2: 4.0, y_n: 4, ..PixelSums::default() };
        let mut wide = vec![flat; 25];
        wide[12] = PixelSums { y2: 8.0, ..flat };
        // Lit everywhere: the shadow rays see no noise.
        let lights = vec![light(10.0, 10.0, 1.0); 25];
        let opts = AutoOptions { adaptive_radius: 0, ..AutoOptions::default() };
        let t = adaptive_targets(&opts, 64, 0, 5, &wide, &lights, 1).expect("measured noise");
        assert_eq!(t.iter().sum::<u32>(), 25 * 64);
        // The nine pixels whose window holds the centre share the rest of the pass.
        let base = opts.proportional().uniform_share(64);
        for p in 0..25usize {
            let near = (p % 5).abs_diff(2) <= 1 && (p / 5).abs_diff(2) <= 1;
            assert!(if near { t[p] > 64 } else { t[p] == base }, "pixel {p}: {t:?}");
        }
        let off = AutoOptions { adaptive_measured: false, ..opts };
        assert!(adaptive_targets(&off, 64, 0, 5, &wide, &lights, 1).is_none());
    }
}

//! From per-pixel bandwidths to where and how much to shade (Bagher et al. 2012, Sec. 2.2,
//! 2.3 and 3.1): the pixel's bandwidth from a few light directions (Eq. 4) and its variance
//! bound (Eq. 8), the image-space bandwidth (Eq. 5), the level to shade at (Eq. 9), sample
//! counts from a fixed budget, and the pyramids of levels (min) and variances (max).
//!
//! Levels are spacing exponents: level l shades every 2^l-th pixel in each direction, 0 every
//! pixel, and negative levels (-1, -2) 2^-l samples per pixel along each axis for
//! antialiasing. The paper's Sec. 3.2 counts resolutions the other way (2^k x 2^k); this
//! module keeps Eq. 9's sense throughout.
use super::vector::Nu;

/// One light direction's part in a pixel's bandwidth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionBand {
    /// The bandwidth at the eye along this direction's one-bounce path (Eq. 3).
    pub nu: Nu,
    /// Angular bandwidth of the incident light at the point and of the BRDF for this pair of
    /// directions (Eq. 7's `nu_xa` and `nu_rho_a`).
    pub light_a: f64,
    pub brdf_a: f64,
    /// Luminance of the incident radiance `L_i` and of `L_i rho` (`chi_i`), and the cosine.
    pub radiance: f64,
    pub chi: f64,
    pub cos: f64,
    /// 1 / the density the direction was drawn with (1 for the paper's uniform form).
    pub inv_pdf: f64,
}

/// Eq. 4 and Eq. 8 over a pixel's directions: its bandwidth and its variance bound.
///
/// Eq. 4 as printed divides by the sum of `L_i` alone, so its weights `L_i rho cos` do not
/// sum to 1; `normalised` divides by their own sum instead (methods.md §4.1). Either way a
/// pixel that receives no light gets bandwidth 0 (never 0 / 0). Directions drawn by
/// importance carry 1 / pdf in every sum (Eq. 4 and 8 are written for uniform directions).
pub fn pixel_bandwidth(directions: &[DirectionBand], normalised: bool) -> (Nu, f64) {
    let (mut num_s, mut num_a, mut den, mut weights, mut variance) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for d in directions {
        let w = d.chi * d.cos.max(0.0) * d.inv_pdf;
        if !(w.is_finite() && d.nu.s.is_finite() && d.nu.a.is_finite()) {
            // A direction with a non-band-limited path: the pixel is as sharp as it gets.
            if w > 0.0 || w.is_nan() {
                return (Nu { s: f64::INFINITY, a: f64::INFINITY }, f64::INFINITY);
            }
            continue;
        }
        num_s += d.nu.s * w;
        num_a += d.nu.a * w;
        weights += w;
        den += d.radiance * d.inv_pdf;
        variance += (d.light_a + d.brdf_a) * d.chi * d.chi * d.inv_pdf;
    }
    let den = if normalised { weights } else { den };
    let nu = if den > 0.0 { Nu { s: num_s / den, a: num_a / den } } else { Nu::ZERO };
    (nu, variance / directions.len().max(1) as f64)
}

/// Eq. 5: the image-space bandwidth in cycles per pixel of angular bandwidth `nu_a` (per
/// radian) seen through a `fov_x` x `fov_y` (radians) view of `width` x `height` pixels.
pub fn image_bandwidth(nu_a: f64, fov_x: f64, fov_y: f64, width: u32, height: u32) -> f64 {
    nu_a * (fov_x / width as f64).max(fov_y / height as f64)
}

/// Eq. 9: the level to shade at, `min(floor(log2(1 / b_p)), min(log2 W, log2 H))`, never
/// finer than `finest` (0, or -1 / -2 with antialiasing). Zero bandwidth gives the coarsest
/// level; an infinite or NaN one the finest.
pub fn shading_level(b_p: f64, width: u32, height: u32, finest: i32) -> i32 {
    let coarsest = (width.min(height).max(1) as f64).log2().floor() as i32;
    if b_p.is_nan() || b_p == f64::INFINITY {
        return finest;
    }
    if b_p <= 0.0 {
        return coarsest.max(finest);
    }
    let level = (1.0 / b_p).log2().floor();
    (level.clamp(finest as f64, coarsest as f64) as i32).max(finest)
}

/// Samples per shaded pixel from a total budget in proportion to the variance bounds
/// (Eq. 8): `max(1, round(total V / sum V))`; equal shares when no pixel has variance.
pub fn sample_counts(variance: &[f64], total: f64) -> Vec<u32> {
    let finite: Vec<f64> = variance.iter().map(|&v| if v.is_finite() && v > 0.0 { v } else { 0.0 }).collect();
    let sum: f64 = finite.iter().sum();
    let n = variance.len().max(1) as f64;
    variance
        .iter()
        .zip(&finite)
        .map(|(&v, &f)| {
            let share = if v == f64::INFINITY {
                total / n * 4.0
            } else if sum > 0.0 {
                total * f / sum
            } else {
                total / n
            };
            (share.round().max(1.0)).min(u32::MAX as f64) as u32
        })
        .collect()
}

/// A pyramid of a `width` x `height` buffer: level k is ceil(width / 2^k) x ceil(height /
/// 2^k), each entry reducing its 2 x 2 children with `reduce` (min for levels: a coarse
/// entry decides for all its pixels, so it takes the finest any of them needs; max for
/// variances), up to a single entry.
pub fn pyramid<T: Copy>(
    base: &[T],
    width: usize,
    height: usize,
    reduce: impl Fn(T, T) -> T,
) -> Vec<(usize, usize, Vec<T>)> {
    assert_eq!(base.len(), width * height);
    let mut levels = vec![(width, height, base.to_vec())];
    while let Some((w, h, prev)) = levels.last().filter(|(w, h, _)| *w > 1 || *h > 1) {
        let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
        let mut next = Vec::with_capacity(nw * nh);
        for y in 0..nh {
            for x in 0..nw {
                let mut v = prev[(2 * y) * w + 2 * x];
                for (dx, dy) in [(1, 0), (0, 1), (1, 1)] {
                    let (cx, cy) = (2 * x + dx, 2 * y + dy);
                    if cx < *w && cy < *h {
                        v = reduce(v, prev[cy * w + cx]);
                    }
                }
                next.push(v);
            }
        }
        levels.push((nw, nh, next));
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq_9_gives_the_spacing_exponents_of_methods_md() {
        // b_p = 1/8 -> 3, 0.3 -> 1, 1 -> 0, 0 -> the coarsest (log2 of the smaller side).
        assert_eq!(shading_level(0.125, 512, 256, 0), 3);
        assert_eq!(shading_level(0.3, 512, 256, 0), 1);
        assert_eq!(shading_level(1.0, 512, 256, 0), 0);
        assert_eq!(shading_level(0.0, 512, 256, 0), 8);
        assert_eq!(shading_level(1e-9, 512, 256, 0), 8);
        // Beyond Nyquist: the finest level allowed, 0 or an antialiasing level.
        assert_eq!(shading_level(3.0, 512, 256, 0), 0);
        assert_eq!(shading_level(3.0, 512, 256, -2), -2);
        assert_eq!(shading_level(1.5, 512, 256, -2), -1);
        for b in [f64::INFINITY, f64::NAN] {
            assert_eq!(shading_level(b, 512, 256, -1), -1);
        }
        assert_eq!(shading_level(f64::NEG_INFINITY, 7, 5, 0), 2);
    }

    #[test]
    fn eq_5_converts_radians_to_pixels_by_the_larger_pixel_angle() {
        let b = image_bandwidth(100.0, 0.8, 0.6, 400, 200);
        assert!((b - 100.0 * 0.003).abs() < 1e-12);
    }

    #[test]
    fn eq_4_averages_by_reflected_light_and_guards_the_dark() {
        let d = |a: f64, chi: f64| DirectionBand {
            nu: Nu { s: 1.0, a },
            light_a: a,
            brdf_a: 2.0,
            radiance: 1.0,
            chi,
            cos: 1.0,
            inv_pdf: 1.0,
        };
        let (nu, v) = pixel_bandwidth(&[d(10.0, 3.0), d(20.0, 1.0)], true);
        assert!((nu.a - (10.0 * 3.0 + 20.0) / 4.0).abs() < 1e-12 && (nu.s - 1.0).abs() < 1e-12);
        // Eq. 8: sum of (nu_xa + nu_rho) chi^2 over the directions (averaged).
        assert!((v - ((12.0 * 9.0) + 22.0) / 2.0).abs() < 1e-12);
        // As printed: divided by the sum of L (2) instead of the weights' (4).
        let (nu, _) = pixel_bandwidth(&[d(10.0, 3.0), d(20.0, 1.0)], false);
        assert!((nu.a - 25.0).abs() < 1e-12);
        // No light: 0, not NaN. A non-band-limited direction that carries light: infinite.
        let (nu, v) = pixel_bandwidth(&[d(10.0, 0.0), DirectionBand { radiance: 0.0, ..d(5.0, 0.0) }], false);
        assert_eq!((nu, v), (Nu::ZERO, 0.0));
        let (nu, _) = pixel_bandwidth(&[d(f64::INFINITY, 1.0)], true);
        assert_eq!(nu.a, f64::INFINITY);
        assert_eq!(pixel_bandwidth(&[], true).0, Nu::ZERO);
    }

    #[test]
    fn sample_counts_share_the_budget_by_variance() {
        assert_eq!(sample_counts(&[1.0, 3.0, 0.0], 40.0), vec![10, 30, 1]);
        assert_eq!(sample_counts(&[0.0, 0.0], 10.0), vec![5, 5]);
        let c = sample_counts(&[f64::NAN, 1.0, f64::INFINITY], 10.0);
        assert!(c.iter().all(|&n| n >= 1) && c[2] > c[1]);
    }

    #[test]
    fn a_min_pyramid_is_never_coarser_than_any_child() {
        let (w, h) = (7, 5);
        let base: Vec<i32> = (0..w * h).map(|i| ((i * 37) % 9) as i32 - 2).collect();
        let p = pyramid(&base, w, h, i32::min);
        assert_eq!(p.last().map(|(w, h, _)| (*w, *h)), Some((1, 1)));
        assert_eq!(p.last().unwrap().2[0], *base.iter().min().unwrap());
        for k in 1..p.len() {
            let (pw, ph, ref prev) = p[k - 1];
            let (cw, _, ref cur) = p[k];
            for y in 0..ph {
                for x in 0..pw {
                    assert!(cur[(y / 2) * cw + x / 2] <= prev[y * pw + x], "level {k} ({x}, {y})");
                }
            }
        }
        let maxes = pyramid(&[1.0, 5.0, 2.0, 3.0], 2, 2, f64::max);
        assert_eq!(maxes[1].2, vec![5.0]);
    }
}

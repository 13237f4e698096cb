//! Filter width and sample count of axis-aligned filtering of soft shadows
//! (Mehta, Wang, Ramamoorthi 2012, "Axis-Aligned Filtering for Interactive Sampled Soft
//! Shadows"; equation numbers are that paper's). All lengths in one unit (world or internal):
//! only ratios and products with `d` appear.

/// Constants of the method (Sec. 6: k = 3, alpha = 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AafConstants {
    /// Gaussian energy spread factor in Eq. 13.
    pub k: f64,
    /// Geometry bandlimit relative to the pixel bandlimit, Eq. 5 (1 = conservative).
    pub alpha: f64,
}

impl Default for AafConstants {
    fn default() -> Self {
        AafConstants { k: 3.0, alpha: 1.0 }
    }
}

/// Per-pixel inputs: slopes from the occluder distances (Eq. 4), light size, pixel footprint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelGeometry {
    /// Maximum slope s1 = d1/d2_min - 1 (occluder nearest the light), >= s2.
    pub s1: f64,
    /// Minimum slope s2 = d1/d2_max - 1 (occluder nearest the receiver), >= 0.
    pub s2: f64,
    /// Light standard deviation sigma (Omega_L^max = 1/sigma); 0 for a point-like light.
    pub sigma: f64,
    /// Projected pixel size d (Omega_pix^max = 1/d).
    pub d: f64,
}

/// Slope of one occluded shadow ray: an occluder at distance `t` from the receiver on a ray of
/// length `l` to the light. By similar triangles d1/d2 - 1 = t/(l - t) (methods.md §1.1), which
/// needs no light-plane distances and is never negative. Returns infinity for t >= l.
pub fn slope(t: f64, l: f64) -> f64 {
    if t >= l {
        f64::INFINITY
    } else {
        (t / (l - t)).max(0.0)
    }
}

/// `a * b` treating 0 * inf as 0: a zero bandwidth stays zero whatever it is multiplied by.
fn mul0(a: f64, b: f64) -> f64 {
    if a == 0.0 || b == 0.0 {
        0.0
    } else {
        a * b
    }
}

/// The bandlimits of Eqs. 6-8 at filter scale `mu` (Sec. 5.2: Omega_x^f = mu Omega_x0^f).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bandlimits {
    pub omega_l: f64,
    pub omega_x_max: f64,
    pub omega_y_max: f64,
    pub omega_x_f: f64,
    pub omega_y_f: f64,
}

pub fn bandlimits(g: &PixelGeometry, c: &AafConstants, mu: f64) -> Bandlimits {
    let omega_pix = 1.0 / g.d;
    let omega_l = 1.0 / g.sigma; // inf for sigma = 0
                                 // Eq. 6: alpha (d2_max/d1) Omega_pix = alpha / (1 + s2) Omega_pix.
    let omega_x_max = c.alpha / (1.0 + g.s2) * omega_pix;
    // Eq. 7: alpha (1 - d2_min/d1) Omega_pix = alpha s1/(1 + s1) Omega_pix, written so that
    // s1 = inf (occluder at the light) gives alpha Omega_pix instead of NaN.
    let omega_y_max = c.alpha / (1.0 + 1.0 / g.s1) * omega_pix;
    // Eq. 8 with mu applied to the critical filter; min taken before any product so that
    // s2 = 0 (Omega_L/s2 = inf) selects Omega_x^max (methods.md §1.3).
    let omega_x_f = mu * (omega_l / g.s2).min(omega_x_max);
    Bandlimits { omega_l, omega_x_max, omega_y_max, omega_x_f, omega_y_f: omega_l }
}

/// Filter standard deviation beta (Eq. 13), same unit as `d`:
/// beta = (1/k)(1/mu) max(sigma s2, 1/Omega_x^max). Proportional to 1/mu. (The paper's
/// footnote 4 prints beta = k^-1 Omega_x^f, a typo for 1/(k Omega_x^f).) A point-like light
/// (sigma = 0) casts hard shadows, which are not filtered: 0.
pub fn filter_width(g: &PixelGeometry, c: &AafConstants, mu: f64) -> f64 {
    if !(g.sigma > 0.0) {
        return 0.0;
    }
    let b = bandlimits(g, c, 1.0);
    (g.sigma * g.s2).max(1.0 / b.omega_x_max) / (c.k * mu)
}

/// Samples per pixel from the general form of Eq. 15 with packing (a) of Fig. 4:
/// n = (Omega*_x)^2 (Omega*_y)^2 A_p A_l, Omega*_x = Omega_x^f + Omega_x^max,
/// Omega*_y = Omega_y^f + min(s1 Omega_x^f, Omega_y^max), A_p = d^2, A_l = (2 sigma)^2.
/// Equals Eq. 21 where its clamps are inactive, and stays finite for s2 -> 0 and s1 -> inf.
/// A point-like light (sigma = 0) casts hard shadows: nothing to gain, the minimum `n_min`.
pub fn sample_count(g: &PixelGeometry, c: &AafConstants, mu: f64, n_min: f64) -> f64 {
    if !(g.sigma > 0.0) {
        return n_min;
    }
    let b = bandlimits(g, c, mu);
    // Products with the areas taken per factor, so that huge Omega_L meets tiny A_l finitely.
    let x = (b.omega_x_f + b.omega_x_max) * g.d;
    let y = (b.omega_y_f + mul0(g.s1, b.omega_x_f).min(b.omega_y_max)) * 2.0 * g.sigma;
    let n = x * x * y * y;
    if n.is_finite() {
        n.max(n_min)
    } else {
        n_min
    }
}

/// Eq. 21 as printed (common case, no min/max active): the oracle for the general form.
#[cfg(test)]
fn sample_count_eq21(g: &PixelGeometry, c: &AafConstants, mu: f64) -> f64 {
    let (ap, al) = (g.d * g.d, 4.0 * g.sigma * g.sigma);
    4.0 * (1.0 + mu * g.s1 / g.s2).powi(2) * (mu * 2.0 / g.s2 * (ap / al).sqrt() + c.alpha / (1.0 + g.s2)).powi(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    const C: AafConstants = AafConstants { k: 3.0, alpha: 1.0 };

    fn g(s1: f64, s2: f64, sigma: f64, d: f64) -> PixelGeometry {
        PixelGeometry { s1, s2, sigma, d }
    }

    /// Deterministic pseudo-random values in [lo, hi) on a log scale.
    fn log_uniform(i: u64, lo: f64, hi: f64) -> f64 {
        let u = (crate::render::sampler::mix64(i) >> 11) as f64 / (1u64 << 53) as f64;
        (lo.ln() + u * (hi.ln() - lo.ln())).exp()
    }

    #[test]
    fn eq21_equals_the_general_form_where_the_clamps_are_inactive() {
        let mut checked = 0;
        for i in 0..20_000u64 {
            let s2 = log_uniform(4 * i, 1e-3, 10.0);
            let s1 = s2 * log_uniform(4 * i + 1, 1.0, 100.0);
            let (sigma, d) = (log_uniform(4 * i + 2, 1e-3, 10.0), log_uniform(4 * i + 3, 1e-4, 1.0));
            let px = g(s1, s2, sigma, d);
            for mu in [1.0, 2.0, 4.0] {
                let b = bandlimits(&px, &C, mu);
                let inactive = mu / (sigma * s2) <= b.omega_x_max && s1 * b.omega_x_f <= b.omega_y_max;
                if !inactive {
                    continue;
                }
                checked += 1;
                let (a, e) = (sample_count(&px, &C, mu, 0.0), sample_count_eq21(&px, &C, mu));
                assert!((a - e).abs() <= 1e-9 * e, "{px:?} mu={mu}: {a} vs {e}");
            }
        }
        assert!(checked > 1000, "only {checked} cases had inactive clamps");
    }

    #[test]
    fn beta_is_inversely_proportional_to_mu() {
        for (i, px) in [g(2.0, 0.5, 0.3, 0.01), g(0.1, 0.0, 1.0, 0.002), g(50.0, 3.0, 1e-3, 1.0)].iter().enumerate() {
            let b1 = filter_width(px, &C, 1.0);
            for mu in [2.0, 4.0, 8.0, 3.0] {
                assert!((filter_width(px, &C, mu) * mu - b1).abs() <= 1e-12 * b1, "case {i} mu {mu}");
            }
            assert!(b1 > 0.0 && b1.is_finite());
        }
        // Eq. 13 by hand, k = 3, alpha = 1: beta = max(sigma s2, (1 + s2) d / alpha) / (k mu).
        // Light term: max(0.3 * 0.5, 1.5 * 0.01) / 3 = 0.05; pixel term (s2 = 0):
        // max(0, 0.002) / 3 = 6.667e-4.
        assert!((filter_width(&g(2.0, 0.5, 0.3, 0.01), &C, 1.0) - 0.05).abs() < 1e-15);
        assert!((filter_width(&g(2.0, 0.5, 0.3, 0.01), &C, 2.0) - 0.025).abs() < 1e-15);
        assert!((filter_width(&g(0.1, 0.0, 1.0, 0.002), &C, 1.0) - 0.002 / 3.0).abs() < 1e-15);
        // beta/d <= 0.3 px at large mu: neighbour weights fall below exp(-1/(2*0.09)).
        let px = g(2.0, 0.5, 0.3, 0.01);
        let mu = filter_width(&px, &C, 1.0) / px.d / 0.3;
        assert!(filter_width(&px, &C, mu) / px.d <= 0.3 + 1e-12);
    }

    #[test]
    fn n_is_non_decreasing_in_mu_and_roughly_quadratic_for_small_pixels() {
        for i in 0..2000u64 {
            let s2 = log_uniform(3 * i, 1e-4, 20.0);
            let px = g(s2 * log_uniform(3 * i + 1, 1.0, 1e3), s2, log_uniform(3 * i + 2, 1e-2, 1.0), 1e-3);
            let mut last = 0.0;
            for k in 0..8 {
                let n = sample_count(&px, &C, (1u32 << k) as f64, 9.0);
                assert!(n >= last && n.is_finite(), "{px:?} k={k}: {n} < {last}");
                last = n;
            }
        }
        // Where mu (2/s2) sqrt(A_p/A_l) << alpha/(1+s2) (here A_p << A_l and s2 = 0.5):
        // n(2 mu)/n(mu) in [1, 4] (methods.md §1.6).
        let px = g(3.0, 1.0, 0.5, 1e-4);
        for mu in [1.0, 2.0, 4.0] {
            let r = sample_count(&px, &C, 2.0 * mu, 0.0) / sample_count(&px, &C, mu, 0.0);
            assert!((1.0..=4.0 + 1e-9).contains(&r), "{r}");
        }
    }

    #[test]
    fn packing_a_is_tighter_than_packing_b_eq14() {
        for i in 0..5000u64 {
            let s2 = log_uniform(3 * i, 1e-3, 10.0);
            let px = g(s2 * log_uniform(3 * i + 1, 1.0, 100.0), s2, log_uniform(3 * i + 2, 1e-2, 1.0), 1e-2);
            let b = bandlimits(&px, &C, 1.0);
            let a = (b.omega_x_f + b.omega_x_max) * (b.omega_y_f + (px.s1 * b.omega_x_f).min(b.omega_y_max));
            let bb = (2.0 * b.omega_x_f) * (b.omega_y_f + px.s1 * b.omega_x_max);
            assert!(a <= bb * (1.0 + 1e-12), "{px:?}: {a} > {bb}");
        }
    }

    #[test]
    fn per_ray_slope_equals_the_light_plane_form() {
        // Receiver at depth d1 below the light plane, occluder at depth d2 below it; a ray
        // from the receiver to a light point at horizontal offset `h` has length
        // l = sqrt(d1^2 + h^2) and meets the occluder plane at t = l (d1 - d2)/d1.
        for (d1, d2, h) in [(5.0f64, 1.0f64, 0.0f64), (5.0, 4.9, 2.0), (1.0, 0.5, 10.0), (1e4, 1.0, 3.0)] {
            let l = (d1 * d1 + h * h).sqrt();
            let t = l * (d1 - d2) / d1;
            assert!((slope(t, l) - (d1 / d2 - 1.0)).abs() < 1e-9 * (d1 / d2), "{d1} {d2} {h}");
        }
        assert_eq!(slope(0.0, 1.0), 0.0);
        assert_eq!(slope(1.0, 1.0), f64::INFINITY);
    }

    #[test]
    fn extremes_stay_finite_and_bounded() {
        let n_min = 9.0;
        let cases = [
            g(1.0, 0.0, 0.5, 0.01),               // occluder touching the receiver
            g(f64::INFINITY, 1.0, 0.5, 0.01),     // occluder at the light
            g(f64::INFINITY, 0.0, 0.5, 0.01),     // both at once
            g(0.0, 0.0, 0.5, 0.01),               // s1 = s2 = 0
            g(2.0, 1.0, 0.0, 0.01),               // zero-size light: hard shadow
            g(2.0, 1.0, 1e-9, 0.01),              // tiny light
            g(2.0, 1.0, 1e4, 1e-3),               // huge light, tiny pixels
            g(2.0, 1.0, 1e-3 * 0.3, 1e-3 * 1e-3), // scene at 1e-3 units
            g(2.0, 1.0, 1e4 * 0.3, 1e4 * 1e-3),   // scene at 1e4 units
            g(1e12, 1e-12, 0.5, 1e-2),            // extreme slope ratio
        ];
        for px in cases {
            for mu in [1.0, 2.0, 8.0, 64.0] {
                let n = sample_count(&px, &C, mu, n_min);
                let b = filter_width(&px, &C, mu);
                assert!(n.is_finite() && n >= n_min, "{px:?} mu {mu}: n = {n}");
                assert!(b.is_finite() && b >= 0.0, "{px:?} mu {mu}: beta = {b}");
            }
        }
        // Zero-size light: the minimum count and no filter.
        let hard = g(2.0, 1.0, 0.0, 0.01);
        assert_eq!(sample_count(&hard, &C, 1.0, n_min), n_min);
        assert_eq!(filter_width(&hard, &C, 1.0), 0.0);
        // Scale invariance: the same configuration at 1e-3 and 1e4 units gives the same n and
        // the same beta in pixels.
        let (a, b) = (g(2.0, 1.0, 0.3e-3, 1e-6), g(2.0, 1.0, 0.3e4, 10.0));
        let (na, nb) = (sample_count(&a, &C, 2.0, 0.0), sample_count(&b, &C, 2.0, 0.0));
        assert!((na / nb - 1.0).abs() < 1e-9, "{na} vs {nb}");
        let (ba, bb) = (filter_width(&a, &C, 2.0) / a.d, filter_width(&b, &C, 2.0) / b.d);
        assert!((ba / bb - 1.0).abs() < 1e-9);
    }
}

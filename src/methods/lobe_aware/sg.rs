//! Spherical Gaussians (SGs), the lobe representation of Tokuyoshi 2015 (Sec. 4.1, App. C).
//!
//! `G(w, xi, lambda) = exp(lambda (w.xi - 1))` for unit vectors, which equals the Euclidean
//! Gaussian `g(w - xi, 1/lambda)` (methods.md, conventions). Everything runs in f64, and every
//! quantity that can overflow (sharpness from 1e-20 to 1e20) is formed in log space or as a
//! ratio, so no result is NaN or infinite for any finite input.
use glam::DVec3;

/// The diffuse lobe's SG fit, `q(phi) ~ G(n_i, n_j, lambda_c)` (Tokuyoshi 2015 supplemental,
/// App. D; a published constant, see methods.md §3.6).
pub const LAMBDA_C: f64 = 0.9426;

/// Below this product sharpness the closed forms switch to their series.
const SERIES_BELOW: f64 = 1e-4;

/// A spherical Gaussian lobe: unit axis and sharpness (>= 0). The amplitude is kept apart
/// (`Weighted`), since Eq. 12 needs none and Eq. 11 only the amplitudes' ratios.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sg {
    pub axis: DVec3,
    pub sharpness: f64,
}

/// An SG with an amplitude, one term of an SG mixture (Eq. 10, Eq. 11).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weighted {
    pub amplitude: f64,
    pub lobe: Sg,
}

impl Sg {
    pub fn new(axis: DVec3, sharpness: f64) -> Self {
        Sg { axis: axis.normalize_or_zero(), sharpness: sharpness.max(0.0) }
    }

    /// G(w) for a unit direction w.
    pub fn eval(&self, w: DVec3) -> f64 {
        (self.sharpness * (w.dot(self.axis) - 1.0)).exp()
    }

    /// The lobe smoothed by the SG kernel `b = G(w', w, kappa)` (Eq. 9), by Iwasaki's
    /// approximate product (Eq. 10): sharpness `lambda kappa / (lambda + kappa)`. Infinite
    /// kappa (one-bounce light) leaves the lobe as it is.
    pub fn smoothed(&self, kappa: f64) -> Sg {
        if kappa.is_infinite() {
            return *self;
        }
        let l = self.sharpness;
        // l kappa / (l + kappa) without overflow when l is huge: kappa / (1 + kappa / l).
        let s = if l == 0.0 { 0.0 } else { kappa / (1.0 + kappa / l) };
        Sg { axis: self.axis, sharpness: s }
    }

    /// ln of the integral of G over the sphere, `2 pi (1 - e^{-2 lambda}) / lambda`
    /// (methods.md §3.6), tending to 4 pi as lambda -> 0.
    pub fn ln_integral(&self) -> f64 {
        (2.0 * std::f64::consts::PI).ln() + ln_one_minus_exp_neg_2r_over_r(self.sharpness)
    }
}

/// ln((1 - e^{-2r}) / r): the series `ln 2 - r + r^2/6` near 0 (the shared implementation
/// notes print r^2/3, which a direct f64 evaluation refutes), `ln(-expm1(-2r)) - ln r` above.
fn ln_one_minus_exp_neg_2r_over_r(r: f64) -> f64 {
    if r < SERIES_BELOW {
        2f64.ln() - r + r * r / 6.0
    } else {
        (-(-2.0 * r).exp_m1()).ln() - r.ln()
    }
}

/// `r - l1 - l2` for `r = ||l1 xi1 + l2 xi2||`, cancellation-free (methods.md §3.3, after
/// VSGL): `2 l_min (c - 1) / (sqrt(1 + rho^2 + 2 rho c) + 1 + rho)`, rho = l_min / l_max.
fn r_minus_sum(l1: f64, l2: f64, c: f64) -> f64 {
    let (lo, hi) = if l1 <= l2 { (l1, l2) } else { (l2, l1) };
    if hi == 0.0 {
        return 0.0;
    }
    let rho = lo / hi;
    let c = c.clamp(-1.0, 1.0);
    2.0 * lo * (c - 1.0) / ((1.0 + rho * rho + 2.0 * rho * c).max(0.0).sqrt() + 1.0 + rho)
}

/// ln of the exact product integral of two SGs (Tsai and Shih 2006; supplemental App. C):
/// `4 pi sinh(r) / (r e^{l1 + l2})`, r = ||l1 xi1 + l2 xi2||, evaluated as
/// `ln 2 pi + (r - l1 - l2) + ln((1 - e^{-2r}) / r)`.
pub fn ln_product_integral(a: &Sg, b: &Sg) -> f64 {
    let (l1, l2) = (a.sharpness, b.sharpness);
    let c = a.axis.dot(b.axis);
    let d = r_minus_sum(l1, l2, c);
    // r itself from the same form, so that the two terms agree at every scale.
    let r = (l1 + l2 + d).max(0.0);
    (2.0 * std::f64::consts::PI).ln() + d + ln_one_minus_exp_neg_2r_over_r(r)
}

/// Iwasaki's approximate product integral (App. C, Eq. C.1):
/// `2 pi G(xi1, xi2, l1 l2 / (l1 + l2)) / (l1 + l2)`. Not used by the weights (Eq. 12 is its
/// normalised form); kept as the reference the tests compare Eq. 12 and C.1's error with.
pub fn product_integral_iwasaki(a: &Sg, b: &Sg) -> f64 {
    let v = a.sharpness + b.sharpness;
    let u = a.sharpness * b.sharpness;
    2.0 * std::f64::consts::PI * ((u / v) * (a.axis.dot(b.axis) - 1.0)).exp() / v
}

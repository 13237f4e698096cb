//! The cross-bilateral weights of Tokuyoshi 2015: the lobe-aware directional weight (Eq. 12,
//! and Eq. 11 for SG mixtures), the normal-aware baseline (Eq. 4) and the depth weight (Eq. 3).
//! Every weight is finite and in [0, 1], is 1 for a pixel with itself, and is symmetric.
use super::sg::{ln_product_integral, Sg, Weighted};
use glam::DVec3;

/// Eq. 12, the single-SG lobe-aware weight of two smoothed lobes (sharpness `lambda_bar`):
/// `(2 sqrt(l_i l_j) / (l_i + l_j))^beta G(xi_i, xi_j, beta l_i l_j / (l_i + l_j))`, in the
/// supplemental's App. E form `exp((beta/2) ln(4u / v^2) + (beta u / v)(xi_i.xi_j - 1))`, with
/// the first term as `-(beta/2) ln((2 + rho + 1/rho) / 4)`, rho = min/max, so that sharpness from
/// 1e-20 to 1e20 neither overflows nor underflows (methods.md §3.3). `1 - xi_i.xi_j` is not
/// clamped to [0, 1]: opposite axes are less alike than perpendicular ones.
pub fn lobe_weight(a: &Sg, b: &Sg, beta: f64) -> f64 {
    ln_lobe_weight(a, b, beta).exp().clamp(0.0, 1.0)
}

/// ln of `lobe_weight` (at most 0; minus infinity for a weight of 0), so that a gather can add
/// it to the other weights' logarithms and take one exponential per neighbour.
pub fn ln_lobe_weight(a: &Sg, b: &Sg, beta: f64) -> f64 {
    let (lo, hi) = if a.sharpness <= b.sharpness { (a.sharpness, b.sharpness) } else { (b.sharpness, a.sharpness) };
    if hi == 0.0 {
        // Two uniform lobes are the same distribution.
        return 0.0;
    }
    let rho = lo / hi;
    if rho == 0.0 {
        // A uniform lobe against a sharp one: the first factor is 0.
        return f64::NEG_INFINITY;
    }
    // ln(4 rho / (1 + rho)^2) with one logarithm, and none for lobes of equal sharpness (every
    // pair of diffuse pixels), whose term is exactly 0; a gather evaluates this per neighbour.
    // A subnormal rho makes 1/rho infinite and the term minus infinity, its limit.
    let sharpness_term = if rho == 1.0 { 0.0 } else { -(0.25 * (2.0 + rho + 1.0 / rho)).ln() };
    // u / v = lo hi / (lo + hi) = lo / (1 + rho).
    let u_over_v = lo / (1.0 + rho);
    let c = a.axis.dot(b.axis).clamp(-1.0, 1.0);
    (0.5 * beta * sharpness_term.min(0.0) + beta * u_over_v * (c - 1.0)).min(0.0)
}

/// Eq. 11, the lobe-aware weight of two SG mixtures (smoothed lobes with their amplitudes):
/// `(alpha_ij / sqrt(alpha_ii alpha_jj))^beta` with `alpha_ij` the sum over lobe pairs of the
/// amplitudes times the exact SG product integral. Evaluated in log space (log-sum-exp over
/// the pairs; the product integral from `ln_product_integral`); `ln q` is clamped to at most 0
/// (Cauchy-Schwarz), so rounding never yields a weight above 1. Terms of zero amplitude drop
/// out; a mixture with no positive term is dissimilar to everything but itself.
pub fn mixture_weight(a: &[Weighted], b: &[Weighted], beta: f64) -> f64 {
    let (ab, aa, bb) = (ln_alpha(a, b), ln_alpha(a, a), ln_alpha(b, b));
    if !aa.is_finite() || !bb.is_finite() {
        return if a == b { 1.0 } else { 0.0 };
    }
    let ln_q = (ab - 0.5 * (aa + bb)).min(0.0);
    (beta * ln_q).exp().clamp(0.0, 1.0)
}

/// ln alpha_ij of Eq. 11 (without its constant factor, which cancels).
fn ln_alpha(a: &[Weighted], b: &[Weighted]) -> f64 {
    let terms: Vec<f64> = a
        .iter()
        .filter(|x| x.amplitude > 0.0)
        .flat_map(|x| {
            b.iter()
                .filter(|y| y.amplitude > 0.0)
                .map(move |y| x.amplitude.ln() + y.amplitude.ln() + ln_product_integral(&x.lobe, &y.lobe))
        })
        .collect();
    let max = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return f64::NEG_INFINITY;
    }
    max + terms.iter().map(|t| (t - max).exp()).sum::<f64>().ln()
}

/// Eq. 4, the normal-aware baseline: `g(n_i - n_j, sigma_n^2) = exp((n_i.n_j - 1) / sigma_n^2)`.
pub fn normal_weight(ni: DVec3, nj: DVec3, sigma_n2: f64) -> f64 {
    ln_normal_weight(ni, nj, sigma_n2).exp()
}

/// ln of `normal_weight`.
pub fn ln_normal_weight(ni: DVec3, nj: DVec3, sigma_n2: f64) -> f64 {
    let c = ni.dot(nj).clamp(-1.0, 1.0);
    (c - 1.0) / sigma_n2.max(f64::MIN_POSITIVE)
}

/// Eq. 3, the depth weight `g(z_i - z_j, sigma_z^2)`.
pub fn depth_weight(zi: f64, zj: f64, sigma_z2: f64) -> f64 {
    ln_depth_weight(zi, zj, sigma_z2).exp()
}

/// ln of `depth_weight`.
pub fn ln_depth_weight(zi: f64, zj: f64, sigma_z2: f64) -> f64 {
    let d = zi - zj;
    if d == 0.0 {
        return 0.0;
    }
    -(d * d) / (2.0 * sigma_z2.max(f64::MIN_POSITIVE))
}

/// The diffuse-lobe similarity of App. D at kappa = inf, exact:
/// `q(phi) = (sin phi + (pi - phi) cos phi) / pi`, phi the angle between the normals.
pub fn diffuse_similarity(ni: DVec3, nj: DVec3) -> f64 {
    let phi = ni.dot(nj).clamp(-1.0, 1.0).acos();
    (phi.sin() + (std::f64::consts::PI - phi) * phi.cos()) / std::f64::consts::PI
}

/// App. D's normal-aware variance that the lobe-aware weight of two diffuse lobes equals:
/// `sigma_n^2 = (2 lambda_c + kappa) / (beta lambda_c kappa)`.
pub fn diffuse_sigma_n2(beta: f64, kappa: f64) -> f64 {
    let lc = super::sg::LAMBDA_C;
    if kappa.is_infinite() {
        return 1.0 / (beta * lc);
    }
    (2.0 * lc + kappa) / (beta * lc * kappa)
}

/// The distribution-aware weight of two Gaussians in R^m (supplemental App. A): pixel i's
/// feature `x_i` with its own variance `tau_i^2`, smoothed by `nu^2`;
/// `q = (2 tb_i tb_j / (tb_i^2 + tb_j^2))^{m/2} g(x_i - x_j, tb_i^2 + tb_j^2)` with
/// `tb^2 = tau^2 + nu^2`, and `w = q^beta`. Eq. 2's cross-bilateral weight is its case
/// `tau_i = tau_j`.
pub fn gaussian_weight(xi: &[f64], xj: &[f64], tau2: (f64, f64), nu2: f64, beta: f64) -> f64 {
    let (ti, tj) = (tau2.0 + nu2, tau2.1 + nu2);
    let m = xi.len() as f64;
    let d2: f64 = xi.iter().zip(xj).map(|(a, b)| (a - b) * (a - b)).sum();
    let ln_q = 0.5 * m * (2.0 * (ti * tj).sqrt() / (ti + tj)).ln() - d2 / (2.0 * (ti + tj));
    (beta * ln_q.min(0.0)).exp()
}

//! Anisotropic spherical Gaussians (Xu et al. 2013), the optional lobes of Tokuyoshi 2015's
//! Eq. 13 (Sec. 4.2; supplemental, "Anisotropic spherical Gaussians"): a glossy pixel's
//! reflection lobe seen at an angle is stretched in the plane of incidence, which one SG, being
//! isotropic, averages away (App. B's `4 n.psi` is the geometric mean of the two stretches).
//!
//! Conventions (methods.md §3.3): an ASG is `max(w.z, 0) exp(-lx (w.x)^2 - ly (w.y)^2)` with
//! x, y, z orthonormal, and its sharpness is half an SG's (`G(w, z, l) ~ exp(-l theta^2 / 2)`,
//! the ASG `~ exp(-lx theta^2)`). Everything runs in f64; the product of two ASGs needs the
//! eigenvectors of a 3x3 symmetric matrix, which a cyclic Jacobi solver gives (the paper's
//! Cardano formula in f32 bands, its Fig. 19). The per-pixel ASG lobe is `lobe::specular_asg`.
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// An ASG: orthonormal frame (z the lobe's axis) and the sharpness along x and y (>= 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Asg {
    pub x: DVec3,
    pub y: DVec3,
    pub z: DVec3,
    pub lx: f64,
    pub ly: f64,
}

impl Asg {
    /// The ASG about `z` with `x` projected to be orthogonal to it.
    pub fn new(z: DVec3, x: DVec3, lx: f64, ly: f64) -> Asg {
        let z = z.normalize_or(DVec3::Z);
        let x = (x - z * x.dot(z)).try_normalize().unwrap_or_else(|| z.any_orthonormal_vector());
        Asg { x, y: z.cross(x), z, lx: lx.max(0.0), ly: ly.max(0.0) }
    }

    /// The lobe's value in the unit direction `w`.
    pub fn eval(&self, w: DVec3) -> f64 {
        let (a, b) = (w.dot(self.x), w.dot(self.y));
        w.dot(self.z).max(0.0) * (-self.lx * a * a - self.ly * b * b).exp()
    }

    /// The lobe smoothed by the SG kernel `G(w', w, kappa)` (Eq. 9) with Xu's ASG x SG product
    /// (Sec. 4.2): sharpness `l kappa / (2 l + kappa)` along each axis. Infinite kappa (one
    /// bounce) leaves it as it is.
    pub fn smoothed(&self, kappa: f64) -> Asg {
        if kappa.is_infinite() {
            return *self;
        }
        // l kappa / (2 l + kappa) without overflow when l is huge.
        let s = |l: f64| if l == 0.0 { 0.0 } else { kappa / (2.0 + kappa / l) };
        Asg { lx: s(self.lx), ly: s(self.ly), ..*self }
    }

    /// `A` of the algebraic form `max(w.z, 0) exp(-w^T A w)`: `lx x x^T + ly y y^T`.
    fn matrix(&self) -> DMat3 {
        outer(self.x) * self.lx + outer(self.y) * self.ly
    }
}

fn outer(v: DVec3) -> DMat3 {
    DMat3::from_cols(v * v.x, v * v.y, v * v.z)
}

/// ln of the integral of an ASG of sharpness `lx`, `ly` over the sphere,
/// `B = (1/2) integral_0^{2 pi} (1 - e^{-a(phi)}) / a(phi) dphi` with
/// `a = lx cos^2 phi + ly sin^2 phi` (methods.md §3.3; the supplemental's closed form is not
/// reliable in our copy). Where the smaller sharpness is large, `e^{-a}` is below f64's
/// resolution and B is `pi / sqrt(lx ly)`; otherwise the periodic trapezoid rule, which
/// converges exponentially, on enough points to resolve the integrand's peak.
pub fn ln_integral(lx: f64, ly: f64) -> f64 {
    let (hi, lo) = if lx >= ly { (lx, ly) } else { (ly, lx) };
    if lo > CLOSED_FORM_ABOVE {
        return PI.ln() - 0.5 * (hi.ln() + lo.ln());
    }
    // The integrand's peak at phi = pi/2 is about 1/sqrt(hi) wide (sqrt(lo/hi) once lo > 1).
    let points = (32.0 + 8.0 * (hi / lo.max(1.0)).sqrt()).min(MAX_POINTS as f64) as usize;
    // Symmetric in phi -> -phi and phi -> pi - phi: a quarter period, with half-weight ends.
    let h = 0.5 * PI / points as f64;
    let term = |phi: f64| {
        let (s, c) = phi.sin_cos();
        let a = hi * c * c + lo * s * s;
        if a < 1e-8 {
            1.0 - 0.5 * a
        } else {
            -(-a).exp_m1() / a
        }
    };
    let inner: f64 = (1..points).map(|k| term(k as f64 * h)).sum();
    let quarter = h * (0.5 * term(0.0) + inner + 0.5 * term(0.5 * PI));
    // B = (1/2) (4 quarter).
    (2.0 * quarter).ln()
}

/// Above this smaller sharpness `ln_integral` is the closed form (`e^{-40}` ~ 4e-18).
const CLOSED_FORM_ABOVE: f64 = 40.0;
/// At most this many quadrature points per quarter period (extreme anisotropy).
const MAX_POINTS: usize = 2048;

/// The eigenvalues of a symmetric 3x3 matrix, largest first, with their unit eigenvectors
/// (cyclic Jacobi rotations in f64; converges in a few sweeps).
pub fn symmetric_eigen(m: DMat3) -> ([f64; 3], [DVec3; 3]) {
    let mut a = m.to_cols_array_2d();
    let mut v = DMat3::IDENTITY.to_cols_array_2d();
    for _sweep in 0..32 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let scale = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= 1e-30 * scale || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            // The rotation that zeroes a[p][q] (Golub and Van Loan, Alg. 8.4.1).
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
            a[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    // Columns of `v` (stored as rows here: v[k][i] is component k of eigenvector i).
    let vec = |i: usize| DVec3::new(v[0][i], v[1][i], v[2][i]).normalize_or_zero();
    let mut pairs = [(a[0][0], vec(0)), (a[1][1], vec(1)), (a[2][2], vec(2))];
    pairs.sort_by(|p, q| q.0.total_cmp(&p.0));
    (pairs.map(|p| p.0), pairs.map(|p| p.1))
}

/// ln of Xu's approximate product integral of two ASGs (supplemental): with `A3 = A1 + A2`
/// eigen-decomposed as `l'x >= l'y >= l'z` and `e_z` the eigenvector of the smallest, turned
/// towards `z1 + z2`, the integral is `C exp(-l'z) B(l'x - l'z, l'y - l'z)` with
/// `C = max(e_z.z1, 0) max(e_z.z2, 0)`. None where the approximation has no answer: the two
/// smallest eigenvalues so close that `e_z` is not defined (e.g. two round lobes at a right
/// angle, or the paper's failure case of opposite axes with `lx = ly`), or `C = 0`.
pub fn ln_product_integral(a: &Asg, b: &Asg) -> Option<f64> {
    let (l, e) = symmetric_eigen(a.matrix() + b.matrix());
    let gap = l[1] - l[2];
    if !(gap > 1e-9 * l[0].max(1.0)) {
        return None;
    }
    let towards = a.z + b.z;
    let ez = if e[2].dot(towards) < 0.0 { -e[2] } else { e[2] };
    let c = ez.dot(a.z).max(0.0) * ez.dot(b.z).max(0.0);
    if c <= 0.0 {
        return None;
    }
    Some(c.ln() - l[2].max(0.0) + ln_integral(l[0] - l[2], gap))
}

/// Below this sharpness (along its flatter axis) a lobe is low-frequency, where the paper
/// finds the ASG product unreliable (its Fig. 20); such pairs get Eq. 12.
pub const MIN_SHARPNESS: f64 = 2.0;

/// ln of Eq. 13 for single lobes: `beta (ln gamma_ij - (ln gamma_ii + ln gamma_jj) / 2)`
/// with `gamma` the ASG product integral of the smoothed lobes (amplitudes cancel), clamped to
/// at most 0 (the approximation need not keep Cauchy-Schwarz). None where Eq. 13 does not
/// apply (a low-frequency lobe, or `ln_product_integral` without an answer): the caller falls
/// back to Eq. 12, as the paper recommends ASGs only for higher-frequency lobes.
pub fn ln_weight(a: &Asg, b: &Asg, beta: f64) -> Option<f64> {
    AsgLobe::new(*a)?.ln_weight(&AsgLobe::new(*b)?, beta)
}

/// A high-frequency lobe ready for Eq. 13: the ASG and ln of its product integral with itself
/// (Eq. 7's normalisation, computed once per pixel rather than once per pair).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AsgLobe {
    pub lobe: Asg,
    ln_self: f64,
}

impl AsgLobe {
    /// None for a low-frequency lobe (flatter sharpness below `MIN_SHARPNESS`), which Eq. 12
    /// compares instead.
    pub fn new(lobe: Asg) -> Option<AsgLobe> {
        if lobe.lx.min(lobe.ly) < MIN_SHARPNESS {
            return None;
        }
        Some(AsgLobe { lobe, ln_self: ln_product_integral(&lobe, &lobe)? })
    }

    /// ln of Eq. 13 against `other` (see `ln_weight`).
    pub fn ln_weight(&self, other: &AsgLobe, beta: f64) -> Option<f64> {
        let ab = ln_product_integral(&self.lobe, &other.lobe)?;
        let ln_w = beta * (ab - 0.5 * (self.ln_self + other.ln_self)).min(0.0);
        (!ln_w.is_nan()).then_some(ln_w)
    }
}

#[cfg(test)]
#[path = "asg_tests.rs"]
mod tests;

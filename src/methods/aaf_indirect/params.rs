//! The per-pixel formulas of AAF for indirect light (Mehta, Wang, Ramamoorthi, Durand 2013):
//! transfer bandlimits (Eq. 18, Appendix Eqs. 24 and 26), filter width (Eqs. 15-16), sample
//! count (Eqs. 19-21) and the importance-sampling factor gamma (Sec. 4.3). All in f64; every
//! function is finite and non-negative over its whole domain (the property tests check it).
use crate::render::material::GlossyModel;

/// The paper's constants (Sec. 4-5).
#[derive(Clone, Debug, PartialEq)]
pub struct IndirectConstants {
    /// Omega_x^max = alpha / d: the spatial bandlimit that always applies (Eq. 15; 0.3).
    pub alpha: f64,
    /// Omega_h of a Lambertian receiver, 3-D (Eq. 18: 2.8, 95% of the transfer energy).
    pub omega_h_diffuse: f64,
    /// gamma of the cosine lobe (Sec. 4.3: 0.4).
    pub gamma_diffuse: f64,
    /// Fewest samples per pixel and component: the initial rays (Sec. 5: 16).
    pub min_samples: f64,
    /// Most samples per pixel and component at mu = 1 (Sec. 5: 100, scaled by mu).
    pub max_samples: f64,
    /// z_min is at least this fraction of the scene's largest dimension (Sec. 5: 2%).
    pub z_min_fraction: f64,
}

impl Default for IndirectConstants {
    fn default() -> Self {
        IndirectConstants {
            alpha: 0.3,
            omega_h_diffuse: 2.8,
            gamma_diffuse: 0.4,
            min_samples: 16.0,
            max_samples: 100.0,
            z_min_fraction: 0.02,
        }
    }
}

/// Transfer bandlimit Omega_h of the glossy lobe with exponent `m` (Eq. 24 Blinn-Phong,
/// Eq. 26 Phong). The linear fits hold for 4 < m < 50; below, the lobe is at least as wide as
/// the cosine, so the diffuse value bounds it from below; above, the fit is extrapolated (a
/// sharper lobe keeps a higher bandlimit: narrower filter, more samples, never overblur).
pub fn omega_h_glossy(model: GlossyModel, m: f64, c: &IndirectConstants) -> f64 {
    let m = if m.is_finite() { m.max(0.0) } else { 0.0 };
    let fit = match model {
        GlossyModel::BlinnPhong => 3.6 + 0.084 * m,
        GlossyModel::Phong => 4.27 + 0.15 * m,
    };
    fit.max(c.omega_h_diffuse)
}

/// gamma of a glossy lobe (Sec. 4.3): about 80% of cos^m's energy lies within
/// acos(c^(1/m)) of its axis, c = cos(pi/4); gamma is that angle over pi/2. Tends to 1 as
/// m -> 0 and to 0 as m grows.
pub fn gamma_glossy(m: f64) -> f64 {
    if !(m > 0.0) {
        return 1.0;
    }
    let c = std::f64::consts::FRAC_1_SQRT_2;
    (c.powf(1.0 / m).clamp(-1.0, 1.0).acos() / std::f64::consts::FRAC_PI_2).clamp(0.0, 1.0)
}

/// What the formulas need of one pixel and component.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reflectors {
    /// Nearest and farthest reflector hit by the initial rays (world units), z_min already
    /// clamped from below.
    pub z_min: f64,
    pub z_max: f64,
    /// Transfer bandlimit of the receiver's lobe.
    pub omega_h: f64,
    /// Projected pixel size d (world units).
    pub d: f64,
}

/// Reconstruction bandlimit Omega_r_x = mu min(Omega_h / z_min, alpha / d) (Eq. 15).
pub fn omega_r(r: &Reflectors, c: &IndirectConstants, mu: f64) -> f64 {
    let geometric = if r.z_min > 0.0 { r.omega_h / r.z_min } else { f64::INFINITY };
    let pixel = if r.d > 0.0 { c.alpha / r.d } else { f64::INFINITY };
    let w = mu * geometric.min(pixel);
    if w.is_finite() {
        w
    } else {
        0.0
    }
}

/// Filter standard deviation in world units, beta = 2 / Omega_r_x (Eq. 16); 0 (no filter)
/// where Omega_r_x is undefined.
pub fn filter_width(r: &Reflectors, c: &IndirectConstants, mu: f64) -> f64 {
    let w = omega_r(r, c, mu);
    if w > 0.0 {
        2.0 / w
    } else {
        0.0
    }
}

/// Samples per pixel n(mu) in the general form gamma (Omega*_x d)^2 (Omega*_v)^2 with the
/// minimum rates of Eq. 19 and Omega_r_x from Eq. 15 (clamped or not), so it holds on both
/// sides of the clamp; equals Eq. 21 where Omega_h / z_min < alpha / d. Unclamped to the
/// [16, 100 mu] range (`clamp_samples` does that).
pub fn sample_count(r: &Reflectors, c: &IndirectConstants, mu: f64, gamma: f64) -> f64 {
    let wr = omega_r(r, c, mu);
    let wx_d = wr * r.d + c.alpha;
    let wv = r.omega_h + r.z_max * wr;
    let n = gamma * (wx_d * wx_d) * (wv * wv);
    if n.is_finite() {
        n.max(0.0)
    } else {
        f64::MAX
    }
}

/// The paper's clamps on n (Sec. 5): at least the initial samples, at most 100 mu; the upper
/// one never goes below the lower one.
pub fn clamp_samples(n: f64, c: &IndirectConstants, mu: f64) -> f64 {
    let hi = (c.max_samples * mu).max(c.min_samples);
    if n.is_nan() {
        return c.min_samples;
    }
    n.clamp(c.min_samples, hi)
}

/// Eq. 21 as printed, for tests of the general form.
#[cfg(test)]
pub fn eq21(r: &Reflectors, c: &IndirectConstants, mu: f64, gamma: f64) -> f64 {
    let a = mu * r.omega_h * r.d / r.z_min + c.alpha;
    let b = 1.0 + mu * r.z_max / r.z_min;
    gamma * a * a * r.omega_h * r.omega_h * b * b
}

#[cfg(test)]
mod tests;

//! The angular bandwidth of a BRDF, precomputed per incident direction (Bagher et al. 2012,
//! Sec. 2.4): for each incident elevation, the BRDF's slice over the outgoing hemisphere is
//! rendered into an image, its wavelet bandwidth taken at every texel, and the result reduced
//! by maximum to a 16 x 16 table over outgoing elevation and azimuth (the paper's layout). The
//! BRDFs are isotropic, so the incident azimuth is taken as 0 and the outgoing one is relative
//! to it.
//!
//! The slices are `SLICE_ROWS` x 4 `SLICE_ROWS` texels over the hemisphere (1.4 degrees
//! each): the largest bandwidth a slice resolves is 2 pi over that texel, 256 per radian.
//! Lobes narrower than a texel get their analytic band at the mirror direction (`new`).
use super::illumination::{angular, WaveletOptions};
use super::vector::QUANTILE_95;
use crate::render::frame_basis::to_world;
use crate::render::material::{Brdf, GlossyModel};
use glam::Vec3;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

/// Bins of incident elevation, outgoing elevation and outgoing azimuth (the paper's 16).
pub const BINS: usize = 16;
/// Rows of a slice over outgoing elevation (columns: four times as many, over azimuth).
pub const SLICE_ROWS: usize = 64;

#[derive(Clone, Debug, PartialEq)]
pub struct BrdfBandwidth {
    /// [incident bin][outgoing elevation bin][outgoing azimuth bin], radians^-1.
    table: Vec<f32>,
}

fn bin(x: f64, range: f64) -> usize {
    ((x / range * BINS as f64) as usize).min(BINS - 1)
}

impl BrdfBandwidth {
    pub fn new(brdf: &Brdf, opts: &WaveletOptions) -> Self {
        // One incident bin per task: a bin's slice and wavelets are independent of the others'.
        let bins: Vec<Vec<f32>> = (0..BINS).into_par_iter().map(|i| Self::incident_bin(brdf, opts, i)).collect();
        let mut table = bins.concat();
        // A lobe narrower than a slice's texel falls between the texel centres and reads as
        // flat. Its own band, from the Gaussian it approximates (cos^m a ~ exp(-m a^2 / 2),
        // deviation 1 / sqrt(m); twice as wide in wo for Blinn-Phong, whose lobe is in the
        // half vector), is a floor in the bin of the mirror direction. A departure: the paper
        // measured lobes of acquired BRDFs, all wider than its slices' texels.
        if brdf.ks != Vec3::ZERO && brdf.exponent > 0.0 {
            let deviation = match brdf.model {
                GlossyModel::Phong => 1.0 / (brdf.exponent as f64).sqrt(),
                GlossyModel::BlinnPhong => 2.0 / (brdf.exponent as f64).sqrt(),
            };
            let lobe = QUANTILE_95 / deviation;
            for i in 0..BINS {
                let theta_i = (i as f64 + 0.5) / BINS as f64 * FRAC_PI_2;
                let at = (i * BINS + bin(theta_i, FRAC_PI_2)) * BINS + bin(PI, 2.0 * PI);
                table[at] = table[at].max(lobe as f32);
            }
        }
        BrdfBandwidth { table }
    }

    /// The table's entries for incident bin `i`: outgoing elevation x azimuth bins.
    fn incident_bin(brdf: &Brdf, opts: &WaveletOptions, i: usize) -> Vec<f32> {
        let (rows, cols) = (SLICE_ROWS, 4 * SLICE_ROWS);
        let mut table = vec![0.0f32; BINS * BINS];
        let theta_i = (i as f64 + 0.5) / BINS as f64 * FRAC_PI_2;
        let wi = Vec3::new(theta_i.sin() as f32, 0.0, theta_i.cos() as f32);
        let mut slice = vec![0.0f64; rows * cols];
        for r in 0..rows {
            let theta = (r as f64 + 0.5) / rows as f64 * FRAC_PI_2;
            for c in 0..cols {
                let phi = (c as f64 + 0.5) / cols as f64 * 2.0 * PI;
                let wo =
                    Vec3::new((theta.sin() * phi.cos()) as f32, (theta.sin() * phi.sin()) as f32, theta.cos() as f32);
                let f = brdf.eval(wo, wi, Vec3::Z);
                slice[r * cols + c] = (0.2126 * f.x + 0.7152 * f.y + 0.0722 * f.z) as f64;
            }
        }
        let exponents = opts.exponents(&slice, cols, rows);
        for r in 0..rows {
            let theta = (r as f64 + 0.5) / rows as f64 * FRAC_PI_2;
            // The texel's larger angular size: along the meridian or the parallel.
            let size = (FRAC_PI_2 / rows as f64).max(2.0 * PI * theta.sin() / cols as f64);
            for c in 0..cols {
                let phi = (c as f64 + 0.5) / cols as f64 * 2.0 * PI;
                let at = bin(theta, FRAC_PI_2) * BINS + bin(phi, 2.0 * PI);
                let nu = angular(exponents[r * cols + c], size) as f32;
                table[at] = table[at].max(nu);
            }
        }
        table
    }

    /// The angular bandwidth for unit `wi` and `wo` about unit normal `n` (radians^-1); 0
    /// below the surface.
    pub fn at(&self, wi: Vec3, wo: Vec3, n: Vec3) -> f64 {
        let (ci, co) = (n.dot(wi) as f64, n.dot(wo) as f64);
        if ci <= 0.0 || co <= 0.0 {
            return 0.0;
        }
        // Azimuth of wo relative to wi's, in the tangent plane.
        let (ti, to) = ((wi - n * ci as f32).normalize_or_zero(), (wo - n * co as f32).normalize_or_zero());
        let phi = if ti == Vec3::ZERO || to == Vec3::ZERO {
            0.0
        } else {
            let (c, s) = (ti.dot(to) as f64, n.dot(ti.cross(to)) as f64);
            s.atan2(c).rem_euclid(2.0 * PI)
        };
        let (i, o) = (bin(ci.clamp(0.0, 1.0).acos(), FRAC_PI_2), bin(co.clamp(0.0, 1.0).acos(), FRAC_PI_2));
        self.table[(i * BINS + o) * BINS + bin(phi, 2.0 * PI)] as f64
    }
}

/// An outgoing direction at elevation `theta` and azimuth `phi` about `n` (tests and tools).
pub fn direction(n: Vec3, theta: f64, phi: f64) -> Vec3 {
    to_world(n, Vec3::new((theta.sin() * phi.cos()) as f32, (theta.sin() * phi.sin()) as f32, theta.cos() as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn phong(m: f32) -> Brdf {
        Brdf { kd: Vec3::splat(0.05), ks: Vec3::splat(0.6), exponent: m, model: GlossyModel::Phong }
    }

    #[test]
    fn a_lambertian_brdf_has_no_bandwidth() {
        let b = BrdfBandwidth::new(&Brdf { kd: Vec3::splat(0.8), ..Brdf::BLACK }, &WaveletOptions::default());
        assert!(b.table.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn sharper_lobes_have_more_bandwidth_at_the_mirror_direction() {
        let opts = WaveletOptions::default();
        let wi = direction(Vec3::Z, 0.6, 0.0);
        let mirror = Vec3::new(-wi.x, -wi.y, wi.z);
        let mut last = 0.0;
        for m in [10.0, 100.0, 1000.0] {
            let nu = BrdfBandwidth::new(&phong(m), &opts).at(wi, mirror, Vec3::Z);
            // A cos^m lobe is about a Gaussian of width 1 / sqrt(m): its 95% band is
            // 1.64 sqrt(m); the wavelet estimate is conservative, so at least that, and it
            // rises with m.
            assert!(nu >= 1.64 * (m as f64).sqrt() && nu > last, "m = {m}: {nu} after {last}");
            last = nu;
        }
        // Far from the lobe a sharp BRDF is flat (its diffuse part): far less bandwidth.
        let b = BrdfBandwidth::new(&phong(1000.0), &opts);
        let away = direction(Vec3::Z, 0.3, 2.0);
        assert!(b.at(wi, away, Vec3::Z) <= 0.25 * b.at(wi, mirror, Vec3::Z));
    }

    #[test]
    fn lookups_below_the_surface_or_at_extremes_stay_finite() {
        let b = BrdfBandwidth::new(&phong(1e6), &WaveletOptions::default());
        assert_eq!(b.at(Vec3::NEG_Z, Vec3::Z, Vec3::Z), 0.0);
        for (wi, wo) in [(Vec3::Z, Vec3::Z), (Vec3::new(1.0, 0.0, 1e-6).normalize(), Vec3::Z)] {
            let nu = b.at(wi, wo, Vec3::Z);
            assert!(nu.is_finite() && nu >= 0.0);
        }
        // A lobe far narrower than the slices' texels keeps its own band at the mirror
        // direction: 1.64 sqrt(m).
        let wi = direction(Vec3::Z, 0.6, 0.0);
        let nu = b.at(wi, Vec3::new(-wi.x, -wi.y, wi.z), Vec3::Z);
        assert!((nu / (QUANTILE_95 * 1000.0) - 1.0).abs() < 1e-6, "{nu}");
    }
}

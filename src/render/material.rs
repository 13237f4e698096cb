//! Materials and their BRDFs: Lambertian and energy-normalised (Blinn-)Phong.
use super::frame_basis::{cosine_hemisphere, power_cosine, power_cosine_pdf, to_world};
use super::texture::{ColorTexture, ScalarTexture};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GlossyModel {
    BlinnPhong,
    Phong,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    Lambertian {
        albedo: ColorTexture,
    },
    Glossy {
        diffuse: ColorTexture,
        specular: ColorTexture,
        exponent: ScalarTexture,
        model: GlossyModel,
    },
    /// The surface of an area light: emits (see `Light`), reflects nothing.
    Emitter {
        light: u32,
    },
}

impl Material {
    /// Whether shading reads surface coordinates (some texture varies over the surface); when
    /// not, meshes using the material need no uv table.
    pub fn uses_uv(&self) -> bool {
        use super::texture::Texture::Checker;
        match self {
            Material::Lambertian { albedo } => matches!(albedo, Checker { .. }),
            Material::Glossy { diffuse, specular, exponent, .. } => {
                matches!(diffuse, Checker { .. })
                    || matches!(specular, Checker { .. })
                    || matches!(exponent, Checker { .. })
            }
            Material::Emitter { .. } => false,
        }
    }

    /// Whether the material has a glossy lobe somewhere: a `Glossy` whose specular colour is not
    /// black everywhere.
    pub fn has_lobe(&self) -> bool {
        match self {
            Material::Glossy { specular, .. } => specular.values().iter().any(|v| *v != Vec3::ZERO),
            _ => false,
        }
    }

    /// The BRDF at surface coordinates `uv`.
    pub fn brdf(&self, uv: Vec2) -> Brdf {
        match self {
            Material::Lambertian { albedo } => {
                Brdf { kd: albedo.eval(uv), ks: Vec3::ZERO, exponent: 0.0, model: GlossyModel::Phong }
            }
            Material::Glossy { diffuse, specular, exponent, model } => {
                Brdf { kd: diffuse.eval(uv), ks: specular.eval(uv), exponent: exponent.eval(uv), model: *model }
            }
            Material::Emitter { .. } => Brdf::BLACK,
        }
    }
}

/// A BRDF at one point: f = kd/pi + ks * lobe. The lobes are normalised so that kd + ks <= 1
/// conserves energy: Phong `(m+2)/(2 pi) cos^m(alpha)` with alpha the angle between wi and the
/// mirror direction of wo (Lafortune and Willems 1994); Blinn-Phong
/// `(m+1)/(8 pi) cos^m(theta_h) / ((wo.h) max(cos_i, cos_o))`, the isotropic specular lobe of
/// Ashikhmin and Shirley 2000 without Fresnel: reciprocal, and f cos_i / pdf = cos_i /
/// max(cos_i, cos_o) <= 1 under half-vector sampling, so its albedo never exceeds ks. (The AAF
/// indirect paper's Eq. 13 leaves the normalisation out; its bandlimit fit, Eq. 24, comes from
/// the cos^m(theta_h) factor, which this keeps.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Brdf {
    pub kd: Vec3,
    pub ks: Vec3,
    pub exponent: f32,
    pub model: GlossyModel,
}

/// A sampled incident direction with the BRDF value and the density it was drawn with.
#[derive(Clone, Copy, Debug)]
pub struct BrdfSample {
    pub wi: Vec3,
    pub f: Vec3,
    pub pdf: f32,
}

/// Rec. 709 luminance of a linear RGB colour.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

#[inline]
fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    2.0 * w.dot(n) * n - w
}

impl Brdf {
    pub const BLACK: Brdf = Brdf { kd: Vec3::ZERO, ks: Vec3::ZERO, exponent: 0.0, model: GlossyModel::Phong };

    pub fn is_black(&self) -> bool {
        self.kd == Vec3::ZERO && self.ks == Vec3::ZERO
    }

    /// Probability of sampling the glossy lobe.
    #[inline]
    fn specular_probability(&self) -> f32 {
        let (d, s) = (luminance(self.kd), luminance(self.ks));
        if s <= 0.0 {
            0.0
        } else {
            s / (d + s)
        }
    }

    /// Value of the specular lobe (without ks) and the density of sampling it, for unit wo, wi
    /// and normal n (all on the same side).
    #[inline]
    fn lobe(&self, wo: Vec3, wi: Vec3, n: Vec3) -> (f32, f32) {
        let m = self.exponent;
        match self.model {
            GlossyModel::Phong => {
                let c = reflect(wo, n).dot(wi);
                if c <= 0.0 {
                    return (0.0, 0.0);
                }
                let p = power_cosine_pdf(c, m);
                ((m + 2.0) / (m + 1.0) * p, p)
            }
            GlossyModel::BlinnPhong => {
                let h = (wo + wi).normalize_or_zero();
                let (c, oh) = (n.dot(h), wo.dot(h));
                if c <= 0.0 || oh <= 0.0 {
                    return (0.0, 0.0);
                }
                let pdf = power_cosine_pdf(c, m) / (4.0 * oh);
                let cos_max = n.dot(wi).max(n.dot(wo));
                (pdf / cos_max, pdf)
            }
        }
    }

    /// f(wo, wi) for unit vectors with n facing wo; zero below the surface.
    pub fn eval(&self, wo: Vec3, wi: Vec3, n: Vec3) -> Vec3 {
        if n.dot(wi) <= 0.0 || n.dot(wo) <= 0.0 {
            return Vec3::ZERO;
        }
        let mut f = self.kd * (1.0 / PI);
        if self.ks != Vec3::ZERO {
            f += self.ks * self.lobe(wo, wi, n).0;
        }
        f
    }

    /// `(eval, pdf)` with the glossy lobe computed once: the same numbers as the two calls.
    #[inline]
    pub fn eval_and_pdf(&self, wo: Vec3, wi: Vec3, n: Vec3) -> (Vec3, f32) {
        let cos_i = n.dot(wi);
        if cos_i <= 0.0 || n.dot(wo) <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let ps = self.specular_probability();
        let lobe = if self.ks != Vec3::ZERO || ps > 0.0 { self.lobe(wo, wi, n) } else { (0.0, 0.0) };
        let mut f = self.kd * (1.0 / PI);
        if self.ks != Vec3::ZERO {
            f += self.ks * lobe.0;
        }
        let mut pdf = (1.0 - ps) * cos_i / PI;
        if ps > 0.0 {
            pdf += ps * lobe.1;
        }
        (f, pdf)
    }

    /// Density (solid angle) with which `sample` draws wi.
    pub fn pdf(&self, wo: Vec3, wi: Vec3, n: Vec3) -> f32 {
        let cos_i = n.dot(wi);
        if cos_i <= 0.0 || n.dot(wo) <= 0.0 {
            return 0.0;
        }
        let ps = self.specular_probability();
        let mut pdf = (1.0 - ps) * cos_i / PI;
        if ps > 0.0 {
            pdf += ps * self.lobe(wo, wi, n).1;
        }
        pdf
    }

    /// Samples wi from the glossy lobe alone (the AAF indirect strategy estimates the glossy
    /// component on its own, Mehta et al. 2013 Sec. 5): returns wi and the estimator weight
    /// lobe(wo, wi) cos(theta_i) / pdf(wi), without ks. None when the drawn direction is below
    /// the surface or the lobe is empty (then the sample contributes 0).
    pub fn sample_specular(&self, wo: Vec3, n: Vec3, u: [f32; 2]) -> Option<(Vec3, f32)> {
        let wi = self.sample_lobe_direction(wo, n, u)?;
        let cos_i = n.dot(wi);
        let (f, pdf) = self.lobe(wo, wi, n);
        let w = f * cos_i / pdf;
        (pdf > 0.0 && w.is_finite()).then_some((wi, w))
    }

    /// The direction of `u` under the glossy lobe (about the mirror direction for Phong, of the
    /// half vector for Blinn-Phong).
    #[inline]
    fn lobe_direction(&self, wo: Vec3, n: Vec3, u: [f32; 2]) -> Vec3 {
        match self.model {
            GlossyModel::Phong => to_world(reflect(wo, n), power_cosine(u, self.exponent)),
            GlossyModel::BlinnPhong => reflect(wo, to_world(n, power_cosine(u, self.exponent))),
        }
        .normalize_or_zero()
    }

    /// Samples wi from the glossy lobe alone, for a strategy that estimates the glossy part on
    /// its own (`mis::shadowed_lobe_term`): the direction only (None below the surface or without a
    /// lobe), since a caller that keeps only some directions evaluates the lobe for those
    /// (`specular_and_pdf`).
    #[inline]
    pub fn sample_lobe_direction(&self, wo: Vec3, n: Vec3, u: [f32; 2]) -> Option<Vec3> {
        if self.ks == Vec3::ZERO || n.dot(wo) <= 0.0 {
            return None;
        }
        let wi = self.lobe_direction(wo, n, u);
        (n.dot(wi) > 0.0).then_some(wi)
    }

    /// The glossy part of f(wo, wi) (ks times the lobe) and the density with which
    /// `sample_lobe_direction` draws wi; zeros below the surface or without a lobe.
    #[inline]
    pub fn specular_and_pdf(&self, wo: Vec3, wi: Vec3, n: Vec3) -> (Vec3, f32) {
        if self.ks == Vec3::ZERO || n.dot(wi) <= 0.0 || n.dot(wo) <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let (f, pdf) = self.lobe(wo, wi, n);
        (self.ks * f, pdf)
    }

    /// Importance-samples wi: cosine for the diffuse part, the power-cosine lobe for the glossy
    /// part, chosen by luminance; the density is that of the mixture, so the estimate
    /// f cos / pdf stays unbiased whichever lobe drew the direction.
    pub fn sample(&self, wo: Vec3, n: Vec3, u_lobe: f32, u: [f32; 2]) -> Option<BrdfSample> {
        if self.is_black() || n.dot(wo) <= 0.0 {
            return None;
        }
        let ps = self.specular_probability();
        let wi = if u_lobe < ps {
            match self.model {
                GlossyModel::Phong => to_world(reflect(wo, n), power_cosine(u, self.exponent)),
                GlossyModel::BlinnPhong => {
                    let h = to_world(n, power_cosine(u, self.exponent));
                    reflect(wo, h)
                }
            }
        } else {
            to_world(n, cosine_hemisphere(u))
        };
        let wi = wi.normalize_or_zero();
        let (f, pdf) = self.eval_and_pdf(wo, wi, n);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BrdfSample { wi, f, pdf })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sampler::PixelSampler;

    fn glossy(model: GlossyModel, m: f32) -> Brdf {
        Brdf { kd: Vec3::splat(0.3), ks: Vec3::splat(0.6), exponent: m, model }
    }

    /// Directional albedo by importance sampling: sum f cos / pdf.
    fn albedo(b: &Brdf, wo: Vec3, n: usize) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for i in 0..n {
            let mut s = PixelSampler::new(5, 0, i as u32);
            let ul = s.next_1d();
            if let Some(x) = b.sample(wo, Vec3::Z, ul, s.next_2d()) {
                sum += x.f * x.wi.z / x.pdf;
            }
        }
        sum / n as f32
    }

    /// Integral of `f(wi)` over the upper hemisphere by the midpoint rule in (cos theta, phi).
    fn hemisphere_integral(n: usize, f: impl Fn(Vec3) -> f64) -> f64 {
        let mut sum = 0.0f64;
        for i in 0..n {
            let c = (i as f32 + 0.5) / n as f32;
            let s = (1.0 - c * c).sqrt();
            for j in 0..n {
                let phi = (j as f32 + 0.5) / n as f32 * 2.0 * PI;
                sum += f(Vec3::new(s * phi.cos(), s * phi.sin(), c));
            }
        }
        sum * 2.0 * std::f64::consts::PI / (n * n) as f64
    }

    /// Directional albedo by quadrature of f cos.
    fn quadrature_albedo(b: &Brdf, wo: Vec3) -> f64 {
        hemisphere_integral(600, |wi| (b.eval(wo, wi, Vec3::Z).x * wi.z) as f64)
    }

    #[test]
    fn lambertian_albedo_is_exact_under_cosine_sampling() {
        let b = Brdf { kd: Vec3::new(0.2, 0.5, 0.8), ..Brdf::BLACK };
        let a = albedo(&b, Vec3::new(0.3, 0.1, 0.9).normalize(), 256);
        assert!((a - b.kd).abs().max_element() < 1e-4, "{a}");
    }

    #[test]
    fn sampling_density_matches_pdf_and_energy_is_conserved() {
        for model in [GlossyModel::Phong, GlossyModel::BlinnPhong] {
            for m in [1.0, 10.0, 50.0, 1000.0] {
                let b = glossy(model, m);
                let wo = Vec3::Z;
                let a = albedo(&b, wo, 1 << 14);
                // At most kd + ks; broad Blinn-Phong lobes lose energy by design.
                assert!(a.x <= 0.9 + 0.01, "{model:?} m={m}: albedo {a}");
                assert!(a.x > 0.3, "{model:?} m={m}: albedo {a}");
                if m >= 50.0 {
                    assert!(a.x > 0.85, "{model:?} m={m}: albedo {a}");
                }
                // The sampled estimate equals a quadrature of f cos: sample() agrees with eval().
                let q = quadrature_albedo(&b, Vec3::new(0.6, 0.0, 0.8));
                let s = albedo(&b, Vec3::new(0.6, 0.0, 0.8), 1 << 14);
                if m <= 50.0 {
                    assert!((q - s.x as f64).abs() < 0.01, "{model:?} m={m}: quadrature {q} sampled {s}");
                }
            }
        }
    }

    #[test]
    fn glossy_lobe_sampling_estimates_the_glossy_albedo() {
        // sum over lobe samples of lobe cos / pdf = int ks-free lobe cos: the quadrature of
        // the glossy part of f / ks. Exponents up to 1e6 stay finite.
        for model in [GlossyModel::Phong, GlossyModel::BlinnPhong] {
            for m in [0.0, 3.0, 20.0, 1e6] {
                let b = glossy(model, m);
                let wo = Vec3::new(0.6, 0.0, 0.8);
                let n = 1 << 14;
                let mut sum = 0.0f64;
                for i in 0..n {
                    if let Some((wi, w)) = b.sample_specular(wo, Vec3::Z, PixelSampler::new(8, 0, i).next_2d()) {
                        assert!(w.is_finite() && w >= 0.0 && wi.z > 0.0, "{model:?} m={m}: {w}");
                        sum += w as f64;
                    }
                }
                let sampled = sum / n as f64;
                if m <= 20.0 {
                    let q =
                        hemisphere_integral(600, |wi| (b.specular_and_pdf(wo, wi, Vec3::Z).0.x * wi.z) as f64) / 0.6;
                    assert!((q - sampled).abs() < 0.01, "{model:?} m={m}: quadrature {q} sampled {sampled}");
                } else {
                    assert!(sampled > 0.5 && sampled <= 1.0 + 1e-3, "{model:?} m={m}: {sampled}");
                }
            }
        }
    }

    #[test]
    fn pdf_integrates_to_at_most_one() {
        // Riemann sum of the pdf over the hemisphere in (cos, phi).
        for model in [GlossyModel::Phong, GlossyModel::BlinnPhong] {
            let b = glossy(model, 20.0);
            let wo = Vec3::new(0.5, 0.0, 0.866).normalize();
            let sum = hemisphere_integral(400, |wi| b.pdf(wo, wi, Vec3::Z) as f64);
            // Lobe mass below the horizon is lost, so <= 1, and most of it is kept.
            assert!(sum <= 1.01 && sum > 0.9, "{model:?}: {sum}");
        }
    }

    #[test]
    fn extreme_exponents_stay_finite() {
        for model in [GlossyModel::Phong, GlossyModel::BlinnPhong] {
            for m in [0.0, 1e-6, 1e6] {
                let b = glossy(model, m);
                let wo = Vec3::new(0.1, 0.2, 0.97).normalize();
                for i in 0..200 {
                    let mut s = PixelSampler::new(1, 2, i);
                    let ul = s.next_1d();
                    if let Some(x) = b.sample(wo, Vec3::Z, ul, s.next_2d()) {
                        let w = x.f * x.wi.z / x.pdf;
                        assert!(w.is_finite() && w.min_element() >= 0.0, "m={m}: {w}");
                    }
                }
            }
        }
    }

    #[test]
    fn below_the_surface_is_black() {
        let b = glossy(GlossyModel::Phong, 10.0);
        assert_eq!(b.eval(Vec3::Z, Vec3::NEG_Z, Vec3::Z), Vec3::ZERO);
        assert_eq!(b.pdf(Vec3::Z, Vec3::new(1.0, 0.0, -0.1).normalize(), Vec3::Z), 0.0);
    }
}

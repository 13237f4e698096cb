//! `bandwidth`'s camera samples per pixel (a departure, docs/methods.md §4.3): a share of each
//! pass (`adaptive_share`, half) goes where one camera sample of the pixel's estimate varies
//! most.
//!
//! The paper shares its integration samples by a bound on the shading's variance (Eq. 8, the
//! lookups here); what is left in wedge's images is the noise of what each camera sample traces
//! (shadows, bounces, antialiasing across objects' edges) and the spread of the shaded values
//! inside the pixel (a distant texture), which no bandwidth predicts. It is
//! measured: each pixel keeps the first and second moments of its samples' terms, and the
//! variance of one sample's share of the pixel's estimate follows from them
//! (`Moments::sample_variance`). The counts then go in proportion to its square root
//! (`pipeline::allocation`), a share of every pass uniform.
use super::options::Visibility;

/// A pixel's sums over its samples of the luminance (channel mean) of their terms: `w` of the
/// whole estimates, `a`, `b`, `c` of `rest`, `shadowed` and `unshadowed` on the centre's object,
/// `s` of the shaded values (its own `S_hat`'s samples).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    pub w: f64,
    pub ww: f64,
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub aa: f64,
    pub bb: f64,
    pub cc: f64,
    pub ab: f64,
    pub ac: f64,
    pub bc: f64,
    pub s: f64,
    pub ss: f64,
}

fn luminance(v: [f32; 3]) -> f64 {
    (v[0] as f64 + v[1] as f64 + v[2] as f64) / 3.0
}

impl Moments {
    pub fn add_whole(&mut self, v: [f32; 3]) {
        let w = luminance(v);
        self.w += w;
        self.ww += w * w;
    }

    pub fn add_shaded(&mut self, v: [f32; 3]) {
        let s = luminance(v);
        self.s += s;
        self.ss += s * s;
    }

    pub fn add_terms(&mut self, rest: [f32; 3], shadowed: [f32; 3], unshadowed: [f32; 3]) {
        let (a, b, c) = (luminance(rest), luminance(shadowed), luminance(unshadowed));
        self.a += a;
        self.b += b;
        self.c += c;
        self.aa += a * a;
        self.bb += b * b;
        self.cc += c * c;
        self.ab += a * b;
        self.ac += a * c;
        self.bc += b * c;
    }

    /// The variance of one of the pixel's `n` samples' share of its estimate, None below two
    /// samples. A sample on the centre's object counts as `a + k_b b - k_c c`, the estimate's
    /// derivatives in its sums (the delta method): with the ratio estimator `S_hat sum(b) /
    /// sum(c)`, `k_b = S / c_mean` and `k_c = S rho / c_mean` (`rho = sum(b) / sum(c)`), so a
    /// pixel wholly lit (b = c) or wholly in shadow (b = 0) shows only the rest's noise; with the
    /// control variate `k_b = k_c = 1`; with no shading yet, `k_b = 1, k_c = 0` (the plain
    /// estimate). `s_hat` is the luminance of the pixel's `S_hat`.
    ///
    /// Where `S_hat` is the mean of the pixel's own `n_shaded` shaded values (its lookups'
    /// noise and the texture and shape it varies with inside the pixel), their variance adds
    /// as the estimate's derivative in `S_hat` squared times `n / n_shaded`: `rho^2 n_same^2 /
    /// (n n_shaded)` per unit (1 in place of `rho` with the control variate); its covariance
    /// with the other terms is left out. An `S_hat` upsampled from parents adds nothing: more
    /// samples of this pixel do not lower its noise.
    pub fn sample_variance(
        &self,
        n: u32,
        n_same: u32,
        n_shaded: u32,
        s_hat: Option<f64>,
        visibility: Visibility,
    ) -> Option<f64> {
        if n < 2 {
            return None;
        }
        let (kb, kc) = match (s_hat, visibility) {
            (None, _) => (1.0, 0.0),
            (Some(_), Visibility::ControlVariate) => (1.0, 1.0),
            (Some(_), Visibility::Ratio) if self.c <= 0.0 || n_same == 0 => (1.0, 0.0),
            (Some(s), Visibility::Ratio) => {
                let c_mean = self.c / n_same as f64;
                (s / c_mean, s * (self.b / self.c) / c_mean)
            }
        };
        let nf = n as f64;
        let sum = self.w + self.a + kb * self.b - kc * self.c;
        let sum2 = self.ww + self.aa + kb * kb * self.bb + kc * kc * self.cc + 2.0 * kb * self.ab
            - 2.0 * kc * self.ac
            - 2.0 * kb * kc * self.bc;
        let mut v = (sum2 / nf - (sum / nf).powi(2)).max(0.0) * nf / (nf - 1.0);
        if s_hat.is_some() && n_shaded >= 2 {
            let m = n_shaded as f64;
            let var_s = (self.ss / m - (self.s / m).powi(2)).max(0.0) * m / (m - 1.0);
            let k = match visibility {
                Visibility::Ratio if self.c > 0.0 => self.b / self.c,
                Visibility::Ratio => 0.0,
                Visibility::ControlVariate => 1.0,
            };
            v += k * k * (n_same as f64).powi(2) / (nf * m) * var_s;
        }
        v.is_finite().then_some(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::test_rng::Rng;

    fn terms(m: &mut Moments, a: f32, b: f32, c: f32) {
        m.add_terms([a; 3], [b; 3], [c; 3]);
    }

    /// The plain estimate (no `S_hat`): the variance of `rest + shadowed` and the whole samples
    /// as one population, the unbiased sample variance.
    #[test]
    fn without_shading_it_is_the_variance_of_the_plain_samples() {
        let mut m = Moments::default();
        terms(&mut m, 1.0, 2.0, 5.0); // 3
        terms(&mut m, 0.0, 1.0, 5.0); // 1
        m.add_whole([2.0, 2.0, 2.0]); // 2
        let v = m.sample_variance(3, 2, 0, None, Visibility::Ratio).unwrap();
        assert!((v - 1.0).abs() < 1e-12, "{v}");
        assert_eq!(m.sample_variance(1, 1, 0, None, Visibility::Ratio), None);
        assert_eq!(Moments::default().sample_variance(0, 0, 0, None, Visibility::Ratio), None);
    }

    /// With the ratio estimator, a pixel wholly lit (shadowed = unshadowed) or wholly shadowed
    /// (shadowed = 0) has no noise from the light, however much the unshadowed samples vary:
    /// only `rest`'s variance is left.
    #[test]
    fn the_ratio_removes_the_light_s_noise_where_visibility_is_constant() {
        let mut rng = Rng(3);
        let (mut lit, mut dark) = (Moments::default(), Moments::default());
        for _ in 0..64 {
            let c = 10.0 * rng.f();
            terms(&mut lit, 0.5, c, c);
            terms(&mut dark, 0.5, 0.0, c);
        }
        for m in [lit, dark] {
            assert!(m.sample_variance(64, 64, 0, Some(5.0), Visibility::Ratio).unwrap() < 1e-9);
            // The control variate keeps the unshadowed samples' noise in shadow.
            let cv = m.sample_variance(64, 64, 0, Some(5.0), Visibility::ControlVariate).unwrap();
            assert!(if m.b == 0.0 { cv > 1.0 } else { cv < 1e-9 }, "{cv}");
        }
    }

    /// In a penumbra the delta method's variance matches the spread of the ratio estimate over
    /// repeated pixels: n times the variance of the estimate, within sampling error.
    #[test]
    fn in_a_penumbra_it_predicts_the_ratio_estimate_s_spread() {
        let (n, trials, s_hat) = (64u32, 2000, 4.0);
        let mut rng = Rng(11);
        let mut estimates = Vec::new();
        let mut predicted = 0.0;
        for _ in 0..trials {
            let mut m = Moments::default();
            for _ in 0..n {
                // Unshadowed light varies; visible with probability 0.4; rest noisy too.
                let c = 1.0 + 2.0 * rng.f();
                let b = if rng.f() < 0.4 { c } else { 0.0 };
                terms(&mut m, 0.2 * rng.f(), b, c);
            }
            let nf = n as f64;
            estimates.push((m.a + nf * s_hat * m.b / m.c) / nf);
            predicted += m.sample_variance(n, n, 0, Some(s_hat), Visibility::Ratio).unwrap() / trials as f64;
        }
        let mean = estimates.iter().sum::<f64>() / trials as f64;
        let spread = estimates.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (trials - 1) as f64;
        let ratio = predicted / (n as f64 * spread);
        // 2000 trials: the sample variance's relative error is about sqrt(2 / 2000) = 3%.
        assert!((ratio - 1.0).abs() < 0.12, "predicted / measured = {ratio}");
    }

    /// Values that overflow give no variance rather than an infinite or NaN one.
    #[test]
    fn non_finite_sums_give_none() {
        let mut m = Moments::default();
        m.add_whole([f32::MAX; 3]);
        m.add_whole([f32::MAX; 3]);
        m.ww = f64::INFINITY;
        assert_eq!(m.sample_variance(2, 0, 0, None, Visibility::Ratio), None);
    }
}

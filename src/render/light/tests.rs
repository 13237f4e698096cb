//! Tests of the lights: sampling against closed forms and quadrature, the Gaussian profile's
//! tables, clipping at the horizon.
use super::irradiance::*;
use super::profile::*;
use super::*;
use crate::render::sampler::PixelSampler;

#[test]
fn polygon_irradiance_matches_the_corner_form_factor() {
    // Point under the corner of an a x b rectangle at height h (Howell's catalogue C-11):
    // F = 1/(2 pi) [A/sqrt(1+A^2) atan(B/sqrt(1+A^2)) + B/sqrt(1+B^2) atan(A/sqrt(1+B^2))].
    let (a, b, h) = (2.0f64, 1.0f64, 1.5f64);
    let (aa, bb) = (a / h, b / h);
    let f = (aa / (1.0 + aa * aa).sqrt() * (bb / (1.0 + aa * aa).sqrt()).atan()
        + bb / (1.0 + bb * bb).sqrt() * (aa / (1.0 + bb * bb).sqrt()).atan())
        / (2.0 * std::f64::consts::PI);
    let v = [Vec3::new(0.0, 0.0, 1.5), Vec3::new(2.0, 0.0, 1.5), Vec3::new(2.0, 1.0, 1.5), Vec3::new(0.0, 1.0, 1.5)];
    let e = polygon_irradiance(Vec3::ZERO, Vec3::Z, &v);
    assert!((e - std::f64::consts::PI * f).abs() < 1e-6, "{e} vs {}", std::f64::consts::PI * f);
}

#[test]
fn area_sampling_estimates_the_analytic_irradiance() {
    // A 1 x 0.5 light facing down at height 1, offset from the receiver point.
    let light = RectLight::new(
        Vec3::new(-0.2, 0.3, 1.0),
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::ONE,
        EmissionProfile::Uniform,
    );
    assert!(light.normal.z < 0.0);
    let x = Vec3::ZERO;
    let exact = polygon_irradiance(
        x,
        Vec3::Z,
        &[
            light.corner,
            light.corner + light.edge_u,
            light.corner + light.edge_u + light.edge_v,
            light.corner + light.edge_v,
        ],
    );
    let n = 4096;
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for i in 0..n {
        let s = light.sample(x, PixelSampler::new(11, 0, i).next_2d()).unwrap();
        let e = (s.weight.x * s.wi.z) as f64;
        sum += e;
        sum2 += e * e;
    }
    let mean = sum / n as f64;
    let sd = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
    // Stratified samples beat the iid standard error; 4 sigma of the iid error is generous
    // yet fails on any radiometric factor error (pi, area, cos_L, 1/r^2).
    assert!((mean - exact).abs() < 4.0 * sd + 1e-6, "mean {mean} exact {exact} sd {sd}");
}

/// Stratified Monte Carlo estimate of the unshadowed irradiance (unit radiance) and its
/// standard error, from `sample`.
fn mc_irradiance(l: &RectLight, x: Vec3, n: Vec3, ng: Vec3, count: u32) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for i in 0..count {
        let e = l.sample(x, PixelSampler::new(21, 0, i).next_2d()).map_or(0.0, |s| {
            if ng.dot(s.wi) <= 0.0 {
                return 0.0;
            }
            (s.weight.x * n.dot(s.wi).max(0.0)) as f64 / l.radiance.x as f64
        });
        sum += e;
        sum2 += e * e;
    }
    let mean = sum / count as f64;
    (mean, ((sum2 / count as f64 - mean * mean) / count as f64).sqrt())
}

#[test]
fn deterministic_irradiance_matches_monte_carlo_for_both_profiles() {
    for profile in [EmissionProfile::Uniform, EmissionProfile::Gaussian] {
        let l = RectLight::new(Vec3::new(-0.5, 1.0, -0.5), Vec3::X, Vec3::Z * 1.5, Vec3::ONE, profile);
        assert!(l.normal.y < 0.0);
        // Facing up below the light; tilted so the horizon cuts the light; grazing.
        let cases = [
            (Vec3::new(0.3, 0.0, 0.2), Vec3::Y),
            (Vec3::new(0.0, 0.2, 0.1), Vec3::new(0.6, 0.8, 0.0).normalize()),
            (Vec3::new(2.0, 0.5, 0.0), Vec3::new(-1.0, 0.05, 0.0).normalize()),
            (Vec3::new(0.0, 0.5, 0.0), Vec3::new(1.0, 0.0, 0.0)),
        ];
        // A shading normal tilted off the geometric one: both horizons clip.
        let tilted =
            (Vec3::new(0.0, 0.3, 0.1), Vec3::new(0.5, 0.85, 0.0).normalize(), Vec3::new(-0.4, 0.9, 0.0).normalize());
        for (x, n, ng) in cases.into_iter().map(|(x, n)| (x, n, n)).chain([tilted]) {
            let exact = l.unshadowed_irradiance(x, n, ng);
            let (mc, se) = mc_irradiance(&l, x, n, ng, 1 << 15);
            assert!(
                (exact - mc).abs() < 4.0 * se + 2e-3 * mc.abs() + 1e-7,
                "{profile:?} at {x} n {n}: {exact} vs {mc} ± {se}"
            );
        }
        // Behind the light, or facing away: nothing.
        assert_eq!(l.unshadowed_irradiance(Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Y, Vec3::NEG_Y), 0.0);
        assert_eq!(l.unshadowed_irradiance(Vec3::new(0.0, 0.0, 0.0), Vec3::NEG_Y, Vec3::NEG_Y), 0.0);
    }
}

#[test]
fn near_field_irradiance_of_a_gaussian_light_is_accurate() {
    // Receivers very close to the light, where the 1/r^2 peak defeats a fixed rule (a single
    // 4 x 4 rule was off by 15-50% here): the adaptive rule must match Monte Carlo.
    let l = RectLight::new(Vec3::new(-0.5, 1.0, -0.5), Vec3::X, Vec3::Z, Vec3::ONE, EmissionProfile::Gaussian);
    for (x, n) in [
        (Vec3::new(0.0, 0.8, 0.0), Vec3::Y),
        (Vec3::new(0.1, 0.95, -0.1), Vec3::Y),
        (Vec3::new(0.6, 0.9, 0.0), Vec3::new(-1.0, 0.0, 0.0)),
        (Vec3::new(0.53, 0.97, 0.2), Vec3::new(-1.0, 0.3, 0.0).normalize()),
    ] {
        let e = l.unshadowed_irradiance(x, n, n);
        let (mc, se) = mc_irradiance(&l, x, n, n, 1 << 17);
        assert!((e - mc).abs() < 4.0 * se + 2e-3 * mc, "at {x}: {e} vs {mc} ± {se}");
    }
    let u = RectLight::new(Vec3::new(-0.5, 1.0, -0.5), Vec3::X, Vec3::Z, Vec3::ONE, EmissionProfile::Uniform);
    let e = u.unshadowed_irradiance(Vec3::new(0.0, 1.0 - 1e-4, 0.0), Vec3::Y, Vec3::Y);
    assert!((e - std::f64::consts::PI).abs() < 1e-2, "a light filling the hemisphere gives pi: {e}");
}

/// Irradiance of a Gaussian light by a 600 x 600 midpoint rule over the whole rectangle
/// (receivers that see all of it).
fn brute_force_gaussian_irradiance(l: &RectLight, x: Vec3, n: Vec3) -> f64 {
    let k = 600;
    let (xd, nd, nl) = (x.as_dvec3(), n.as_dvec3(), l.normal.as_dvec3());
    let mut sum = 0.0;
    for i in 0..k {
        for j in 0..k {
            let (s, t) = ((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
            let y = l.corner.as_dvec3() + s * l.edge_u.as_dvec3() + t * l.edge_v.as_dvec3();
            let d = y - xd;
            let r2 = d.length_squared();
            sum += l.profile_weight(y.as_vec3()) as f64 * nd.dot(d).max(0.0) * (-nl.dot(d)).max(0.0) / (r2 * r2);
        }
    }
    sum * l.area as f64 / (k * k) as f64
}

/// A square Gaussian light of side `2 span sigma` centred over the origin at height 1,
/// facing down (sigma = 0.25).
fn gaussian_light_spanning(span: f32) -> RectLight {
    let side = 2.0 * span * 0.25;
    let corner = Vec3::new(-0.5 * side, 1.0, -0.5 * side);
    RectLight::gaussian(corner, Vec3::X * side, Vec3::Z * side, Vec3::ONE, 0.25)
}

#[test]
fn far_field_rule_matches_a_brute_force_quadrature() {
    // Receivers from 0.8 weighted diagonals (`weighted_diagonal`) to fifty away, tilted,
    // seeing the whole light; the authors' light (a 1 x 1.4 rectangle spanning +-1 sigma)
    // and Gaussians whose tails the rectangle holds (+-3 and +-4 sigma), where Gauss-Legendre
    // nodes mapped through the profile's inverse distribution function were off by 2e-3.
    let lights = [
        RectLight::new(Vec3::new(-0.5, 1.0, -0.7), Vec3::X, Vec3::Z * 1.4, Vec3::ONE, EmissionProfile::Gaussian),
        gaussian_light_spanning(3.0),
        gaussian_light_spanning(4.0),
    ];
    for l in &lights {
        let diagonal = l.weighted_diagonal() as f32;
        let full = (l.edge_u + l.edge_v).length();
        // The squares span +-3 and +-4 sigma: 2/3 and 1/2 of the diagonal lie within 2 sigma.
        let span = l.edge_u.length() / (2.0 * l.sigma());
        let expected = if span > 2.0 { full * 2.0 / span } else { full };
        assert!((diagonal - expected).abs() < 1e-5 * full, "{diagonal} vs {expected}");
        let mut used = 0;
        for k in 0..120 {
            let h = diagonal * (0.8 + 49.2 * ((k % 20) as f32 / 19.0).powi(3));
            let off = Vec3::new(((k * 7) % 11) as f32 - 5.0, 0.0, ((k * 3) % 13) as f32 - 6.0) * 0.1 * h;
            let x = l.center() - Vec3::Y * h + off;
            let n = (Vec3::Y + Vec3::new(0.3 * ((k % 5) as f32 - 2.0), 0.0, 0.2)).normalize();
            let Some(far) = l.far_gaussian_irradiance(x, n, n) else { continue };
            used += 1;
            let exact = brute_force_gaussian_irradiance(l, x, n);
            assert!((far - exact).abs() <= 1e-6 * exact, "sigma {} at {x} (h = {h}): {far} vs {exact}", l.sigma());
            assert_eq!(l.unshadowed_irradiance(x, n, n), far);
        }
        assert!(used > 100, "{used}");
        // Nearer than 0.8 weighted diagonals, or with the light across the horizon: the adaptive rule.
        assert!(l.far_gaussian_irradiance(l.center() - Vec3::Y * 0.75 * diagonal, Vec3::Y, Vec3::Y).is_none());
        assert!(l.far_gaussian_irradiance(l.center() - Vec3::Y * 3.0, Vec3::X, Vec3::X).is_none());
    }
}

/// Integral of z^(2m) exp(-z^2/2) over [-a, a], by the series of the exponential for small
/// a (the recursion below cancels there) and, by parts, M_2m = (2m - 1) M_{2m-2} -
/// 2 a^{2m-1} exp(-a^2/2) from M_0 = sqrt(2 pi) erf(a / sqrt 2) otherwise (where the series
/// cancels instead).
fn truncated_gaussian_moment(a: f64, m: i32) -> f64 {
    if a <= 2.0 {
        let (mut sum, mut coeff) = (0.0, 1.0);
        for j in 0..60 {
            sum += coeff * a.powi(2 * m + 2 * j + 1) / (2 * m + 2 * j + 1) as f64;
            coeff *= -0.5 / (j + 1) as f64;
        }
        2.0 * sum
    } else {
        let mut moment = (2.0 * std::f64::consts::PI).sqrt() * libm::erf(a / std::f64::consts::SQRT_2);
        for k in 1..=m {
            moment = (2 * k - 1) as f64 * moment - 2.0 * a.powi(2 * k - 1) * (-0.5 * a * a).exp();
        }
        moment
    }
}

#[test]
fn truncated_gaussian_rule_integrates_polynomials_of_degree_15_exactly() {
    for a in [0.3, 1.0, 2.0, 3.0, 4.0, 8.0] {
        let rule = truncated_gaussian_rule(a);
        for degree in 0..16 {
            let exact = if degree % 2 == 1 { 0.0 } else { truncated_gaussian_moment(a, degree / 2) };
            let sum: f64 = rule.iter().map(|&(z, w)| w * z.powi(degree)).sum();
            let scale = rule.iter().map(|&(z, w)| w * z.abs().powi(degree)).sum::<f64>();
            assert!((sum - exact).abs() <= 1e-11 * scale, "a {a} degree {degree}: {sum} vs {exact}");
        }
        assert!(rule.iter().all(|&(z, w)| z.abs() < a && w > 0.0), "a {a}: {rule:?}");
        assert!(rule.windows(2).all(|p| p[0].0 < p[1].0), "a {a}: nodes in order");
    }
}

#[test]
fn a_narrow_gaussian_light_is_sampled_and_integrated_alike() {
    // The sampled estimate (uniform points weighted by the profile) and the deterministic
    // irradiance agree for a light spanning +-4 sigma, near (adaptive rule, split to the
    // profile's scale) and far; so do a skewed parallelogram's, which takes the adaptive rule.
    let narrow = gaussian_light_spanning(4.0);
    let skewed = RectLight::gaussian(Vec3::new(-0.5, 1.0, -0.5), Vec3::X, Vec3::new(0.4, 0.0, 1.0), Vec3::ONE, 0.2);
    assert!(skewed.gauss_rule.is_empty());
    for l in [&narrow, &skewed] {
        assert!((l.profile_weight(l.center() + Vec3::X * 3.0 * l.sigma()) - (-4.5f32).exp()).abs() < 1e-6);
        for (x, n) in [
            (Vec3::new(0.1, 0.7, 0.0), Vec3::Y),
            (Vec3::new(0.3, 0.9, -0.1), Vec3::new(-0.3, 1.0, 0.0).normalize()),
            (Vec3::new(0.5, -3.0, 0.2), Vec3::Y),
        ] {
            let e = l.unshadowed_irradiance(x, n, n);
            let (mc, se) = mc_irradiance(l, x, n, n, 1 << 16);
            assert!((e - mc).abs() < 4.0 * se + 2e-3 * mc, "sigma {} at {x}: {e} vs {mc} ± {se}", l.sigma());
        }
    }
}

#[test]
fn gaussian_samples_follow_the_profile_and_stay_on_the_light() {
    // Far below the light the geometry term is almost constant, so a sample's weight is
    // the profile over the density: nearly constant when the density follows the profile
    // (it would range over a factor e^4.5 = 90 at +-3 sigma with uniform placement).
    for l in [
        gaussian_light_spanning(3.0),
        gaussian_light_spanning(4.0),
        RectLight::new(Vec3::new(-0.5, 1.0, -0.7), Vec3::X, Vec3::Z * 1.4, Vec3::ONE, EmissionProfile::Gaussian),
    ] {
        let x = l.center() - Vec3::Y * 40.0 * (l.edge_u + l.edge_v).length();
        let (mut sum, mut sum2, count) = (0.0f64, 0.0f64, 4096);
        for i in 0..count {
            let u = PixelSampler::new(5, 0, i).next_2d();
            let (y, _) = l.place(u);
            let rel = y - l.corner;
            let (a, b) = (rel.dot(l.edge_u) / l.edge_u.length_squared(), rel.dot(l.edge_v) / l.edge_v.length_squared());
            assert!((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b), "{u:?} -> {a}, {b}");
            let w = l.sample(x, u).unwrap().weight.x as f64;
            (sum, sum2) = (sum + w, sum2 + w * w);
        }
        let mean = sum / count as f64;
        let spread = (sum2 / count as f64 - mean * mean).max(0.0).sqrt() / mean;
        // Within a segment of the table the profile still varies, most in the wide segments
        // of the tails.
        assert!(spread < 0.02, "sigma {}: weights spread {spread}", l.sigma());
    }
    // Uniform lights and skewed parallelograms are placed uniformly by area.
    let skewed = RectLight::gaussian(Vec3::ZERO, Vec3::X, Vec3::new(0.4, 0.0, 1.0), Vec3::ONE, 0.2);
    assert_eq!(skewed.place([0.25, 0.5]), (skewed.point([0.25, 0.5]), skewed.area));
}

#[test]
fn the_edge_distribution_inverts_its_table() {
    // The table holds the exact inverse of the distribution function F at j / SEGMENTS;
    // place(u) lands inside u's segment, linearly between its ends, and returns that
    // segment's reciprocal density: for a narrow, a moderate and an almost flat profile.
    for (len, sigma) in [(8.0, 1.0), (2.0, 1.0), (1.0, 30.0)] {
        let e = EdgeDistribution::new(len, sigma);
        let bound = 0.5 * len / (sigma * std::f64::consts::SQRT_2);
        let f = |x: f64| (libm::erf(bound * (2.0 * x - 1.0)) + libm::erf(bound)) / (2.0 * libm::erf(bound));
        let n = ProfileSampler::SEGMENTS;
        for (j, &x) in e.inverse.iter().enumerate() {
            assert!((f(x as f64) - j as f64 / n as f64).abs() < 1e-6, "len {len} sigma {sigma}: F({x}) at {j}");
        }
        assert!(e.inverse.windows(2).all(|w| w[1] > w[0]), "len {len} sigma {sigma}: increasing");
        for i in 0..=4000 {
            let u = (i as f32 / 4000.0).min(1.0 - f32::EPSILON) * (1.0 - 1e-7) + [0.0, 1e-7][i % 2];
            let (a, reciprocal) = e.place(u);
            let j = ((u as f64 * n as f64) as usize).min(n - 1);
            let (x0, x1) = (e.inverse[j], e.inverse[j + 1]);
            assert!(a >= x0 && a <= x1, "len {len} sigma {sigma}: {u} -> {a} outside [{x0}, {x1}]");
            let t = u as f64 * n as f64 - j as f64;
            assert!((a as f64 - (x0 as f64 + t * (x1 - x0) as f64)).abs() < 1e-6, "{u} -> {a}");
            assert!((reciprocal - (x1 - x0) * n as f32).abs() <= 1e-5 * reciprocal, "{u}: {reciprocal}");
        }
        // A point found by a ray gets the density of the segment `place` drew it from: at
        // every segment's middle and at its ends, tails included.
        for j in 0..n {
            let (x0, x1) = (e.inverse[j], e.inverse[j + 1]);
            let (mid, reciprocal) = e.place((j as f32 + 0.5) / n as f32);
            assert_eq!(e.reciprocal_density(mid), reciprocal, "len {len} sigma {sigma}: segment {j}");
            assert_eq!(e.reciprocal_density(x0), reciprocal, "len {len} sigma {sigma}: segment {j} start");
            if j + 1 < n {
                let next = (e.inverse[j + 2] - x1) * n as f32;
                assert_eq!(e.reciprocal_density(x1), next, "len {len} sigma {sigma}: segment {j} end");
            }
        }
        assert_eq!(e.reciprocal_density(1.0), (e.inverse[n] - e.inverse[n - 1]) * n as f32);
    }
}

#[test]
fn corners_on_the_horizon_stay_finite() {
    // The receiver's horizon passes exactly through a light corner.
    let u = RectLight::new(Vec3::new(0.0, 1.0, 0.0), Vec3::X, Vec3::Z, Vec3::ONE, EmissionProfile::Uniform);
    let x = Vec3::new(0.0, 0.0, 0.0);
    let n = Vec3::new(1.0, 0.0, 0.0).cross(Vec3::new(0.0, 1.0, 0.0) - x).normalize();
    let e = u.unshadowed_irradiance(x, n.normalize(), n.normalize());
    assert!(e.is_finite() && e >= 0.0, "{e}");
}

#[test]
fn back_side_receives_nothing() {
    let light = RectLight::new(Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE, EmissionProfile::Uniform);
    // Normal is +z; a point below cannot see the emitting side.
    assert!(light.sample(Vec3::new(0.5, 0.5, -1.0), [0.5, 0.5]).is_none());
    assert!(light.sample(Vec3::new(0.5, 0.5, 1.0), [0.5, 0.5]).is_some());
}

#[test]
fn gaussian_profile_is_one_at_centre_and_uses_sigma_sqrt_area_over_two() {
    let l = RectLight::new(Vec3::ZERO, Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::ONE, EmissionProfile::Gaussian);
    assert_eq!(l.sigma(), 1.0);
    assert_eq!(RectLight::gaussian(Vec3::ZERO, Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::ONE, 0.5).sigma(), 0.5);
    assert!((l.profile_weight(l.center()) - 1.0).abs() < 1e-7);
    let y = l.center() + Vec3::X;
    assert!((l.profile_weight(y) - (-0.5f32).exp()).abs() < 1e-6);
}

/// Variance of a profile's marginal along the u edge by brute force: the 1-D integrals of
/// z^2 w(z) and w(z) with a 20000-panel midpoint rule.
fn marginal_variance(profile: impl Fn(f64) -> f64, half: f64) -> f64 {
    let n = 20_000;
    let (mut m0, mut m2) = (0.0, 0.0);
    for i in 0..n {
        let z = -half + (i as f64 + 0.5) * 2.0 * half / n as f64;
        m0 += profile(z);
        m2 += z * z * profile(z);
    }
    m2 / m0
}

#[test]
fn emission_std_is_the_spread_of_the_emitted_power() {
    // A 2 x 6 rectangle: the narrower direction is u, of half-width 1.
    let (u, v) = (Vec3::X * 2.0, Vec3::Y * 6.0);
    for sigma in [0.25f32, 0.5, 1.0, 2.0, 20.0] {
        let l = RectLight::gaussian(Vec3::ZERO, u, v, Vec3::ONE, sigma);
        let s = sigma as f64;
        let exact = marginal_variance(|z| (-z * z / (2.0 * s * s)).exp(), 1.0).sqrt();
        let got = l.emission_std() as f64;
        assert!((got - exact).abs() < 1e-5 * exact, "sigma {sigma}: {got} vs {exact}");
    }
    // The authors' light (sigma = sqrt(area)/2, a square spanning +-1 sigma): 0.54 sigma.
    let authors = RectLight::new(Vec3::ZERO, Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::ONE, EmissionProfile::Gaussian);
    assert!((authors.emission_std() - 0.539_55).abs() < 1e-4, "{}", authors.emission_std());
    // A square spanning +-3 sigma is nearly the whole Gaussian; +-40 sigma is all of it.
    let wide = RectLight::gaussian(Vec3::ZERO, Vec3::X * 6.0, Vec3::Y * 6.0, Vec3::ONE, 1.0);
    assert!((wide.emission_std() - 0.986_6).abs() < 1e-3, "{}", wide.emission_std());
    let whole = RectLight::gaussian(Vec3::ZERO, Vec3::X * 80.0, Vec3::Y * 80.0, Vec3::ONE, 1.0);
    assert_eq!(whole.emission_std(), 1.0);
    // Uniform: width / sqrt(12) of the narrower edge, whatever the order of the edges.
    let flat = RectLight::new(Vec3::ZERO, v, u, Vec3::ONE, EmissionProfile::Uniform);
    assert!((flat.emission_std() - 2.0 / 12f32.sqrt()).abs() < 1e-6);
    // Zero size: no spread.
    let none = RectLight::new(Vec3::ZERO, Vec3::ZERO, Vec3::Y, Vec3::ONE, EmissionProfile::Uniform);
    assert_eq!(none.emission_std(), 0.0);
}

#[test]
fn truncated_normal_variance_joins_its_series_and_its_limits() {
    // Both sides of the switch to the series agree, and the uniform limit a^2/3 holds.
    let (below, above) = (truncated_normal_variance(0.05 - 1e-15), truncated_normal_variance(0.05));
    assert!((below - above).abs() < 1e-9 * below, "{below} vs {above}");
    assert!((truncated_normal_variance(1e-6) / (1e-12 / 3.0) - 1.0).abs() < 1e-9);
    assert!((truncated_normal_variance(1.0) - 0.291_125).abs() < 1e-5);
    assert_eq!(truncated_normal_variance(0.0), 0.0);
    assert_eq!(truncated_normal_variance(f64::INFINITY), 1.0);
    // Increasing in a.
    let mut last = 0.0;
    for i in 1..300 {
        let v = truncated_normal_variance(i as f64 * 0.02);
        assert!(v > last, "a = {}", i as f64 * 0.02);
        last = v;
    }
}

#[test]
fn point_light_is_inverse_square() {
    let p = PointLight { position: Vec3::new(0.0, 0.0, 2.0), intensity: Vec3::splat(8.0) };
    let s = p.sample(Vec3::ZERO).unwrap();
    assert_eq!(s.weight, Vec3::splat(2.0));
    assert_eq!(s.dist, 2.0);
}

/// Shoelace area of a polygon in the z = 0 plane.
fn area_xy(p: &[Vec3]) -> f32 {
    (0..p.len()).map(|i| p[i].x * p[(i + 1) % p.len()].y - p[(i + 1) % p.len()].x * p[i].y).sum::<f32>() / 2.0
}

#[test]
fn clipping_the_quad_by_two_planes_keeps_the_part_above_both() {
    let quad = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
    let x = Vec3::new(0.5, 0.5, 0.0);
    // Above both planes: the whole quad, unchanged.
    let all = clip_above_both(Vec3::new(-1.0, -1.0, 0.0), Vec3::X, Vec3::Y, &quad);
    assert_eq!(all.as_slice(), quad.as_slice());
    // x > 0.5 and y > 0.5: the top-right quarter.
    let quarter = clip_above_both(x, Vec3::X, Vec3::Y, &quad);
    assert!((area_xy(quarter.as_slice()) - 0.25).abs() < 1e-6);
    // Two diagonal cuts cut off two corners: six vertices, area 1 - 2 * (1/8).
    let (a, b) = (Vec3::new(1.0, 1.0, 0.0).normalize(), Vec3::new(-1.0, -1.0, 0.0).normalize());
    let hexagon = clip_above_both(Vec3::new(0.5, 0.0, 0.0), a, Vec3::ZERO, &quad);
    assert_eq!(hexagon.len, 0, "a zero normal keeps nothing");
    let hexagon =
        ClippedPolygon::new(&quad).clip_above(Vec3::new(0.5, 0.0, 0.0), a).clip_above(Vec3::new(1.0, 0.5, 0.0), b);
    assert_eq!(hexagon.len, 6);
    assert!((area_xy(hexagon.as_slice()) - 0.75).abs() < 1e-6, "{}", area_xy(hexagon.as_slice()));
    // Below a plane: nothing.
    assert_eq!(clip_above_both(Vec3::new(2.0, 0.0, 0.0), Vec3::X, Vec3::Y, &quad).len, 0);
}

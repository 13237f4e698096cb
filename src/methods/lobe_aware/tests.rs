//! The test oracles of methods.md §3.6 for the SG algebra, the lobes and the weights.
use super::lobe::{diffuse, specular};
use super::options::LobeOptions;
use super::sg::{ln_product_integral, product_integral_iwasaki, Sg, Weighted, LAMBDA_C};
use super::weights::*;
use crate::render::material::GlossyModel;
use glam::DVec3;
use std::f64::consts::PI;

/// Midpoint quadrature of f over the unit sphere, in polar coordinates about +z.
pub(super) fn sphere_integral(f: impl Fn(DVec3) -> f64, n_theta: usize) -> f64 {
    let n_phi = 2 * n_theta;
    let (dt, dp) = (PI / n_theta as f64, 2.0 * PI / n_phi as f64);
    let mut sum = 0.0;
    for i in 0..n_theta {
        let t = (i as f64 + 0.5) * dt;
        let (st, ct) = t.sin_cos();
        for j in 0..n_phi {
            let (sp, cp) = ((j as f64 + 0.5) * dp).sin_cos();
            sum += f(DVec3::new(st * cp, st * sp, ct)) * st;
        }
    }
    sum * dt * dp
}

fn at_angle(deg: f64) -> DVec3 {
    let a = deg.to_radians();
    DVec3::new(a.sin(), 0.0, a.cos())
}

#[test]
fn an_sg_is_the_euclidean_gaussian_of_unit_vectors() {
    for (axis, w, l) in [(at_angle(0.0), at_angle(33.0), 4.0), (at_angle(70.0), at_angle(-20.0), 0.3)] {
        let g = Sg::new(axis, l);
        let euclid = (-(w - axis).length_squared() * l / 2.0).exp();
        assert!((g.eval(w) - euclid).abs() < 1e-14);
    }
}

#[test]
fn sg_integral_matches_quadrature_and_tends_to_four_pi() {
    for l in [0.01, 0.5, 3.0, 10.0] {
        let g = Sg::new(DVec3::Z, l);
        let q = sphere_integral(|w| g.eval(w), 400);
        let closed = g.ln_integral().exp();
        assert!((closed - q).abs() < 1e-4 * q, "lambda {l}: {closed} vs {q}");
        assert!((closed - 2.0 * PI * (1.0 - (-2.0 * l).exp()) / l).abs() < 1e-12);
    }
    assert!((Sg::new(DVec3::Z, 0.0).ln_integral().exp() - 4.0 * PI).abs() < 1e-12);
    // Just below the switch to the series, the series equals the direct form in f64.
    for l in [0.99e-4f64, 1e-6, 1e-12] {
        let direct = (2.0 * PI * -(-2.0 * l).exp_m1() / l).ln();
        let series = Sg::new(DVec3::Z, l).ln_integral();
        assert!((series - direct).abs() < 1e-12, "{l}: {series} vs {direct}");
    }
}

#[test]
fn exact_product_integral_matches_quadrature_and_iwasaki_is_a_few_percent_off() {
    let (a, b) = (Sg::new(DVec3::Z, 3.0), Sg::new(at_angle(40.0), 7.0));
    let q = sphere_integral(|w| a.eval(w) * b.eval(w), 500);
    let exact = ln_product_integral(&a, &b).exp();
    assert!((exact - q).abs() < 1e-5, "{exact} vs {q}");
    assert!((exact - 0.399716).abs() < 1e-5);
    // C.1 underestimates at moderate sharpness and improves as it grows.
    let iw = product_integral_iwasaki(&a, &b);
    assert!((iw - 0.38442).abs() < 1e-4, "{iw}");
    let rel = |l: f64| {
        let (a, b) = (Sg::new(DVec3::Z, l), Sg::new(at_angle(5.0), l));
        (product_integral_iwasaki(&a, &b) / ln_product_integral(&a, &b).exp() - 1.0).abs()
    };
    assert!(rel(100.0) < rel(10.0) && rel(10.0) < rel(1.0) && rel(100.0) < 0.01);
    // Equal and opposite lobes: r = 0, still finite (2 pi e^{-2l} * 2).
    let (a, b) = (Sg::new(DVec3::Z, 2.0), Sg::new(-DVec3::Z, 2.0));
    assert!((ln_product_integral(&a, &b).exp() - 4.0 * PI * (-4.0f64).exp()).abs() < 1e-12);
}

#[test]
fn the_product_integral_has_no_cancellation_at_high_sharpness() {
    // lambda = 1e4 at 0.06 degrees, where the naive f32 form loses most of its digits to
    // cancellation (methods.md §3.3): the log-space value agrees with a direct f64 evaluation.
    let l = 1e4;
    let theta = 0.06f64.to_radians();
    let (a, b) = (Sg::new(DVec3::Z, l), Sg::new(at_angle(0.06), l));
    let r = (2.0 * l * l * (1.0 + theta.cos())).sqrt();
    let expected = (2.0 * PI).ln() + (r - 2.0 * l) + ((1.0 - (-2.0 * r).exp()) / r).ln();
    // r - 2 l computed in f64 here keeps 1e-12 relative accuracy at this scale.
    assert!((ln_product_integral(&a, &b) - expected).abs() < 1e-6);
}

#[test]
fn eq12_and_eq11_agree_as_methods_md_predicts() {
    let beta = 20.0;
    let max_diff = |l: f64| {
        (0..=180)
            .map(|d| {
                let (a, b) = (Sg::new(DVec3::Z, l), Sg::new(at_angle(d as f64), l));
                let w11 = mixture_weight(
                    &[Weighted { amplitude: 1.0, lobe: a }],
                    &[Weighted { amplitude: 1.0, lobe: b }],
                    beta,
                );
                (w11 - lobe_weight(&a, &b, beta)).abs()
            })
            .fold(0.0, f64::max)
    };
    let (d1, d10, d100) = (max_diff(1.0), max_diff(10.0), max_diff(100.0));
    assert!((d1 - 0.22).abs() < 0.03, "lambda 1: {d1}");
    assert!((d10 - 0.018).abs() < 0.004, "lambda 10: {d10}");
    assert!((d100 - 0.0018).abs() < 0.0005, "lambda 100: {d100}");
}

#[test]
fn weights_are_one_for_a_pixel_with_itself_symmetric_bounded_and_fall_with_angle() {
    let beta = 13.1;
    let lobes = [Sg::new(DVec3::Z, 0.5), Sg::new(at_angle(10.0), 30.0), Sg::new(at_angle(-50.0), 3000.0)];
    for a in &lobes {
        assert_eq!(lobe_weight(a, a, beta), 1.0);
        let m = [Weighted { amplitude: 0.7, lobe: *a }, Weighted { amplitude: 0.2, lobe: Sg::new(DVec3::X, 4.0) }];
        assert!((mixture_weight(&m, &m, beta) - 1.0).abs() < 1e-12);
        for b in &lobes {
            let (ab, ba) = (lobe_weight(a, b, beta), lobe_weight(b, a, beta));
            assert_eq!(ab, ba);
            assert!((0.0..=1.0).contains(&ab));
            let mb = [Weighted { amplitude: 1.3, lobe: *b }];
            let (x, y) = (mixture_weight(&m, &mb, beta), mixture_weight(&mb, &m, beta));
            assert!((x - y).abs() < 1e-12 && (0.0..=1.0).contains(&x));
        }
    }
    for l in [0.5, 10.0, 500.0] {
        let w: Vec<f64> =
            (0..=180).map(|d| lobe_weight(&Sg::new(DVec3::Z, l), &Sg::new(at_angle(d as f64), l), 5.0)).collect();
        assert!(w.windows(2).all(|p| p[1] <= p[0]), "lambda {l}");
        if l <= 10.0 {
            assert!(w[180] < w[90], "opposite axes weigh less than perpendicular ones");
        }
    }
}

#[test]
fn equal_axes_weigh_by_sharpness_ratio_and_eq12_equals_its_appendix_e_form() {
    let beta = 20.0;
    let w = lobe_weight(&Sg::new(DVec3::Z, 5.0), &Sg::new(DVec3::Z, 20.0), beta);
    assert!((w - 0.8f64.powf(beta)).abs() < 1e-15);
    for (li, lj, deg) in [(3.0, 7.0, 12.0), (50.0, 50.0, 3.0), (0.2, 9.0, 80.0)] {
        let (a, b) = (Sg::new(DVec3::Z, li), Sg::new(at_angle(deg), lj));
        let (u, v) = (li * lj, li + lj);
        let app_e = ((beta / 2.0) * (4.0 * u / (v * v)).ln() + (beta * u / v) * (a.axis.dot(b.axis) - 1.0)).exp();
        let printed = (2.0 * u.sqrt() / v).powf(beta) * (beta * u / v * (a.axis.dot(b.axis) - 1.0)).exp();
        assert!((lobe_weight(&a, &b, beta) - app_e).abs() < 1e-12);
        assert!((app_e - printed).abs() < 1e-12);
    }
    // The sharpness term in its one-logarithm form equals ln(4 rho / (1 + rho)^2) from equal
    // lobes down to a ratio of 1e-300, and is exactly 0 for equal sharpness.
    let lo_hi: Vec<(f64, f64)> = (0..=300)
        .map(|k| (10f64.powi(-k), 1.0))
        .chain([(1.0 - 1e-9, 1.0), (0.999, 1.0), (3.0, 3.0), (1e20, 1e20), (1e-20, 1e20)])
        .collect();
    for (lo, hi) in lo_hi {
        let rho = lo / hi;
        let want = 0.5 * beta * (4f64.ln() + rho.ln() - 2.0 * rho.ln_1p()).min(0.0);
        let got = ln_lobe_weight(&Sg::new(DVec3::Z, lo), &Sg::new(DVec3::Z, hi), beta);
        assert!((got - want).abs() <= 1e-12 * want.abs() + 1e-13, "rho {rho}: {got} vs {want}");
        if lo == hi {
            assert_eq!(got, 0.0);
        }
    }
}

#[test]
fn appendix_d_the_diffuse_similarity_and_its_normal_aware_equivalent() {
    for deg in [0.0, 20.0, 45.0, 90.0, 135.0, 180.0] {
        let (ni, nj) = (DVec3::Z, at_angle(deg));
        let q = sphere_integral(|w| w.dot(ni).max(0.0) * w.dot(nj).max(0.0), 400) * 3.0 / (2.0 * PI);
        assert!((diffuse_similarity(ni, nj) - q).abs() < 1e-4, "{deg}: {q}");
    }
    assert!((diffuse_similarity(DVec3::Z, DVec3::Z) - 1.0).abs() < 1e-15);
    assert!((diffuse_similarity(DVec3::Z, DVec3::X) - 1.0 / PI).abs() < 1e-15);
    assert!(diffuse_similarity(DVec3::Z, -DVec3::Z).abs() < 1e-15);
    // sigma_n^2(beta = 20, kappa = 100) as published, and Eq. 12 on two smoothed diffuse lobes
    // is Eq. 4 with that variance.
    assert!((diffuse_sigma_n2(20.0, 100.0) - 0.05404477).abs() < 1e-8);
    for deg in [0.0, 10.0, 60.0, 150.0] {
        let (ni, nj) = (DVec3::Z, at_angle(deg));
        for (beta, kappa) in [(20.0, 100.0), (13.1, f64::INFINITY)] {
            let lw = lobe_weight(&diffuse(ni).smoothed(kappa), &diffuse(nj).smoothed(kappa), beta);
            let nw = normal_weight(ni, nj, diffuse_sigma_n2(beta, kappa));
            assert!((lw - nw).abs() < 1e-12, "{deg} {beta} {kappa}: {lw} vs {nw}");
        }
    }
    assert_eq!(diffuse(DVec3::Z).sharpness, 2.0 * LAMBDA_C);
}

#[test]
fn appendix_a_gaussian_weights_match_quadrature_of_normalised_gaussians() {
    // 1-D: q = integral of p_i p_j with p the L2-normalised Gaussians of variance tau^2 + nu^2.
    let (xi, xj, ti, tj, nu) = (0.3, 1.1, 0.2, 0.5, 0.1);
    let g = |x: f64, m: f64, v: f64| (-(x - m) * (x - m) / (2.0 * v)).exp();
    let norm = |v: f64| (PI * v).powf(0.25);
    let (vi, vj) = (ti + nu, tj + nu);
    let n = 200_000;
    let h = 20.0 / n as f64;
    let q: f64 = (0..n)
        .map(|k| -10.0 + (k as f64 + 0.5) * h)
        .map(|x| g(x, xi, vi) / norm(vi) * g(x, xj, vj) / norm(vj))
        .sum::<f64>()
        * h;
    let beta = 3.0;
    assert!((gaussian_weight(&[xi], &[xj], (ti, tj), nu, beta) - q.powf(beta)).abs() < 1e-9);
    // Equal tau: Eq. 2's Gaussian with variance (2 tau^2 + 2 nu^2) / beta.
    let w = gaussian_weight(&[0.0, 1.0], &[0.5, 0.2], (0.3, 0.3), 0.2, beta);
    let d2 = 0.25 + 0.64;
    assert!((w - (-d2 / (2.0 * (2.0 * 0.3 + 2.0 * 0.2) / beta)).exp()).abs() < 1e-12);
}

#[test]
fn the_warp_at_normal_view_halves_twice_and_points_along_the_normal() {
    let o = LobeOptions::default();
    let n = at_angle(30.0);
    let s = specular(GlossyModel::BlinnPhong, 200.0, n, n, &o);
    assert!((s.sharpness - 50.0).abs() < 1e-12 && (s.axis - n).length() < 1e-12);
    // Phong needs no warp: its lobe is the mirror direction's, at the exponent.
    let psi = at_angle(-20.0);
    let p = specular(GlossyModel::Phong, 200.0, DVec3::Z, psi, &o);
    assert!((p.sharpness - 200.0).abs() < 1e-12 && (p.axis - at_angle(20.0)).length() < 1e-12);
}

/// Property tests at the extremes (issue 17): weights finite and in [0, 1] for sharpness from
/// 1e-20 to 1e20, grazing views, back-facing shading normals and opposite axes.
#[test]
fn weights_stay_finite_and_bounded_at_the_extremes() {
    let o = LobeOptions::default();
    let sharpness: Vec<f64> = (-20..=20).map(|e| 10f64.powi(e)).collect();
    let axes = [DVec3::Z, -DVec3::Z, DVec3::X, at_angle(1e-7), at_angle(179.9999)];
    for &li in &sharpness {
        for &lj in &sharpness {
            for &ai in &axes {
                for &aj in &axes {
                    let (a, b) = (Sg::new(ai, li), Sg::new(aj, lj));
                    for kappa in [f64::INFINITY, 100.0] {
                        let w = lobe_weight(&a.smoothed(kappa), &b.smoothed(kappa), 20.0);
                        assert!(w.is_finite() && (0.0..=1.0).contains(&w), "{li} {lj} {ai} {aj}: {w}");
                    }
                    let w = mixture_weight(
                        &[Weighted { amplitude: 1.0, lobe: a }],
                        &[Weighted { amplitude: 1e-30, lobe: b }],
                        20.0,
                    );
                    assert!(w.is_finite() && (0.0..=1.0).contains(&w), "eq 11 {li} {lj}: {w}");
                }
            }
        }
    }
    // Grazing and back-facing views give a finite, capped lobe with a unit axis, the mirror
    // direction of the view.
    let n = DVec3::Z;
    for psi in [at_angle(89.99999), at_angle(90.0), at_angle(120.0), -DVec3::Z] {
        for model in [GlossyModel::BlinnPhong, GlossyModel::Phong] {
            for m in [0.0, 1.0, 1e4, 1e30] {
                let s = specular(model, m, n, psi, &o);
                assert!(s.sharpness.is_finite() && s.sharpness <= o.max_sharpness);
                assert!((s.axis.length() - 1.0).abs() < 1e-9, "{psi} {m}: {}", s.axis);
                let mirror = (2.0 * n.dot(psi) * n - psi).normalize_or_zero();
                if mirror != DVec3::ZERO {
                    assert!((s.axis - mirror).length() < 1e-9, "{psi}: axis {} vs mirror {mirror}", s.axis);
                }
            }
        }
    }
    // A mixture with no positive amplitude (zero reflectance) is like nothing but itself.
    let zero = [Weighted { amplitude: 0.0, lobe: Sg::new(DVec3::Z, 3.0) }];
    let one = [Weighted { amplitude: 1.0, lobe: Sg::new(DVec3::Z, 3.0) }];
    assert_eq!(mixture_weight(&zero, &one, 20.0), 0.0);
    assert_eq!(mixture_weight(&zero, &zero, 20.0), 1.0);
    // Depth and normal weights.
    assert_eq!(depth_weight(5.0, 5.0, 0.0), 1.0);
    assert_eq!(depth_weight(5.0, 6.0, 0.0), 0.0);
    assert!((normal_weight(DVec3::Z, DVec3::X, 0.5) - (-2.0f64).exp()).abs() < 1e-15);
}

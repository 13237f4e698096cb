//! Oracles of the ASG lobes (methods.md §3.3, §3.6): integrals and product integrals against
//! quadrature over the sphere (about +z, within 20 degrees of which every lobe here points),
//! the eigen-solver against reconstruction, the warp against the reflected NDF it stands for,
//! and the weight's normalisation, symmetry and range.
use super::*;
use crate::methods::lobe_aware::lobe::specular_asg as specular;
use crate::methods::lobe_aware::options::LobeOptions;
use crate::methods::lobe_aware::sg::Sg;
use crate::methods::lobe_aware::tests::sphere_integral;
use crate::methods::lobe_aware::weights::ln_lobe_weight;
use crate::render::material::GlossyModel;

#[test]
fn the_integral_matches_quadrature_and_its_limits() {
    assert!((ln_integral(0.0, 0.0).exp() - PI).abs() < 1e-12, "a cosine lobe integrates to pi");
    for (lx, ly) in [(5.0, 1.0), (1.0, 5.0), (50.0, 3.0), (200.0, 0.0), (30.0, 30.0), (120.0, 45.0)] {
        let asg = Asg::new(DVec3::Z, DVec3::X, lx, ly);
        let want = sphere_integral(|w| asg.eval(w), 1500);
        let got = ln_integral(lx, ly).exp();
        assert!((got / want - 1.0).abs() < 2e-3, "B({lx}, {ly}) = {got}, quadrature {want}");
    }
    // The published value at (5, 1) (methods.md §3.3: the printed closed form gives 1.53).
    assert!((ln_integral(5.0, 1.0).exp() - 1.145).abs() < 1e-3);
    // Continuous where the closed form takes over.
    let (below, above) = (ln_integral(300.0, 39.999), ln_integral(300.0, 40.001));
    assert!((below - above).abs() < 1e-4, "{below} {above}");
}

#[test]
fn the_eigen_solver_reconstructs_symmetric_matrices() {
    let mut seed = 7u64;
    let mut next = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for scale in [1e-6, 1.0, 1e3, 1e12] {
        for _ in 0..50 {
            let (a, b, c) = (next(), next(), next());
            let (d, e, f) = (next(), next(), next());
            let m = DMat3::from_cols_array(&[a, d, e, d, b, f, e, f, c]) * scale;
            let (l, v) = symmetric_eigen(m);
            assert!(l[0] >= l[1] && l[1] >= l[2], "{l:?}");
            let rebuilt = (0..3).fold(DMat3::ZERO, |acc, i| acc + outer(v[i]) * l[i]);
            let err = (rebuilt - m).to_cols_array().iter().fold(0.0f64, |e, x| e.max(x.abs()));
            assert!(err < 1e-12 * scale, "{err} at scale {scale}");
            for i in 0..3 {
                assert!((v[i].length() - 1.0).abs() < 1e-12);
                assert!(v[i].dot(v[(i + 1) % 3]).abs() < 1e-10);
            }
        }
    }
}

#[test]
fn the_product_integral_matches_quadrature_for_sharp_lobes() {
    let tilt = |deg: f64| DVec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos());
    let cases = [
        (Asg::new(DVec3::Z, DVec3::X, 20.0, 5.0), Asg::new(tilt(10.0), DVec3::Y, 12.0, 6.0)),
        (Asg::new(DVec3::Z, DVec3::X, 60.0, 60.0), Asg::new(tilt(5.0), DVec3::X, 60.0, 60.0)),
        (Asg::new(DVec3::Z, DVec3::X, 100.0, 10.0), Asg::new(DVec3::Z, DVec3::Y, 100.0, 10.0)),
        (Asg::new(DVec3::Z, DVec3::X, 40.0, 8.0), Asg::new(tilt(20.0), DVec3::X, 40.0, 8.0)),
    ];
    for (a, b) in cases {
        let want = sphere_integral(|w| a.eval(w) * b.eval(w), 1500);
        let got = ln_product_integral(&a, &b).expect("defined").exp();
        assert!((got / want - 1.0).abs() < 0.03, "{got} against quadrature {want} for {a:?} {b:?}");
    }
    // Undefined where the smallest eigenvalue is double: round lobes at a right angle.
    let a = Asg::new(DVec3::Z, DVec3::X, 10.0, 10.0);
    let b = Asg::new(DVec3::X, DVec3::Y, 10.0, 10.0);
    assert_eq!(ln_product_integral(&a, &b), None);
}

#[test]
fn the_warp_follows_the_reflected_blinn_phong_ndf() {
    // The warped lobe's curvature along x and y, against the NDF D(h) = (n.h)^m evaluated at
    // the half vector of each reflected direction: ln D falls as lx (w.x)^2 + ly (w.y)^2.
    let (m, n) = (400.0, DVec3::Z);
    let opts = LobeOptions::default();
    for view_deg in [0.0f64, 30.0, 60.0, 75.0] {
        let psi = DVec3::new(view_deg.to_radians().sin(), 0.0, view_deg.to_radians().cos());
        let asg = specular(GlossyModel::BlinnPhong, m, n, psi, &opts);
        let mirror = 2.0 * n.dot(psi) * n - psi;
        assert!((asg.z - mirror).length() < 1e-12);
        let ln_d = |w: DVec3| m * (w + psi).normalize().dot(n).ln();
        let step = 2e-3;
        for (axis, sharpness) in [(asg.x, asg.lx), (asg.y, asg.ly)] {
            let w = (asg.z + axis * step).normalize();
            let curvature = -(ln_d(w) - ln_d(asg.z)) / (w.dot(axis) * w.dot(axis));
            assert!((curvature / sharpness - 1.0).abs() < 0.02, "{view_deg} deg: {curvature} against {sharpness}");
        }
        // The geometric mean is half App. B's SG sharpness.
        let sg = crate::methods::lobe_aware::lobe::specular(GlossyModel::BlinnPhong, m, n, psi, &opts);
        assert!(((asg.lx * asg.ly).sqrt() / (0.5 * sg.sharpness) - 1.0).abs() < 1e-12);
    }
    // Phong: round, half the SG's sharpness.
    let asg = specular(GlossyModel::Phong, 64.0, n, DVec3::new(0.6, 0.0, 0.8), &opts);
    assert_eq!((asg.lx, asg.ly), (32.0, 32.0));
}

#[test]
fn smoothing_convolves_the_variances() {
    let a = Asg::new(DVec3::Z, DVec3::X, 50.0, 5.0);
    assert_eq!(a.smoothed(f64::INFINITY), a);
    let s = a.smoothed(100.0);
    // Variances 1/(2 l) and the kernel's 1/kappa add.
    assert!((1.0 / (2.0 * s.lx) - (1.0 / 100.0 + 1.0 / 100.0)).abs() < 1e-12);
    assert!((1.0 / (2.0 * s.ly) - (1.0 / 10.0 + 1.0 / 100.0)).abs() < 1e-12);
    let huge = Asg::new(DVec3::Z, DVec3::X, 1e300, 1e300).smoothed(100.0);
    assert!((huge.lx - 50.0).abs() < 1e-9, "{}", huge.lx);
}

#[test]
fn weights_are_normalised_symmetric_in_range_and_finite_at_the_extremes() {
    let opts = LobeOptions { max_sharpness: f64::INFINITY, ..LobeOptions::default() };
    let views = [0.0f64, 40.0, 80.0, 89.9];
    let normals = [DVec3::Z, DVec3::new(0.3, 0.0, 1.0).normalize(), DVec3::new(0.0, -0.5, 1.0).normalize()];
    for m in [1e-20, 1.0, 50.0, 1e4, 1e20] {
        let lobes: Vec<Asg> = views
            .iter()
            .flat_map(|v| normals.iter().map(move |&n| (v, n)))
            .map(|(v, n)| {
                let psi = DVec3::new(v.to_radians().sin(), 0.0, v.to_radians().cos());
                specular(GlossyModel::BlinnPhong, m, n, psi, &opts).smoothed(100.0)
            })
            .collect();
        for a in &lobes {
            if let Some(w) = ln_weight(a, a, 20.0) {
                assert!(w.abs() < 1e-9, "w(i, i) = {} at m = {m}", w.exp());
            }
            for b in &lobes {
                let (ab, ba) = (ln_weight(a, b, 20.0), ln_weight(b, a, 20.0));
                match (ab, ba) {
                    (Some(x), Some(y)) => {
                        assert!(x <= 0.0 && !x.is_nan(), "{x} at m = {m}");
                        assert!((x.exp() - y.exp()).abs() < 1e-9, "asymmetric: {x} {y}");
                    }
                    (None, None) => {}
                    _ => panic!("one-sided fallback at m = {m}"),
                }
            }
        }
    }
    // Low-frequency lobes are Eq. 12's.
    let flat = Asg::new(DVec3::Z, DVec3::X, 1.0, 0.5);
    assert_eq!(ln_weight(&flat, &flat, 20.0), None);
}

#[test]
fn round_lobes_weigh_as_eq_12_and_stretched_ones_tell_directions_apart() {
    // Round lobes of SG sharpness 2 nu: Eq. 13 tends to Eq. 12 at small angles.
    let nu = 200.0;
    for deg in [0.5f64, 2.0, 5.0] {
        let axis = DVec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos());
        let (a, b) = (Asg::new(DVec3::Z, DVec3::X, nu, nu), Asg::new(axis, DVec3::Y, nu, nu));
        let asg = ln_weight(&a, &b, 1.0).unwrap();
        let sg = ln_lobe_weight(&Sg::new(DVec3::Z, 2.0 * nu), &Sg::new(axis, 2.0 * nu), 1.0);
        assert!((asg - sg).abs() < 0.02 * sg.abs().max(1e-3), "{deg} deg: {asg} against {sg}");
    }
    // A lobe stretched along y: the same tilt costs less along y than along x, which one SG
    // cannot tell apart.
    let a = Asg::new(DVec3::Z, DVec3::X, 400.0, 25.0);
    let tilted = |dir: DVec3| Asg { z: (DVec3::Z + dir * 0.05).normalize(), ..a };
    let along_y = ln_weight(&a, &Asg::new(tilted(DVec3::Y).z, DVec3::X, 400.0, 25.0), 1.0).unwrap();
    let along_x = ln_weight(&a, &Asg::new(tilted(DVec3::X).z, DVec3::X, 400.0, 25.0), 1.0).unwrap();
    assert!(along_y > along_x + 0.1, "along y {along_y}, along x {along_x}");
}

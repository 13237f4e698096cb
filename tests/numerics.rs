//! Property tests over the core numerics at the extremes of their domains: the AAF sampling-rate
//! and filter-width formulas, the screen-space filter, the light and BRDF radiometry, ray
//! casting, and scene validation. Every result must be finite, non-negative and bounded; bad
//! numbers in a scene must come back as an error naming a field, never as a panic or a NaN image.
use glam::{DVec3, Vec2, Vec3};
use proptest::prelude::*;
use std::sync::Arc;
use wedge::methods::aaf_indirect::params as gi;
use wedge::methods::aaf_shadows::params::{filter_width, sample_count, slope, AafConstants, PixelGeometry};
use wedge::pipeline::frame::Frame;
use wedge::pipeline::job::{CancelToken, Halt, Method, RenderJob};
use wedge::pipeline::progressive::render;
use wedge::proto;
use wedge::render::filter::{separable, FilterOptions, FilterPixel};
use wedge::render::light::{EmissionProfile, RectLight};
use wedge::render::material::{Brdf, GlossyModel};
use wedge::scene::{compile, SceneLimits};

/// The same cases on every run, so CI is reproducible (a new seed explores new cases).
const FIXED_SEED: proptest::test_runner::RngSeed = proptest::test_runner::RngSeed::Fixed(0x5eed_2026);

/// Failing cases are saved here and replayed first on every run: each failure found becomes a
/// regression test.
fn regressions() -> Option<Box<dyn proptest::test_runner::FailurePersistence>> {
    Some(Box::new(proptest::test_runner::FileFailurePersistence::Direct("tests/proptest-regressions/numerics.txt")))
}

/// Positive magnitudes over many decades (and the ends of the range).
fn magnitude(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    prop_oneof![
        1 => Just(lo),
        1 => Just(hi),
        8 => (lo.ln()..hi.ln()).prop_map(f64::exp),
    ]
}

fn unit_vector() -> impl Strategy<Value = Vec3> {
    (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
        .prop_filter("non-zero", |(x, y, z)| x * x + y * y + z * z > 1e-4)
        .prop_map(|(x, y, z)| Vec3::new(x, y, z).normalize())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, failure_persistence: regressions(), rng_seed: FIXED_SEED, ..ProptestConfig::default() })]

    #[test]
    fn aaf_rates_and_widths_are_finite_and_bounded(
        s2 in prop_oneof![Just(0.0), magnitude(1e-9, 1e9)],
        ratio in prop_oneof![Just(1.0), Just(f64::INFINITY), magnitude(1.0, 1e9)],
        sigma in prop_oneof![Just(0.0), magnitude(1e-6, 1e5)],
        d in magnitude(1e-9, 1e5),
        mu in magnitude(1e-3, 1e3),
    ) {
        let g = PixelGeometry { s1: s2 * ratio, s2, sigma, d };
        let c = AafConstants::default();
        let n = sample_count(&g, &c, mu, 9.0);
        prop_assert!(n.is_finite() && n >= 9.0, "{g:?} mu {mu}: n {n}");
        let b = filter_width(&g, &c, mu);
        prop_assert!(b.is_finite() && b >= 0.0, "{g:?} mu {mu}: beta {b}");
        // Doubling mu halves the filter (beta proportional to 1/mu) anywhere in the domain.
        let b2 = filter_width(&g, &c, 2.0 * mu);
        prop_assert!((b2 * 2.0 - b).abs() <= 1e-12 * b.max(1e-300), "{g:?} mu {mu}: {b} then {b2}");
    }

    #[test]
    fn indirect_rates_and_widths_are_finite_and_bounded(
        z_min in prop_oneof![Just(0.0), Just(f64::INFINITY), magnitude(1e-9, 1e9)],
        ratio in prop_oneof![Just(1.0), magnitude(1.0, 1e9)],
        d in prop_oneof![Just(0.0), magnitude(1e-9, 1e5)],
        m in prop_oneof![Just(0.0), Just(1e6), magnitude(1e-6, 1e6)],
        phong in any::<bool>(),
        mu in magnitude(1e-3, 1e3),
    ) {
        // AAF for indirect light (Mehta et al. 2013, Eqs. 15-21) over the whole domain,
        // including glossy exponents up to 1e6 and reflectors at the receiver or at infinity.
        let c = gi::IndirectConstants::default();
        let model = if phong { GlossyModel::Phong } else { GlossyModel::BlinnPhong };
        for (omega_h, gamma) in [(c.omega_h_diffuse, c.gamma_diffuse), (gi::omega_h_glossy(model, m, &c), gi::gamma_glossy(m))] {
            prop_assert!(omega_h.is_finite() && omega_h >= c.omega_h_diffuse && (0.0..=1.0).contains(&gamma));
            let r = gi::Reflectors { z_min, z_max: z_min * ratio, omega_h, d };
            let b = gi::filter_width(&r, &c, mu);
            prop_assert!(b.is_finite() && b >= 0.0, "{r:?} mu {mu}: beta {b}");
            let b2 = gi::filter_width(&r, &c, 2.0 * mu);
            prop_assert!((b2 * 2.0 - b).abs() <= 1e-12 * b.max(1e-300), "{r:?} mu {mu}: {b} then {b2}");
            let n = gi::clamp_samples(gi::sample_count(&r, &c, mu, gamma), &c, mu);
            prop_assert!(n.is_finite() && n >= c.min_samples && n <= (c.max_samples * mu).max(c.min_samples), "{r:?}: {n}");
        }
    }

    #[test]
    fn per_ray_slopes_are_never_negative(t in 0.0f64..1e6, l in 1e-9f64..1e6) {
        let s = slope(t, l);
        prop_assert!(s >= 0.0 && !s.is_nan());
    }

    #[test]
    fn the_filter_is_a_convex_combination(
        seed in any::<u64>(),
        w in 1usize..12,
        h in 1usize..12,
        beta_px in prop_oneof![Just(0.0), magnitude(1e-6, 1e4)],
    ) {
        let mut rng = seed;
        let mut next = || { rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (rng >> 11) as f64 / (1u64 << 53) as f64 };
        let pixels: Vec<FilterPixel> = (0..w * h)
            .map(|i| FilterPixel {
                position: DVec3::new((i % w) as f64, (i / w) as f64, next()) * 0.01,
                normal: if next() < 0.2 { Vec3::X } else { Vec3::Z },
                object: (next() * 3.0) as u32,
                valid: next() < 0.9,
                beta: beta_px * 0.01 * next(),
                d: 0.01,
            })
            .collect();
        let values: Vec<[f64; 3]> = (0..w * h).map(|_| [next(), next() * 10.0, 0.0]).collect();
        let mut out = values.clone();
        let o = FilterOptions { object_id_check: next() < 0.5, tangent_plane: next() < 0.5, ..FilterOptions::default() };
        separable(&pixels, &mut out, w, &o);
        for c in 0..3 {
            let lo = values.iter().map(|v| v[c]).fold(f64::INFINITY, f64::min);
            let hi = values.iter().map(|v| v[c]).fold(f64::NEG_INFINITY, f64::max);
            for v in &out {
                prop_assert!(v[c].is_finite() && v[c] >= lo - 1e-12 && v[c] <= hi + 1e-12);
            }
        }
    }

    #[test]
    fn light_radiometry_is_finite_and_bounded(
        size in magnitude(1e-4, 1e5),
        aspect in magnitude(1e-3, 1e3),
        gaussian in any::<bool>(),
        offset in (-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0),
        distance in prop_oneof![Just(0.0f32), magnitude(1e-6, 1e3).prop_map(|x| x as f32)],
        n in unit_vector(),
        u in (0.0f32..1.0, 0.0f32..1.0),
    ) {
        // A light of edges a x b facing -y; the receiver anywhere around it, at any distance
        // (zero: touching the light's plane).
        let (a, b) = ((size * aspect.sqrt()) as f32, (size / aspect.sqrt()) as f32);
        let profile = if gaussian { EmissionProfile::Gaussian } else { EmissionProfile::Uniform };
        let light = RectLight::new(Vec3::ZERO, Vec3::new(a, 0.0, 0.0), Vec3::new(0.0, 0.0, b), Vec3::ONE, profile);
        let x = Vec3::new(offset.0 * a, -distance * size as f32, offset.2 * b);
        let e = light.unshadowed_irradiance(x, n, n);
        // Irradiance from unit radiance is at most pi (a light filling the hemisphere).
        prop_assert!(e.is_finite() && (0.0..=std::f64::consts::PI * (1.0 + 1e-6)).contains(&e), "E = {e}");
        if let Some(s) = light.sample(x, [u.0, u.1]) {
            prop_assert!(s.weight.is_finite() && s.weight.min_element() >= 0.0);
            prop_assert!(s.dist.is_finite() && s.dist > 0.0);
        }
    }

    #[test]
    fn brdf_sample_weights_are_finite_non_negative_and_bounded(
        kd in 0.0f32..0.5,
        ks in 0.0f32..0.5,
        m in prop_oneof![Just(0.0f32), Just(1e6f32), magnitude(1e-6, 1e6).prop_map(|x| x as f32)],
        blinn in any::<bool>(),
        wo in unit_vector(),
        lobe in 0.0f32..1.0,
        u in (0.0f32..1.0, 0.0f32..1.0),
    ) {
        let model = if blinn { GlossyModel::BlinnPhong } else { GlossyModel::Phong };
        let b = Brdf { kd: Vec3::splat(kd), ks: Vec3::splat(ks), exponent: m, model };
        if let Some(s) = b.sample(wo, Vec3::Z, lobe, [u.0, u.1]) {
            let w = s.f * s.wi.z.max(0.0) / s.pdf;
            // Energy conservation bounds a single weight by (m+2)/(m+1) <= 2 times kd + ks.
            prop_assert!(w.is_finite() && w.min_element() >= 0.0 && w.max_element() <= 2.0 * (kd + ks) + 1e-4, "{w}");
        }
        let f = b.eval(wo, Vec3::new(u.0, u.1, 1.0).normalize(), Vec3::Z);
        prop_assert!(f.is_finite() && f.min_element() >= 0.0);
    }

    #[test]
    fn non_finite_numbers_in_a_scene_are_rejected_naming_a_field(which in 0usize..9, bad in prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY)]) {
        let mut s = small_scene(1.0);
        let cam = s.camera.as_mut().unwrap();
        let set = |v: &mut Option<proto::Vec3>| v.as_mut().unwrap().x = bad;
        let (expected, _) = match which {
            0 => { set(&mut cam.position); ("scene.camera.position.x", ()) }
            1 => { set(&mut cam.look_at); ("scene.camera.look_at.x", ()) }
            2 => { cam.vertical_fov_deg = bad; ("scene.camera.vertical_fov_deg", ()) }
            3 => { rect(&mut s).radiance.as_mut().unwrap().g = bad; ("scene.lights[0].rect.radiance.g", ()) }
            4 => { set(&mut rect(&mut s).edge_u); ("scene.lights[0].rect.edge_u.x", ()) }
            5 => { set(&mut rect(&mut s).corner); ("scene.lights[0].rect.corner.x", ()) }
            6 => {
                if let Some(proto::shape::Geometry::Sphere(sp)) = s.shapes[0].geometry.as_mut() { sp.radius = bad; }
                ("scene.shapes[0].sphere.radius", ())
            }
            7 => {
                s.shapes[0].transform = Some(proto::Transform { rotate_deg: bad, ..Default::default() });
                ("scene.shapes[0].transform.rotate_deg", ())
            }
            _ => {
                s.shapes[0].geometry = Some(proto::shape::Geometry::Mesh(proto::Mesh {
                    positions: vec![0.0, 0.0, 0.0, 1.0, bad, 0.0, 0.0, 1.0, 0.0],
                    indices: vec![0, 1, 2],
                    ..Default::default()
                }));
                ("scene.shapes[0].mesh.positions[4]", ())
            }
        };
        let e = compile(&s, &SceneLimits::default(), None).err();
        prop_assert_eq!(e.map(|e| e.field), Some(expected.to_string()));
    }
}

proptest! {
    // Whole renders are slower: fewer cases.
    #![proptest_config(ProptestConfig { cases: 24, failure_persistence: regressions(), rng_seed: FIXED_SEED, ..ProptestConfig::default() })]

    #[test]
    fn renders_are_finite_at_any_scale_and_from_inside_geometry(
        scale in magnitude(1e-4, 1e5),
        inside in any::<bool>(),
        method in prop_oneof![Just(Method::Uniform), Just(Method::Aaf), Just(Method::Auto)],
    ) {
        let mut s = small_scene(scale as f32);
        if inside {
            // The camera sits inside the sphere.
            let k = scale as f32;
            s.camera.as_mut().unwrap().position = Some(proto::Vec3 { x: 0.1 * k, y: 0.6 * k, z: 0.2 * k });
        }
        let scene = Arc::new(compile(&s, &SceneLimits::default(), None).expect("valid scene"));
        let job = RenderJob { seed: 1, bounces: 2, ..RenderJob::new(scene, method, Halt::passes(2)) };
        let mut last: Option<Frame> = None;
        render(&job, &CancelToken::new(), &mut |f| { last = Some(f.clone()); true }).expect("render");
        let f = last.expect("a frame");
        prop_assert!(f.color.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
        prop_assert!(f.unfiltered_color().iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
        prop_assert!(f.spp.iter().all(|v| v.is_finite() && *v >= 0.0));
    }

    #[test]
    fn near_parallel_and_degenerate_rays_never_panic(
        eps in magnitude(1e-12, 1e-1),
        degenerate in any::<bool>(),
    ) {
        // A ray skimming a triangle's plane, and (optionally) a degenerate triangle on its way.
        let mut b = wedge::render::scene::SceneBuilder::new(wedge::render::scene::CameraDesc {
            position: Vec3::new(-5.0, eps as f32, 0.0),
            look_at: Vec3::new(0.0, 0.0, 0.0),
            up: Vec3::Y,
            vertical_fov_deg: 1.0,
            width: 3,
            height: 3,
        });
        let m = b.add_material(wedge::render::material::Material::Lambertian {
            albedo: wedge::render::texture::Texture::Constant(Vec3::splat(0.5)),
        });
        b.geometry.push([Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 1.0)], None, Some([Vec2::ZERO; 3]), m, 0);
        if degenerate {
            b.geometry.push([Vec3::new(-2.0, 0.0, 0.0), Vec3::new(-2.0, 0.0, 0.0), Vec3::new(-2.0, 1.0, 0.0)], None, None, m, 1);
        }
        b.add_rect_light(RectLight::new(Vec3::new(-0.5, 2.0, -0.5), Vec3::X, Vec3::Z, Vec3::ONE, EmissionProfile::Uniform));
        let scene = b.build();
        let c = &scene.default_view();
        for (px, py) in [(1.5, 1.5), (0.0, 0.0), (3.0, 3.0)] {
            if let Some(h) = scene.intersect(c.position, c.direction(px, py), 0.0) {
                prop_assert!(h.t.is_finite() && h.t >= 0.0 && h.ns.is_finite() && h.p.is_finite());
            }
        }
    }
}

fn rect(s: &mut proto::Scene) -> &mut proto::RectLight {
    match s.lights[0].kind.as_mut() {
        Some(proto::light::Kind::Rect(r)) => r,
        _ => unreachable!("the small scene's first light is a rect"),
    }
}

/// A sphere on a floor under a square light, `scale` times the unit size, 12 x 9 pixels.
fn small_scene(scale: f32) -> proto::Scene {
    let v = |x: f32, y: f32, z: f32| Some(proto::Vec3 { x: x * scale, y: y * scale, z: z * scale });
    let rgb = |r: f32| Some(proto::Rgb { r, g: r, b: r });
    proto::Scene {
        camera: Some(proto::Camera {
            position: v(0.0, 1.5, 4.0),
            look_at: v(0.0, 0.5, 0.0),
            up: None,
            vertical_fov_deg: 45.0,
            width: 12,
            height: 9,
        }),
        materials: vec![proto::Material {
            name: "m".into(),
            kind: Some(proto::material::Kind::Lambertian(proto::Lambertian {
                albedo: Some(proto::ColorTexture {
                    kind: Some(proto::color_texture::Kind::Constant(proto::Rgb { r: 0.7, g: 0.7, b: 0.7 })),
                }),
            })),
        }],
        shapes: vec![
            proto::Shape {
                material: "m".into(),
                geometry: Some(proto::shape::Geometry::Sphere(proto::Sphere {
                    center: v(0.0, 0.5, 0.0),
                    radius: 0.5 * scale,
                    subdivisions: 8,
                })),
                ..Default::default()
            },
            proto::Shape {
                material: "m".into(),
                geometry: Some(proto::shape::Geometry::Quad(proto::Quad {
                    corner: v(-3.0, 0.0, -3.0),
                    edge_u: v(0.0, 0.0, 6.0),
                    edge_v: v(6.0, 0.0, 0.0),
                })),
                ..Default::default()
            },
        ],
        lights: vec![proto::Light {
            kind: Some(proto::light::Kind::Rect(proto::RectLight {
                corner: v(-0.5, 2.5, -0.5),
                edge_u: v(1.0, 0.0, 0.0),
                edge_v: v(0.0, 0.0, 1.0),
                radiance: rgb(5.0),
                profile: 0,
                ..Default::default()
            })),
        }],
        settings: None,
        description: String::new(),
    }
}

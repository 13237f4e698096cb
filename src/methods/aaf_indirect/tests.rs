//! Tests of the indirect strategy on small scenes with fixed seeds (methods.md §2.5).
use super::*;
use crate::pipeline::job::{Halt, Method};
use crate::render::light::polygon_irradiance;
use crate::scene::{compile, json::parse_scene, SceneLimits};
use std::sync::Arc;

fn scene(json: &str) -> Arc<Scene> {
    let s = parse_scene(json, "test").expect("test scene parses");
    Arc::new(compile(&s, &SceneLimits::default(), None).expect("test scene compiles"))
}

/// `passes` passes after the preview (pass 0) for the AAF family, whose `frames` drop it: frame
/// k of these tests is pass k + 1 of the render, the k-th frame of the analysis proper.
fn job(scene: Arc<Scene>, method: Method, passes: u32, seed: u64, bounces: u32) -> RenderJob {
    let halt = Halt::passes(passes + (method != Method::Uniform) as u32);
    RenderJob { seed, bounces, ..RenderJob::new(scene, method, halt) }
}

use super::super::tests::{builtin, frames, rmse};

fn reference(scene: Arc<Scene>, bounces: u32, spp: f64) -> Frame {
    let mut j = job(scene, Method::Uniform, 20, 99, bounces);
    j.halt.max_mean_spp = spp;
    frames(&j).pop().unwrap()
}

fn mean_of(img: &[[f32; 3]], c: usize) -> f64 {
    img.iter().map(|p| p[c] as f64).sum::<f64>() / img.len() as f64
}

/// A closed Lambertian sphere of albedo `a` with a point light at its centre and the camera
/// inside: every wall point gets the same direct radiance L0 = a I / (pi R^2), and each bounce
/// multiplies it by a, so with N bounces L = L0 (1 + a + ... + a^N) -> L0 / (1 - a).
fn furnace(a: f32) -> Arc<Scene> {
    scene(&format!(
        r#"{{"camera": {{"position": {{"x": 0, "y": 0, "z": 0.1}}, "lookAt": {{"x": 0, "y": 0, "z": 1}},
             "up": {{"x": 0, "y": 1, "z": 0}}, "verticalFovDeg": 70, "width": 16, "height": 16}},
           "materials": [{{"name": "wall", "lambertian": {{"albedo": {{"constant": {{"r": {a}, "g": {a}, "b": {a}}}}}}}}}],
           "shapes": [{{"material": "wall", "sphere": {{"center": {{}}, "radius": 1, "subdivisions": 96}}}}],
           "lights": [{{"point": {{"position": {{}}, "intensity": {{"r": 3, "g": 3, "b": 3}}}}}}]}}"#
    ))
}

#[test]
fn white_furnace_converges_to_the_geometric_series() {
    let a = 0.6f64;
    let bounces = 24; // a^25 ~ 3e-6
    let s = furnace(a as f32);
    let l0 = a * 3.0 / std::f64::consts::PI;
    let expected = l0 * (1.0 - a.powi(bounces as i32 + 1)) / (1.0 - a);
    for method in [Method::Aaf, Method::Uniform] {
        let mut j = job(s.clone(), method, 3, 5, bounces);
        j.initial_spp = 32;
        let f = frames(&j).pop().unwrap();
        let m = mean_of(&f.color, 0);
        // The tessellated sphere's faces sit up to 0.03% inside the unit sphere: 1%.
        assert!((m / expected - 1.0).abs() < 0.01, "{method:?}: mean {m} expected {expected}");
        // A constant field stays constant under the filter.
        let spread = f.color.iter().map(|p| (p[0] as f64 - m).abs()).fold(0.0, f64::max);
        if method == Method::Aaf {
            assert!(spread < 0.03 * m, "max deviation {spread} of {m}");
        }
    }
}

#[test]
fn rmse_falls_as_mu_grows_on_the_glossy_cornell_box() {
    let s = builtin("cornell-glossy", 32, 32);
    let reference = reference(s.clone(), 1, 1024.0);
    let f = frames(&job(s, Method::Aaf, 5, 1, 1));
    let names: Vec<&str> = f[0].components.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["diffuse", "glossy"]);
    let e: Vec<f64> = f.iter().map(|fr| rmse(&fr.color, &reference.color)).collect();
    // Frames 0 and 1 share mu0 (the error is the filter's bias, which more samples do not
    // move); from then on each doubling of mu should cut the error at least as much as
    // doubling uniform samples does (1/sqrt 2), here with 0.8 for the reference's own noise,
    // and by (1/sqrt 2)^3 over the three steps.
    for k in 2..5 {
        assert!(e[k] < 0.8 * e[k - 1], "error fell too slowly at pass {k}: {e:?}");
    }
    assert!(e[4] < 0.36 * e[1], "{e:?}");
    // The filter narrows as 1/mu, per component, at every pixel filtered in both passes.
    for c in 0..2 {
        for k in 2..5 {
            let (a, b) = (&f[k - 1].components[c], &f[k].components[c]);
            let pairs = a.filter_width.as_ref().unwrap().iter().zip(b.filter_width.as_ref().unwrap());
            let mut n = 0;
            for (wa, wb) in pairs.filter(|(wa, wb)| **wa > 0.0 && **wb > 0.0) {
                assert!((wb / wa - 0.5).abs() < 1e-4, "component {c} pass {k}: {wa} -> {wb}");
                n += 1;
            }
            assert!(n > 100, "component {c} pass {k}: {n} pixels filtered");
        }
    }
    // Counts stay inside the paper's clamps: at least 16, at most 100 mu (or the floor).
    let opts = IndirectOptions::default();
    for (k, fr) in f.iter().enumerate().skip(1) {
        let mu = opts.mu0 * 2f64.powi(k as i32 - 1);
        let hi = (100.0 * mu).max(16.0 * mu / opts.mu0).ceil();
        for c in &fr.components {
            let (lo, top) = c.spp.iter().fold((f32::MAX, 0.0f32), |(a, b), &x| (a.min(x), b.max(x)));
            assert!(lo >= 16.0 && top as f64 <= hi, "pass {k} {}: {lo}..{top} (cap {hi})", c.name);
        }
    }
}

#[test]
fn the_filtered_stream_converges_to_the_per_pixel_mean() {
    let s = builtin("interior", 12, 9);
    let mut j = job(s, Method::Aaf, 7, 3, 1);
    j.indirect.initial_samples = 4;
    j.indirect.constants.min_samples = 4.0;
    j.indirect.constants.max_samples = 0.5; // keep mu = 28.8 affordable in a debug build
    let last = frames(&j).pop().unwrap();
    let widths = last.filter_width.as_ref().unwrap();
    assert!(widths.iter().all(|&w| w <= 0.3), "max width {}", widths.iter().cloned().fold(0.0, f32::max));
    let unfiltered = last.unfiltered.as_ref().unwrap();
    let e = rmse(&last.color, unfiltered);
    let scale = mean_of(&last.color, 0);
    assert!(e < 0.01 * scale, "rmse {e} vs mean {scale}");
}

#[test]
fn shadows_and_indirect_light_add_up_to_the_uniform_image() {
    // The Cornell box has an area light: AAF runs the soft-shadow part and the indirect part
    // side by side; their sum must carry the same energy as plain path tracing.
    let s = builtin("cornell", 24, 24);
    let reference = reference(s.clone(), 1, 512.0);
    let f = frames(&job(s, Method::Aaf, 4, 2, 1)).pop().unwrap();
    let names: Vec<&str> = f.components.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["shadow", "diffuse"]);
    for c in 0..3 {
        let (a, b) = (mean_of(&f.unfiltered.clone().unwrap(), c), mean_of(&reference.color, c));
        assert!((a / b - 1.0).abs() < 0.02, "channel {c}: {a} vs {b}");
    }
    // Total samples: the shadow part's plus the indirect part's camera samples.
    for p in 0..f.spp.len() {
        assert!(f.components.iter().all(|c| c.spp[p] <= f.spp[p]), "pixel {p}");
    }
}

/// A floor with a wall standing on it at x = 1 (height 1, from z = -3 to 3), seen from above.
fn floor_and_wall() -> Arc<Scene> {
    scene(
        r#"{"camera": {"position": {"x": 0, "y": 3, "z": 0.01}, "lookAt": {"x": 0, "y": 0, "z": 0},
             "up": {"x": 0, "y": 0, "z": -1}, "verticalFovDeg": 40, "width": 16, "height": 16},
           "materials": [{"name": "m", "lambertian": {"albedo": {"constant": {"r": 0.5, "g": 0.5, "b": 0.5}}}}],
           "shapes": [{"material": "m", "quad": {"corner": {"x": -3, "z": -3}, "edgeU": {"z": 6}, "edgeV": {"x": 4}}},
                      {"material": "m", "quad": {"corner": {"x": 1, "z": -3}, "edgeU": {"y": 1}, "edgeV": {"z": 6}}}]}"#,
    )
}

#[test]
fn ambient_occlusion_matches_the_closed_form_next_to_a_wall() {
    let s = floor_and_wall();
    let k = s.world_scale;
    let wall =
        [Vec3::new(1.0, 0.0, -3.0), Vec3::new(1.0, 1.0, -3.0), Vec3::new(1.0, 1.0, 3.0), Vec3::new(1.0, 0.0, 3.0)]
            // The internal frame centres the bounds (-3, 0, -3)..(1, 1, 3) at the origin.
            .map(|p| (p - Vec3::new(-1.0, 0.5, 0.0)) * k);
    let g = GBuffer::build(&s, &s.default_view());
    // Open fraction = 1 - (cosine-weighted solid angle of the wall) / pi.
    let exact: Vec<Option<f64>> = g
        .pixels
        .iter()
        .map(|p| {
            (p.is_valid() && p.normal.y > 0.99)
                .then(|| 1.0 - polygon_irradiance(p.position, p.normal, &wall) / std::f64::consts::PI)
        })
        .collect();
    let error = |f: &Frame| {
        let (mut se, mut n) = (0.0, 0);
        for (p, e) in exact.iter().enumerate() {
            if let Some(e) = e {
                se += (f.color[p][0] as f64 - e).powi(2);
                n += 1;
            }
        }
        (se / n as f64).sqrt()
    };
    let ao = Integrand::AmbientOcclusion { max_distance: f32::INFINITY };
    let mut u = job(s.clone(), Method::Uniform, 20, 4, 0);
    (u.integrand, u.halt.max_mean_spp) = (ao, 4096.0);
    let uniform = frames(&u).pop().unwrap();
    assert!(error(&uniform) < 0.01, "uniform AO error {}", error(&uniform));
    let mut j = job(s, Method::Aaf, 6, 4, 0);
    j.integrand = ao;
    let f = frames(&j);
    assert_eq!(f[0].components.len(), 1);
    let e: Vec<f64> = f.iter().map(error).collect();
    assert!(e[5] < 0.5 * e[0] && e[5] < 0.03, "{e:?}");
    for fr in &f {
        assert!(fr.color.iter().flatten().all(|v| (0.0..=1.0 + 1e-6).contains(v)));
    }
    // A distance limit shorter than any reflector leaves everything open.
    let mut j = job(floor_and_wall(), Method::Aaf, 2, 4, 0);
    j.integrand = Integrand::AmbientOcclusion { max_distance: 1e-3 };
    let f = frames(&j).pop().unwrap();
    let g = GBuffer::build(&j.scene, &j.view);
    for (p, c) in f.color.iter().enumerate() {
        if g.pixels[p].is_valid() && g.pixels[p].position.x < 0.0 {
            assert!((c[0] - 1.0).abs() < 1e-6, "pixel {p}: {}", c[0]);
        }
    }
}

#[test]
fn pixels_whose_rays_all_miss_are_left_unfiltered() {
    // A lone floor under a point light: no reflector anywhere, so no indirect light, no
    // filter, and the AAF image equals the direct light alone.
    let s = scene(
        r#"{"camera": {"position": {"y": 3}, "lookAt": {}, "up": {"z": -1}, "verticalFovDeg": 40, "width": 12, "height": 12},
           "materials": [{"name": "m", "lambertian": {"albedo": {"constant": {"r": 0.5, "g": 0.5, "b": 0.5}}}}],
           "shapes": [{"material": "m", "quad": {"corner": {"x": -3, "z": -3}, "edgeU": {"z": 6}, "edgeV": {"x": 6}}}],
           "lights": [{"point": {"position": {"y": 2}, "intensity": {"r": 1, "g": 1, "b": 1}}}]}"#,
    );
    let f = frames(&job(s.clone(), Method::Aaf, 3, 1, 2));
    let direct = frames(&job(s, Method::Uniform, 1, 1, 0)).pop().unwrap();
    for fr in &f {
        let d = &fr.components[0];
        assert!(d.filter_width.as_ref().unwrap().iter().all(|&w| w == 0.0));
        assert!(d.spp.iter().all(|&n| n >= 16.0));
        assert_eq!(fr.color, *fr.unfiltered.as_ref().unwrap());
    }
    // Direct light of a point light is exact per camera sample: only antialiasing differs.
    assert!(rmse(&f[2].color, &direct.color) < 1e-3 * mean_of(&direct.color, 0).max(1e-3) + 1e-3);
}

#[test]
fn extreme_exponents_corners_and_grazing_views_stay_finite() {
    for (m, cam_y) in [(0.0, 1.5), (1e6, 1.5), (16.0, 0.02)] {
        let s = scene(&format!(
            r#"{{"camera": {{"position": {{"x": -2.9, "y": {cam_y}, "z": -2.9}}, "lookAt": {{"x": 3, "y": 0, "z": 3}},
                 "up": {{"y": 1}}, "verticalFovDeg": 60, "width": 12, "height": 10}},
               "materials": [{{"name": "g", "glossy": {{"diffuse": {{"constant": {{"r": 0.3, "g": 0.3, "b": 0.3}}}},
                   "specular": {{"constant": {{"r": 0.6, "g": 0.6, "b": 0.6}}}}, "exponent": {{"constant": {m}}}}}}}],
               "shapes": [{{"material": "g", "box": {{"min": {{"x": -3, "y": 0, "z": -3}}, "max": {{"x": 3, "y": 2, "z": 3}}}}}}],
               "lights": [{{"point": {{"position": {{"x": 0, "y": 1.5, "z": 0}}, "intensity": {{"r": 2, "g": 2, "b": 2}}}}}}]}}"#
        ));
        // Inside a closed box: corners everywhere (z_min -> 0, clamped to 2% of the scene).
        let f = frames(&job(s, Method::Aaf, 3, 7, 2));
        for fr in &f {
            assert!(fr.color.iter().flatten().all(|v| v.is_finite() && *v >= 0.0), "m={m}");
            for c in &fr.components {
                assert!(c.filter_width.as_ref().unwrap().iter().all(|w| w.is_finite() && *w >= 0.0));
                assert!(c.spp.iter().all(|&n| n.is_finite() && n <= 1000.0));
            }
        }
        assert!(mean_of(&f[2].color, 0) > 0.0);
    }
}

#[test]
fn pixel_centres_converge_to_the_pixel_centre_image() {
    let s = builtin("interior", 24, 18);
    let mut r = job(s.clone(), Method::Uniform, 20, 99, 1);
    (r.halt.max_mean_spp, r.pixel_centers) = (1024.0, true);
    let reference = frames(&r).pop().unwrap();
    let mut j = job(s, Method::Aaf, 4, 1, 1);
    j.pixel_centers = true;
    let f = frames(&j);
    let e: Vec<f64> = f.iter().map(|fr| rmse(&fr.color, &reference.color)).collect();
    assert!(e[3] < 0.7 * e[1] && e[3] < e[2], "{e:?}");
}

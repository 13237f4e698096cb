//! Tests of the AAF strategy on small scenes with fixed seeds.
use super::*;
use crate::pipeline::frame::Frame;
use crate::pipeline::job::StopCheck;
use crate::pipeline::job::{CancelToken, Halt, Method};
use crate::pipeline::progressive::render;
use crate::render::scene::{CameraDesc, SceneBuilder};
use crate::render::texture::Texture;
use glam::Vec2;
use std::sync::Arc;

/// A floor, a box hovering over it (or touching it) and one or two square lights, all scaled
/// by `scale` (lengths only; radiometry is scale-free).
fn shadow_scene(w: u32, h: u32, scale: f32, profile: EmissionProfile, lights: usize, gap: f32) -> Arc<Scene> {
    let s = |v: Vec3| v * scale;
    let mut b = SceneBuilder::new(CameraDesc {
        position: s(Vec3::new(0.3, 3.0, 3.2)),
        look_at: s(Vec3::new(0.0, 0.0, 0.1)),
        up: Vec3::Y,
        vertical_fov_deg: 45.0,
        width: w,
        height: h,
    });
    let white = b.add_material(Material::Lambertian {
        albedo: Texture::Checker { even: Vec3::splat(0.8), odd: Vec3::splat(0.5), scale: 4.0 },
    });
    let floor = b.new_object();
    let (c, u, v) = (s(Vec3::new(-3.0, 0.0, -3.0)), s(Vec3::new(0.0, 0.0, 6.0)), s(Vec3::new(6.0, 0.0, 0.0)));
    b.geometry.push([c, c + u, c + u + v], None, Some([Vec2::ZERO, Vec2::Y, Vec2::ONE]), white, floor);
    b.geometry.push([c, c + u + v, c + v], None, Some([Vec2::ZERO, Vec2::ONE, Vec2::X]), white, floor);
    // A flat box (two quads, top and bottom) of half-size 0.4 at height `gap`.
    let boxo = b.new_object();
    for y in [gap, gap + 0.05] {
        let (c, u, v) = (s(Vec3::new(-0.4, y, -0.4)), s(Vec3::new(0.8, 0.0, 0.0)), s(Vec3::new(0.0, 0.0, 0.8)));
        b.geometry.push([c, c + u, c + u + v], None, None, white, boxo);
        b.geometry.push([c, c + u + v, c + v], None, None, white, boxo);
    }
    for k in 0..lights {
        let x = if lights == 1 { -0.4 } else { -1.2 + 1.2 * k as f32 };
        b.add_rect_light(RectLight::new(
            s(Vec3::new(x, 2.0, -0.4)),
            s(Vec3::new(0.8, 0.0, 0.0)),
            s(Vec3::new(0.0, 0.0, 0.8)),
            Vec3::splat(6.0),
            profile,
        ));
    }
    Arc::new(b.build())
}

/// `passes` passes after the preview (pass 0) for the AAF family, whose `frames` drop it: frame
/// k of these tests is pass k + 1 of the render, the k-th frame of the analysis proper.
fn job(scene: Arc<Scene>, method: Method, passes: u32, seed: u64) -> RenderJob {
    RenderJob { seed, ..RenderJob::new(scene, method, Halt::passes(passes + (method != Method::Uniform) as u32)) }
}

use super::super::tests::{frames, rmse};

#[test]
fn rmse_against_the_ground_truth_falls_as_mu_grows() {
    let scene = shadow_scene(32, 24, 1.0, EmissionProfile::Gaussian, 1, 0.6);
    // Ground truth: plain Monte Carlo at 2048 spp with another seed.
    let mut rj = job(scene.clone(), Method::Uniform, 12, 99);
    rj.halt.max_mean_spp = 2048.0;
    let reference = frames(&rj).pop().unwrap();
    // Passes 0..=4 run mu = 1 (the sparse samples filtered), 2, 4, 8, 16.
    let f = frames(&job(scene, Method::Aaf, 5, 1));
    let e: Vec<f64> = f.iter().map(|fr| rmse(&fr.color, &reference.color)).collect();
    // Eq. 21's count grows as mu^2 where the penumbra sets it, so each doubling of mu should
    // cut the error at least as much as doubling uniform samples does (1/sqrt 2), here with
    // 0.8 for the reference's own noise, and by (1/sqrt 2)^3 over the three steps.
    for k in 2..5 {
        assert!(e[k] < 0.8 * e[k - 1], "error fell too slowly from mu={} to mu={}: {e:?}", 1 << (k - 2), 1 << (k - 1));
    }
    assert!(e[4] < 0.36 * e[1], "{e:?}");
    // The filter narrows: mean width in pixels halves with each doubling of mu.
    let mean_width = |fr: &Frame| {
        let w = fr.filter_width.as_ref().unwrap();
        w.iter().map(|&x| x as f64).sum::<f64>() / w.len() as f64
    };
    for k in 1..5 {
        let r = mean_width(&f[k]) / mean_width(&f[k - 1]);
        assert!((r - 0.5).abs() < 1e-3, "pass {k}: ratio {r}");
    }
    // Samples grow with mu and are spent where the shadow is.
    assert!(f.windows(2).all(|p| p[1].stats.mean_spp >= p[0].stats.mean_spp));
    let spp = &f[3].spp;
    assert!(spp.iter().cloned().fold(0.0, f32::max) > 4.0 * spp.iter().cloned().fold(f32::MAX, f32::min));
}

#[test]
fn a_cut_off_gaussian_light_is_filtered_by_the_spread_it_emits() {
    // The test scene's lights span +-1 sigma (sigma = sqrt(area)/2), and emit with a standard
    // deviation of 0.54 sigma. Eq. 13's beta = max(sigma s2, (1 + s2) d) / (k mu) takes that
    // spread by default: each pixel's width is between 0.54 times the profile-sigma width
    // (where sigma s2 is the larger term) and the same (where the pixel term is). The box is
    // high (s2 about 1.5) so that the sigma term sets many widths.
    let scene = shadow_scene(48, 36, 1.0, EmissionProfile::Gaussian, 1, 1.2);
    let Light::Rect(light) = &scene.lights[0] else { panic!("a rectangle light") };
    let ratio = (light.emission_std() / light.sigma()) as f64;
    assert!((ratio - 0.5396).abs() < 1e-3, "{ratio}");
    let widths = |sigma: LightSigma| {
        let mut j = job(scene.clone(), Method::Aaf, 2, 5);
        j.aaf.light_sigma = sigma;
        frames(&j).pop().unwrap().filter_width.unwrap()
    };
    let (emitted, profile) = (widths(LightSigma::Emitted), widths(LightSigma::Profile));
    let mut at_ratio = 0;
    for (&e, &p) in emitted.iter().zip(&profile) {
        assert_eq!(e == 0.0, p == 0.0, "the same pixels are filtered");
        if p > 0.0 {
            let r = (e / p) as f64;
            assert!(r > ratio - 1e-5 && r < 1.0 + 1e-5, "width ratio {r}");
            at_ratio += ((r - ratio).abs() < 1e-4) as usize;
        }
    }
    assert!(at_ratio > 10, "{at_ratio} pixels where sigma s2 sets the width");
    // A uniform light keeps the paper's treatment (sigma = sqrt(area)/2, mu times 1.5): the
    // option changes nothing.
    let uniform = shadow_scene(24, 18, 1.0, EmissionProfile::Uniform, 1, 0.6);
    let colour = |sigma: LightSigma| {
        let mut j = job(uniform.clone(), Method::Aaf, 2, 5);
        j.aaf.light_sigma = sigma;
        frames(&j).pop().unwrap().color
    };
    assert_eq!(colour(LightSigma::Emitted), colour(LightSigma::Profile));
}

#[test]
fn the_filtered_stream_converges_to_the_per_pixel_mean() {
    let scene = shadow_scene(20, 16, 1.0, EmissionProfile::Uniform, 1, 0.6);
    let mut j = job(scene, Method::Aaf, 9, 3);
    j.aaf.cap = 4.0; // keep the sample counts of mu = 128 small for a debug build
    let last = frames(&j).pop().unwrap();
    let widths = last.filter_width.as_ref().unwrap();
    assert!(widths.iter().all(|&w| w <= 0.3), "max width {}", widths.iter().cloned().fold(0.0, f32::max));
    let unfiltered = last.unfiltered.as_ref().unwrap();
    // Neighbour weights below exp(-1/(2 * 0.09)) ~ 0.4%: the filter is nearly the identity.
    let e = rmse(&last.color, unfiltered);
    let scale = last.color.iter().map(|c| c[0] as f64).sum::<f64>() / last.color.len() as f64;
    assert!(e < 0.01 * scale, "rmse {e} vs mean {scale}");
}

#[test]
fn fully_lit_pixels_are_left_unfiltered() {
    // No occluder near the light's path: every pixel is fully lit, its visibility is exactly 1,
    // no pixel gets a filter width, and the output equals the unfiltered estimate.
    let scene = shadow_scene(16, 12, 1.0, EmissionProfile::Gaussian, 1, -5.0);
    for fr in frames(&job(scene, Method::Aaf, 3, 5)) {
        let u = fr.unfiltered.as_ref().unwrap();
        for (a, b) in fr.color.iter().zip(u) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-6 * b[c].abs().max(1e-3), "{a:?} vs {b:?}");
            }
        }
        assert!(fr.filter_width.as_ref().unwrap().iter().all(|&w| w == 0.0));
    }
}

#[test]
fn each_light_has_its_own_counts_and_they_add_up() {
    let one = frames(&job(shadow_scene(12, 10, 1.0, EmissionProfile::Gaussian, 1, 0.6), Method::Aaf, 1, 2));
    let two = frames(&job(shadow_scene(12, 10, 1.0, EmissionProfile::Gaussian, 2, 0.6), Method::Aaf, 1, 2));
    // Pass 0 is the sparse pass: 9 per light where the pixel sees the floor or the box.
    assert!(one[0].spp.iter().all(|&s| s == 9.0));
    assert!(two[0].spp.iter().all(|&s| s == 18.0));
    // After the sparse passes, each light gets the count its own penumbra asks for: the two
    // lights' counts differ at some pixels, and the frame's spp is their sum at every pixel.
    let j = job(shadow_scene(24, 18, 1.0, EmissionProfile::Gaussian, 2, 0.6), Method::Aaf, 3, 2);
    let mut st = ShadowStrategy::new(&j, FilterMode::Aaf);
    assert_eq!(st.lights.len(), 2);
    let stop = StopCheck::cancel_only(&CancelToken::new());
    let g = Arc::new(GBuffer::build(&j.scene, &j.view));
    let mut last = None;
    for pass in 0..4 {
        let ctx = PassContext { scene: &j.scene, job: &j, view: &j.view, pass, stop: &stop, gbuffer: Some(&g) };
        st.sample(&ctx).expect("pass");
        last = Some(Strategy::frame(&mut st, &ctx).expect("frame"));
    }
    let frame = last.unwrap();
    let shadow = &frame.components[0];
    let mut differ = 0;
    for p in 0..frame.spp.len() {
        let (a, b) = (st.sums[2 * p].n, st.sums[2 * p + 1].n);
        assert_eq!(shadow.spp[p], (a + b) as f32, "pixel {p}");
        differ += (a != b) as usize;
    }
    assert!(differ > 10, "the lights' counts differ at only {differ} pixels");
}

#[test]
fn images_do_not_depend_on_the_scene_scale() {
    let run = |scale| {
        frames(&job(shadow_scene(16, 12, scale, EmissionProfile::Uniform, 1, 0.5), Method::Aaf, 3, 8)).pop().unwrap()
    };
    let (small, unit, big) = (run(1e-3), run(1.0), run(1e4));
    for other in [&small, &big] {
        let e = rmse(&other.color, &unit.color);
        assert!(e < 1e-3, "rmse {e} between scales");
        assert!(other.color.iter().flatten().all(|v| v.is_finite()));
    }
}

#[test]
fn contact_shadows_and_grazing_views_stay_finite() {
    // The box touches the floor (s2 -> 0 at the contact), and a camera skimming the floor.
    let scene = shadow_scene(24, 8, 1.0, EmissionProfile::Gaussian, 1, 0.0);
    for fr in frames(&job(scene, Method::Aaf, 4, 4)) {
        assert!(fr.color.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
        assert!(fr.spp.iter().all(|s| s.is_finite() && *s >= 9.0));
        assert!(fr.filter_width.as_ref().unwrap().iter().all(|w| w.is_finite() && *w >= 0.0));
    }
    let mut b = SceneBuilder::new(CameraDesc {
        position: Vec3::new(0.0, 0.01, 5.0),
        look_at: Vec3::new(0.0, 0.0, 0.0),
        up: Vec3::Y,
        vertical_fov_deg: 30.0,
        width: 16,
        height: 8,
    });
    let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.5)) });
    let (c, u, v) = (Vec3::new(-20.0, 0.0, -20.0), Vec3::new(0.0, 0.0, 40.0), Vec3::new(40.0, 0.0, 0.0));
    b.geometry.push([c, c + u, c + u + v], None, None, m, 0);
    b.geometry.push([c, c + u + v, c + v], None, None, m, 0);
    b.geometry.push([Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)], None, None, m, 1);
    b.add_rect_light(RectLight::new(Vec3::new(-0.5, 2.0, -0.5), Vec3::X, Vec3::Z, Vec3::ONE, EmissionProfile::Uniform));
    for fr in frames(&job(Arc::new(b.build()), Method::Aaf, 3, 1)) {
        assert!(fr.color.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    }
}

#[test]
fn baselines_use_the_same_interface() {
    let scene = shadow_scene(16, 12, 1.0, EmissionProfile::Gaussian, 1, 0.6);
    // adaptive: AAF's counts, no filter.
    let a = frames(&job(scene.clone(), Method::Adaptive, 3, 1));
    let f = frames(&job(scene.clone(), Method::Aaf, 3, 1));
    assert!(a.iter().all(|fr| fr.filter_width.is_none() && fr.unfiltered.is_none()));
    assert_eq!(a[2].spp, f[2].spp, "adaptive samples exactly as aaf does");
    assert_eq!(&a[2].color, f[2].unfiltered.as_ref().unwrap(), "and its image is aaf's unfiltered one");
    // uniform-filtered: 9 * 2^k everywhere and a fixed 2-pixel filter where there is light.
    let u = frames(&job(scene, Method::UniformFiltered, 3, 1));
    for (k, fr) in u.iter().enumerate() {
        assert!(fr.spp.iter().all(|&s| s == (9 << k) as f32), "pass {k}");
        let w = fr.filter_width.as_ref().unwrap();
        assert!(w.iter().all(|&x| x == 0.0 || (x - 2.0).abs() < 1e-5));
        assert!(w.iter().filter(|&&x| x > 0.0).count() > w.len() / 2);
    }
}

#[test]
fn scenes_without_area_lights_render_as_uniform() {
    let mut b = SceneBuilder::new(CameraDesc {
        position: Vec3::new(0.0, 2.0, 2.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vertical_fov_deg: 40.0,
        width: 8,
        height: 6,
    });
    let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.5)) });
    b.geometry.push(
        [Vec3::new(-2.0, 0.0, -2.0), Vec3::new(2.0, 0.0, -2.0), Vec3::new(0.0, 0.0, 2.0)],
        None,
        None,
        m,
        0,
    );
    b.lights.push(Light::Point(crate::render::light::PointLight { position: Vec3::Y, intensity: Vec3::ONE }));
    let scene = Arc::new(b.build());
    // With no part to analyse there is no preview either: the same passes as `uniform`.
    let mut a = Vec::new();
    render(&job(scene.clone(), Method::Aaf, 1, 1), &CancelToken::new(), &mut |f| {
        a.push(f.clone());
        true
    })
    .expect("render");
    let u = frames(&job(scene, Method::Uniform, 2, 1));
    assert_eq!(a.len(), 2);
    assert_eq!(a[1].color, u[1].color);
}

#[test]
fn smooth_shaded_silhouettes_converge_to_the_ground_truth() {
    // The arch of `curved` has interpolated normals: near its silhouette the shading normal
    // faces away from the viewer or its horizon cuts the light, where the path tracer's BRDF
    // gives nothing. The exact unshadowed term must follow the same rules, or those pixels
    // come out ~7% too bright however many samples are taken.
    let mut s = crate::scene::builtin::get("curved").unwrap();
    if let Some(c) = s.camera.as_mut() {
        (c.width, c.height) = (48, 36);
    }
    let scene = Arc::new(crate::scene::compile(&s, &crate::scene::SceneLimits::default(), None).unwrap());
    let mut rj = job(scene.clone(), Method::Uniform, 20, 99);
    rj.halt.max_mean_spp = 1024.0;
    let reference = frames(&rj).pop().unwrap();
    let adaptive = frames(&job(scene.clone(), Method::Adaptive, 5, 1)).pop().unwrap();
    let g = GBuffer::build(&scene, &scene.default_view());
    let arch = g.pixels.iter().map(|p| p.object).max().unwrap_or(0);
    let (mut se, mut bias, mut n) = (0.0f64, 0.0f64, 0);
    for (i, p) in g.pixels.iter().enumerate() {
        if p.object == arch {
            let d = (adaptive.color[i][0] - reference.color[i][0]) as f64;
            se += d * d;
            bias += d / reference.color[i][0].max(1e-3) as f64;
            n += 1;
        }
    }
    assert!(n > 20, "only {n} arch pixels");
    let (rms, mean_rel) = ((se / n as f64).sqrt(), bias / n as f64);
    assert!(mean_rel.abs() < 0.02, "mean relative error on the arch {mean_rel:+.4} (rms {rms:.4})");
}

#[test]
fn pixel_centres_converge_to_the_pixel_centre_image() {
    // Shading pixel centres (the paper's setting): one camera ray per pixel and pass, r
    // computed once per pixel, and the stream converges to the pixel-centre ground truth.
    let scene = shadow_scene(32, 24, 1.0, EmissionProfile::Gaussian, 1, 0.6);
    let mut rj = job(scene.clone(), Method::Uniform, 12, 99);
    (rj.halt.max_mean_spp, rj.pixel_centers) = (2048.0, true);
    let reference = frames(&rj).pop().unwrap();
    let mut j = job(scene.clone(), Method::Aaf, 5, 1);
    j.pixel_centers = true;
    let f = frames(&j);
    let e: Vec<f64> = f.iter().map(|fr| rmse(&fr.color, &reference.color)).collect();
    assert!(e[4] < 0.5 * e[1], "{e:?}");
    // The jittered stream converges elsewhere: its error against this reference stalls.
    let jittered = frames(&job(scene, Method::Aaf, 5, 1)).pop().unwrap();
    assert!(rmse(&jittered.color, &reference.color) > 1.5 * e[4], "{e:?}");
    // Fewer rays: one camera ray per pixel and pass instead of one per sample.
    let per_sample = |fr: &Frame| fr.stats.rays_traced as f64 / (fr.stats.mean_spp * fr.spp.len() as f64);
    assert!(per_sample(&f[4]) < per_sample(&jittered) - 0.5, "{} vs {}", per_sample(&f[4]), per_sample(&jittered));
}

#[test]
fn slope_queries_cost_no_extra_rays() {
    // Pass 0 draws the same 9 samples per pixel in both modes; only AAF needs the occluder
    // slopes, and it gets both ends of the occluded range from the shadow ray's own traversal
    // (the fixed filter baseline runs a plain any-hit query instead).
    let scene = shadow_scene(24, 18, 1.0, EmissionProfile::Gaussian, 1, 0.6);
    let first = |m| frames(&job(scene.clone(), m, 1, 4)).pop().unwrap();
    let (aaf, fixed) = (first(Method::Aaf), first(Method::UniformFiltered));
    assert_eq!(aaf.stats.mean_spp, fixed.stats.mean_spp);
    assert_eq!(fixed.stats.rays_traced, aaf.stats.rays_traced);
    // Its unfiltered estimate is the same Monte Carlo mean.
    assert_eq!(aaf.unfiltered, fixed.unfiltered);
}

#[test]
fn pixels_outside_every_penumbra_get_the_growing_floor() {
    // mu0 = 2: pass 1 is the paper's mu = 2 with its 9 samples outside penumbrae; later passes
    // double mu. Jittered samples antialias r(x), so the floor grows like mu (9, 18, 36); at
    // pixel centres only an undetected penumbra needs it, and it grows like sqrt(mu).
    let scene = shadow_scene(24, 18, 1.0, EmissionProfile::Gaussian, 1, 0.6);
    for (centres, want) in [(false, [9.0, 9.0, 18.0, 36.0]), (true, [9.0, 9.0, 13.0, 18.0])] {
        let mut j = job(scene.clone(), Method::Aaf, 4, 3);
        j.pixel_centers = centres;
        let got: Vec<f32> =
            frames(&j).iter().map(|f| f.components[0].spp.iter().copied().fold(f32::INFINITY, f32::min)).collect();
        assert_eq!(got, want, "pixel centres: {centres}");
    }
}

#[test]
fn variance_of_mean_matches_the_textbook_formula() {
    // Values 1, 2, 3, 4: sample variance 5/3, variance of the mean 5/12.
    assert!((variance_of_mean(10.0, 30.0, 4) - 5.0 / 12.0).abs() < 1e-12);
    assert_eq!(variance_of_mean(3.0, 9.0, 1), 0.0);
    // Rounding never makes it negative.
    assert_eq!(variance_of_mean(0.3, 0.03, 3), 0.0);
}

#[test]
fn jittered_pixels_on_edges_get_antialiasing_samples() {
    // The checker floor's edges spread r(x) over a pixel: with jittered samples those pixels
    // take more than the floor count, and only them; at pixel centres, or with the option
    // off, nothing does.
    let scene = shadow_scene(32, 24, 1.0, EmissionProfile::Gaussian, 1, 0.6);
    let run = |centres: bool, error: f64| {
        let mut j = job(scene.clone(), Method::Adaptive, 2, 5);
        j.pixel_centers = centres;
        j.aaf.antialias_error = error;
        frames(&j).pop().unwrap()
    };
    let above_floor = |f: &Frame| f.components[0].spp.iter().filter(|&&s| s > 9.0).count();
    // The checker's two albedos are close (0.8 and 0.5): a tight tolerance makes its edges count.
    assert_eq!(run(true, 0.03).spp, run(true, 0.0).spp, "pixel centres ask for no antialiasing samples");
    let (off, on) = (run(false, 0.0), run(false, 0.03));
    let (n_off, n_on) = (above_floor(&off), above_floor(&on));
    assert!(n_on > n_off + 10, "{n_on} pixels above the floor with antialiasing, {n_off} without");
    assert!(n_on < off.components[0].spp.len() / 2, "antialiasing samples went to {n_on} pixels");
    // And they pay: the error against a dense render of the same method falls.
    let mut dense = job(scene.clone(), Method::Adaptive, 5, 9);
    dense.aaf.antialias_error = 0.0;
    let truth = frames(&dense).pop().unwrap();
    assert!(rmse(&on.color, &truth.color) < rmse(&off.color, &truth.color));
}

#[test]
fn jittered_samples_compute_r_only_up_to_the_antialiasing_count() {
    // Penumbra pixels take Eq. 21's many samples, but r(x) is exact at each one: only the
    // first (floor or antialiasing) count computes it; at pixel centres every sample has it.
    let scene = shadow_scene(24, 18, 1.0, EmissionProfile::Gaussian, 1, 0.6);
    for centres in [false, true] {
        let mut j = job(scene.clone(), Method::Aaf, 3, 2);
        j.pixel_centers = centres;
        let mut st = ShadowStrategy::new(&j, FilterMode::Aaf);
        let stop = StopCheck::cancel_only(&CancelToken::new());
        let g = Arc::new(GBuffer::build(&j.scene, &j.view));
        for pass in 0..4 {
            st.sample(&PassContext { scene: &j.scene, job: &j, view: &j.view, pass, stop: &stop, gbuffer: Some(&g) })
                .expect("pass");
        }
        let floor = st.floor(3);
        let beyond = st.sums.iter().filter(|s| s.n > floor).count();
        assert!(beyond > 10, "only {beyond} pixels above the floor");
        for s in &st.sums {
            assert!(s.r_n <= s.n);
            if centres {
                assert_eq!(s.r_n, s.n);
            } else if s.r_n < s.n {
                assert!(s.r_n >= floor, "{} r samples under the floor {floor}", s.r_n);
            }
        }
        assert_eq!(centres, st.sums.iter().all(|s| s.r_n == s.n), "pixel centres: {centres}");
    }
}

#[test]
fn the_fill_averages_the_occluded_pixels_within_its_radius() {
    // Brute force over the disc of every pixel, per light: own slopes where a sparse ray saw
    // an occluder, else the mean of the occluded pixels within fill_radius, else none. Two
    // lights, and an image taller than a band of the fill's parallel loop (32 rows), so
    // that the band edges and the interleaving of lights are both exercised.
    let scene = shadow_scene(40, 70, 1.0, EmissionProfile::Gaussian, 2, 0.6);
    let j = job(scene, Method::Aaf, 1, 5);
    let mut st = ShadowStrategy::new(&j, FilterMode::Aaf);
    let stop = StopCheck::cancel_only(&CancelToken::new());
    let g = Arc::new(GBuffer::build(&j.scene, &j.view));
    for pass in 0..2 {
        st.sample(&PassContext { scene: &j.scene, job: &j, view: &j.view, pass, stop: &stop, gbuffer: Some(&g) })
            .expect("pass");
    }
    let (w, h, nl, r) = (st.width as i64, st.height as i64, st.lights.len(), st.opts.fill_radius as i64);
    let (mut own, mut filled, mut none) = (0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let p = (y * w + x) as usize;
            let valid = st.gbuffer.as_ref().unwrap().pixels[p].is_valid();
            for l in 0..nl {
                let q = &st.sums[p * nl + l];
                let expect = if !valid {
                    None
                } else if q.occ.occluded {
                    own += 1;
                    Some((q.occ.s1, q.occ.s2))
                } else {
                    let (mut n, mut s1, mut s2) = (0.0, 0.0, 0.0);
                    for ny in (y - r).max(0)..=(y + r).min(h - 1) {
                        for nx in (x - r).max(0)..=(x + r).min(w - 1) {
                            let o = &st.sums[(ny * w + nx) as usize * nl + l];
                            if (nx - x).pow(2) + (ny - y).pow(2) <= r * r && o.occ.occluded {
                                (n, s1, s2) = (n + 1.0, s1 + o.occ.s1, s2 + o.occ.s2);
                            }
                        }
                    }
                    (n > 0.0).then(|| (s1 / n, s2 / n))
                };
                match (st.slopes[p * nl + l].get(), expect) {
                    (Some(got), Some(want)) => {
                        filled += usize::from(!q.occ.occluded);
                        for (g, e) in [(got.0, want.0), (got.1, want.1)] {
                            assert!(
                                (g - e).abs() <= 1e-6 * e.abs().max(1e-3),
                                "({x},{y}) light {l}: {got:?} vs {want:?}"
                            );
                        }
                    }
                    (None, None) => none += 1,
                    (got, want) => panic!("({x},{y}) light {l}: {got:?} vs {want:?}"),
                }
            }
        }
    }
    assert!(own > 50 && filled > 50 && none > 50, "own {own}, filled {filled}, none {none}");
}

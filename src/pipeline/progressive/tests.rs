//! Tests of the pass loop on a small analytic-ish scene.
use super::*;
use crate::pipeline::frame::ShadingMaps;
use crate::pipeline::job::{Halt, Method};
use crate::render::light::{EmissionProfile, RectLight};
use crate::render::material::Material;
use crate::render::scene::Scene;
use crate::render::scene::{CameraDesc, SceneBuilder};
use crate::render::texture::Texture;
use glam::Vec3;
use std::sync::Arc;
use std::time::Duration;

/// A box-like room: floor, back wall, a small occluder and a square light.
pub(crate) fn small_scene(width: u32, height: u32) -> Arc<Scene> {
    let mut b = SceneBuilder::new(CameraDesc {
        position: Vec3::new(0.0, 1.0, 3.0),
        look_at: Vec3::new(0.0, 0.5, 0.0),
        up: Vec3::Y,
        vertical_fov_deg: 50.0,
        width,
        height,
    });
    let white = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.7)) });
    let quad = |b: &mut SceneBuilder, c: Vec3, u: Vec3, v: Vec3| {
        let o = b.new_object();
        b.geometry.push([c, c + u, c + u + v], None, None, white, o);
        b.geometry.push([c, c + u + v, c + v], None, None, white, o);
    };
    quad(&mut b, Vec3::new(-2.0, 0.0, -2.0), Vec3::new(0.0, 0.0, 4.0), Vec3::new(4.0, 0.0, 0.0));
    quad(&mut b, Vec3::new(-2.0, 0.0, -1.0), Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 3.0, 0.0));
    quad(&mut b, Vec3::new(-0.3, 0.5, -0.3), Vec3::new(0.0, 0.0, 0.6), Vec3::new(0.6, 0.0, 0.0));
    b.add_rect_light(RectLight::new(
        Vec3::new(-0.5, 2.0, -0.5),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::splat(5.0),
        EmissionProfile::Uniform,
    ));
    Arc::new(b.build())
}

fn job(scene: Arc<Scene>, halt: Halt) -> RenderJob {
    RenderJob { seed: 7, bounces: 1, ..RenderJob::new(scene, Method::Uniform, halt) }
}

fn frames(job: &RenderJob) -> Vec<Frame> {
    let mut out = Vec::new();
    render(job, &CancelToken::new(), &mut |f| {
        out.push(f.clone());
        true
    })
    .unwrap();
    out
}

#[test]
fn passes_refine_with_non_decreasing_spp_and_halt_on_max_passes() {
    let j = job(small_scene(16, 12), Halt { max_passes: 4, max_mean_spp: 0.0, time_budget: None, target_error: None });
    let f = frames(&j);
    assert_eq!(f.len(), 4);
    for (k, fr) in f.iter().enumerate() {
        assert_eq!(fr.stats.pass, k as u32);
        assert_eq!(fr.stats.mean_spp, (1u64 << k) as f64);
        assert!(fr.spp.iter().all(|&s| s == (1u64 << k) as f32));
        assert_eq!(fr.stats.is_final, k == 3);
        assert!(fr.color.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    }
    assert_eq!(f[3].stats.halt_reason, HaltReason::MaxPasses);
    assert!(f.windows(2).all(|w| w[1].stats.rays_traced > w[0].stats.rays_traced));
}

#[test]
fn max_spp_halts_exactly_at_the_requested_count() {
    let j = job(small_scene(8, 8), Halt { max_passes: 100, max_mean_spp: 10.0, time_budget: None, target_error: None });
    let f = frames(&j);
    let last = f.last().unwrap();
    assert_eq!(last.stats.mean_spp, 10.0);
    assert_eq!(last.stats.halt_reason, HaltReason::MaxSpp);
}

#[test]
fn time_budget_halts_after_at_least_one_frame() {
    let j = job(
        small_scene(8, 8),
        Halt { max_passes: 1000, max_mean_spp: 0.0, time_budget: Some(Duration::ZERO), target_error: None },
    );
    let f = frames(&j);
    assert_eq!(f.len(), 1);
    assert_eq!(f[0].stats.halt_reason, HaltReason::TimeBudget);
    // The budget was over before the first pixel, and the first frame is still complete.
    assert_eq!(f[0].stats.mean_spp, 1.0);
    assert!(f[0].stats.pass_complete);
    assert!(f[0].spp.iter().all(|&s| s == 1.0));
}

#[test]
fn image_is_bit_identical_whatever_the_thread_count() {
    let j = job(small_scene(20, 14), Halt { max_passes: 3, max_mean_spp: 0.0, time_budget: None, target_error: None });
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| frames(&j)).pop().unwrap()
    };
    let (a, b) = (run(1), run(3));
    let bits = |f: &Frame| f.color.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(a.stats.rays_traced, b.stats.rays_traced);
    // And a different seed changes it.
    let mut j2 = j.clone();
    j2.seed = 8;
    let c = frames(&j2).pop().unwrap();
    assert_ne!(bits(&a), bits(&c));
}

#[test]
fn cancellation_stops_the_render() {
    let j = job(small_scene(8, 8), Halt { max_passes: 50, max_mean_spp: 0.0, time_budget: None, target_error: None });
    let cancel = CancelToken::new();
    let mut seen = 0;
    let r = render(&j, &cancel, &mut |_| {
        seen += 1;
        if seen == 2 {
            cancel.cancel();
        }
        true
    });
    assert_eq!(r, Err(RenderError::Cancelled));
    assert_eq!(seen, 2);
    // A callback refusing a frame stops it too.
    assert_eq!(render(&j, &CancelToken::new(), &mut |_| false), Err(RenderError::Cancelled));
}

#[test]
fn more_samples_converge_towards_a_reference() {
    // RMSE against a 256 spp render (another seed) falls as passes add samples.
    let scene = small_scene(12, 10);
    let mut rj = job(scene.clone(), Halt { max_passes: 9, max_mean_spp: 256.0, time_budget: None, target_error: None });
    rj.seed = 1234;
    let reference = frames(&rj).pop().unwrap();
    let f = frames(&job(scene, Halt { max_passes: 6, max_mean_spp: 0.0, time_budget: None, target_error: None }));
    let rmse = |fr: &Frame| {
        let se: f64 = fr
            .color
            .iter()
            .zip(&reference.color)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] as f64 - b[c] as f64).powi(2)))
            .sum();
        (se / (3 * fr.color.len()) as f64).sqrt()
    };
    let e: Vec<f64> = f.iter().map(rmse).collect();
    // 1 spp vs 32 spp: error should fall by roughly sqrt(32) ~ 5.7; demand at least 2.5x.
    assert!(e[0] > 2.5 * e[5], "{e:?}");
    assert!(e[5] < e[3] && e[3] < e[1], "{e:?}");
}

#[test]
fn non_finite_samples_are_counted_and_dropped() {
    // A light of infinite radiance seen by the camera makes those paths infinite: they are
    // dropped and counted, the image stays finite, and the spp halt still fires.
    let mut b = SceneBuilder::new(CameraDesc {
        position: Vec3::new(0.0, 0.0, 2.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vertical_fov_deg: 60.0,
        width: 6,
        height: 6,
    });
    let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.5)) });
    b.geometry.push(
        [Vec3::new(-3.0, -3.0, -1.0), Vec3::new(3.0, -3.0, -1.0), Vec3::new(0.0, 3.0, -1.0)],
        None,
        None,
        m,
        0,
    );
    b.add_rect_light(RectLight::new(
        Vec3::new(-0.3, -0.3, 0.0),
        Vec3::new(0.6, 0.0, 0.0),
        Vec3::new(0.0, 0.6, 0.0),
        Vec3::splat(f32::INFINITY),
        EmissionProfile::Uniform,
    ));
    let j = job(Arc::new(b.build()), Halt { max_passes: 50, max_mean_spp: 4.0, time_budget: None, target_error: None });
    let f = frames(&j);
    let last = f.last().unwrap();
    assert!(last.stats.dropped_samples > 0);
    assert_eq!(last.stats.halt_reason, HaltReason::MaxSpp);
    assert_eq!(f.len(), 3, "1 + 1 + 2 samples reach the requested 4");
    assert!(last.color.iter().flatten().all(|v| v.is_finite()));
    // Pixels that only saw the light kept no sample: spp 0 there, and black.
    assert!(last.spp.iter().any(|&s| s < 4.0));
}

use crate::methods::tests::builtin;
use crate::pipeline::job::tests::cut_pass_after_checks;

fn image_mean(f: &Frame) -> f64 {
    f.color.iter().flatten().map(|&v| v as f64).sum::<f64>() / (3 * f.color.len()) as f64
}

/// Every frame estimates the whole image, whatever the budget: one that ends inside pass 0
/// (pass 0 always completes) and one that ends inside a later pass (every pixel keeps at least
/// the samples it had), for every method, on two built-in scenes. The frame's mean is within
/// 3% of a high-spp reference's. `lobe-aware` also runs upsampled, its later pass the one that
/// returns to full resolution (whose cut leaves pixels with no indirect samples of their own).
#[test]
fn frames_cut_by_the_budget_are_complete_for_every_method() {
    for (name, bounces) in [("cornell", 1), ("grids", 0)] {
        let scene = builtin(name, 160, 120);
        let mut rj = job(scene.clone(), Halt::passes(64));
        (rj.bounces, rj.seed, rj.halt.max_mean_spp) = (bounces, 99, 128.0);
        let reference = image_mean(frames(&rj).last().unwrap());
        for (method, upsample) in Method::ALL.iter().map(|&m| (m, 1)).chain([(Method::LobeAware, 2)]) {
            let mut j = job(scene.clone(), Halt::passes(64));
            (j.method, j.bounces) = (method, bounces);
            j.lobe.upsample.factor = upsample;
            // Pass 2 brings every pixel to 4 samples.
            j.lobe.upsample.full_resolution_spp = 4;
            // Inside pass 0: the budget is over before the render starts.
            j.halt.time_budget = Some(Duration::ZERO);
            let f = frames(&j);
            assert_eq!(f.len(), 1, "{name} {method:?}");
            assert!(f[0].stats.pass_complete && f[0].spp.iter().all(|&s| s >= 1.0), "{name} {method:?}");
            let m = image_mean(&f[0]);
            assert!((m / reference - 1.0).abs() < 0.03, "{name} {method:?} pass 0: mean {m} vs {reference}");
            // Inside a later pass: pass 2 cut after a third of its pixels' stop checks, as a
            // deadline would cut it (counted, so that the cut lands inside the pass on any
            // machine under any load); retried earlier for methods whose pass checks less often.
            let pixels = (j.width() * j.height()) as i64;
            let mut cut = false;
            for checks in [pixels / 3, pixels / 10, 16] {
                j.halt = Halt::passes(4);
                let f = cut_pass_after_checks(2, checks, || frames(&j));
                let cut_frame = &f[2];
                assert!(cut_frame.spp.iter().all(|&s| s >= 1.0), "{name} {method:?}: a pixel without samples");
                let m = image_mean(cut_frame);
                assert!((m / reference - 1.0).abs() < 0.03, "{name} {method:?} cut: mean {m} vs {reference}");
                if !cut_frame.stats.pass_complete {
                    assert_eq!(f.len(), 3, "{name} {method:?}: the cut frame is the last");
                    assert_eq!(cut_frame.stats.halt_reason, HaltReason::TimeBudget, "{name} {method:?}");
                    cut = true;
                    break;
                }
            }
            assert!(cut, "{name} {method:?}: no budget ended inside a pass");
        }
    }
}

/// One compiled scene renders from any view: two views of one compile are bit-identical to
/// the same views of two compiles made for them.
#[test]
fn views_of_one_compiled_scene_match_separate_compiles() {
    let base = crate::scene::builtin::get("cornell").unwrap();
    let shared = Arc::new(crate::scene::compile(&base, &crate::scene::SceneLimits::default(), None).unwrap());
    for (w, h, dx) in [(24u32, 18u32, 0.0f32), (20, 30, 120.0)] {
        let mut moved = base.clone();
        let cam = moved.camera.as_mut().unwrap();
        (cam.width, cam.height) = (w, h);
        cam.position.as_mut().unwrap().x += dx;
        let own = Arc::new(crate::scene::compile(&moved, &crate::scene::SceneLimits::default(), None).unwrap());
        let mut a = job(own.clone(), Halt::passes(3));
        a.method = Method::Aaf;
        let mut b = a.clone();
        b.scene = shared.clone();
        b.view = shared.view(&own.default_camera);
        assert_eq!((b.view.width, b.view.height), (w, h));
        let (fa, fb) = (frames(&a), frames(&b));
        assert_eq!(fa.len(), fb.len());
        for (x, y) in fa.iter().zip(&fb) {
            assert_eq!(x.color, y.color);
            assert_eq!(x.spp, y.spp);
        }
    }
}

/// The noise target stops the render once its own estimate reaches it, and a tighter target
/// takes more samples; the first frame has no estimate.
#[test]
fn the_noise_target_halts_the_render() {
    let scene = small_scene(32, 24);
    let mut spp = Vec::new();
    for target in [0.2, 0.05] {
        let mut j = job(scene.clone(), Halt::passes(20));
        j.halt.target_error = Some(target);
        let f = frames(&j);
        assert_eq!(f[0].stats.estimated_error, None);
        let last = f.last().unwrap();
        assert_eq!(last.stats.halt_reason, HaltReason::NoiseTarget, "target {target}");
        assert!(last.stats.estimated_error.unwrap() <= target);
        assert!(f[f.len() - 2].stats.estimated_error.is_none_or(|e| e > target));
        spp.push(last.stats.mean_spp);
    }
    assert!(spp[1] >= 8.0 * spp[0], "{spp:?}");
}

/// Under an environment light (the built-in sky) every method renders the light it cannot
/// analyse by plain sampling and the sky seen directly as it is: each converges to `uniform`'s
/// image (mean within 2% of a 256-spp reference, error at 64 spp no more than 1.5 times
/// `uniform`'s own), with no pixel left non-finite.
#[test]
fn every_method_converges_to_uniform_under_the_sky() {
    let mut s = crate::scene::builtin::get("sky-spheres").unwrap();
    let cam = s.camera.as_mut().unwrap();
    (cam.width, cam.height) = (40, 30);
    let scene = Arc::new(crate::scene::compile(&s, &crate::scene::SceneLimits::default(), None).unwrap());
    let mut rj = job(scene.clone(), Halt::passes(64));
    (rj.bounces, rj.seed, rj.halt.max_mean_spp) = (1, 5, 256.0);
    let reference = frames(&rj).pop().unwrap();
    let mean = image_mean(&reference);
    let mut uniform_error = None;
    for method in Method::ALL {
        let mut j = job(scene.clone(), Halt::passes(64));
        (j.method, j.bounces, j.halt.max_mean_spp) = (method, 1, 64.0);
        let f = frames(&j).pop().unwrap();
        assert!(f.color.iter().flatten().all(|v| v.is_finite()), "{method:?}");
        let m = image_mean(&f);
        assert!((m / mean - 1.0).abs() < 0.02, "{method:?}: mean {m} vs {mean}");
        let e = crate::methods::tests::rmse(&f.color, &reference.color);
        let u = *uniform_error.get_or_insert(e);
        assert!(e < 1.5 * u, "{method:?}: RMSE {e}, uniform's {u}");
    }
}

/// The frame `render_frames` composed last, and per pass whether it composed one.
fn last_composed(j: &RenderJob, wanted: &dyn Fn(u32) -> bool) -> (Frame, Vec<bool>) {
    let (mut last, mut composed) = (None, Vec::new());
    render_frames(j, &CancelToken::new(), wanted, &mut |_, f| {
        composed.push(f.is_some());
        last = f.cloned().or(last.take());
        true
    })
    .unwrap();
    (last.expect("the final frame is composed"), composed)
}

/// A frame nobody uses is not composed, and composing one changes nothing later: every
/// method's final frame is the same bit for bit whether every pass's frame was composed or
/// the final one alone (what sampling reads of the last pass, such as `auto`'s penumbra marks,
/// the end of Tokuyoshi's upsampling or `bandwidth`'s S_hat, is kept by the sampling).
#[test]
fn the_final_frame_is_the_same_whichever_frames_were_composed() {
    for (name, bounces) in [("cornell-glossy", 1), ("grids", 0), ("sky-spheres", 1)] {
        let scene = builtin(name, 24, 18);
        for (method, upsample) in Method::ALL.iter().map(|&m| (m, 1)).chain([(Method::LobeAware, 2)]) {
            let mut j = job(scene.clone(), Halt::passes(4));
            (j.method, j.bounces) = (method, bounces);
            (j.lobe.upsample.factor, j.lobe.upsample.full_resolution_spp) = (upsample, 4);
            // Within four passes: auto's narrow scale and blend, the AAF family's later widths.
            (j.auto.narrow_from_spp, j.auto.blend_from_spp) = (4, 16);
            let (every, composed) = last_composed(&j, &|_| true);
            assert_eq!(composed, [true; 4], "{name} {method:?}");
            let (last, composed) = last_composed(&j, &|_| false);
            assert_eq!(composed, [false, false, false, true], "{name} {method:?}");
            let at = format!("{name} {method:?} upsample {upsample}");
            assert_eq!(every.color, last.color, "{at}");
            assert_eq!(every.unfiltered, last.unfiltered, "{at}");
            assert_eq!(every.spp, last.spp, "{at}");
            assert_eq!(every.filter_width, last.filter_width, "{at}");
            assert_eq!(every.components, last.components, "{at}");
            let timeless_maps = |f: &Frame| f.shading.clone().map(|m| ShadingMaps { analysis_seconds: 0.0, ..m });
            assert!(timeless_maps(&every) == timeless_maps(&last), "{at}");
            // Timings differ, and the error estimate needs a frame before.
            let timeless = |s: &FrameStats| FrameStats {
                elapsed_seconds: 0.0,
                method_seconds: 0.0,
                estimated_error: None,
                ..s.clone()
            };
            assert_eq!(timeless(&every.stats), timeless(&last.stats), "{at}");
        }
    }
}

/// Under a noise target every frame is composed (the halt compares each with the one before),
/// whatever the caller wants; the passes' stats reach the caller either way.
#[test]
fn a_noise_target_composes_every_frame() {
    let mut j = job(small_scene(16, 12), Halt::passes(6));
    j.halt.target_error = Some(1e-9);
    let (last, composed) = last_composed(&j, &|_| false);
    assert_eq!(composed, [true; 6]);
    assert_eq!((last.stats.pass, last.stats.halt_reason), (5, HaltReason::MaxPasses));
    j.halt.target_error = None;
    let mut seen = Vec::new();
    render_frames(&j, &CancelToken::new(), &|pass| pass == 2, &mut |s, f| {
        seen.push((s.pass, s.mean_spp, f.is_some()));
        true
    })
    .unwrap();
    let expect: Vec<_> = (0..6).map(|p| (p, (1u64 << p) as f64, p == 2 || p == 5)).collect();
    assert_eq!(seen, expect);
}

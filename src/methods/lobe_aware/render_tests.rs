//! The `lobe-aware` and `normal-aware` methods through the pipeline, on small built-in scenes
//! with fixed seeds: energy, consistency (the stream converges to plain Monte Carlo) and the
//! narrowing kernel.
use crate::methods::tests::{builtin, frames, rmse};
use crate::pipeline::frame::Frame;
use crate::pipeline::job::{Halt, Method, RenderJob};
use crate::render::scene::Scene;
use std::sync::Arc;

/// `passes` passes after the preview, which `frames` drops.
fn job(scene: Arc<Scene>, method: Method, passes: u32, seed: u64, bounces: u32) -> RenderJob {
    let mut j = RenderJob::new(scene, method, Halt::passes(passes + (method != Method::Uniform) as u32));
    (j.seed, j.bounces) = (seed, bounces);
    j
}

fn reference(scene: Arc<Scene>, bounces: u32, spp: f64) -> Frame {
    let mut j = job(scene, Method::Uniform, 20, 99, bounces);
    j.halt.max_mean_spp = spp;
    frames(&j).pop().unwrap()
}

fn mean(img: &[[f32; 3]]) -> f64 {
    img.iter().flatten().map(|&v| v as f64).sum::<f64>() / (3 * img.len()) as f64
}

/// The glossy Cornell box: both components are filtered and carry their maps; the filtered
/// image keeps the energy of plain path tracing; the samples double per pass from the preview
/// on; the kernel keeps its width up to the 16 initial samples and then narrows by 2^(-1/6) per
/// doubling; and the error against a converged image falls pass by pass.
#[test]
fn the_stream_keeps_the_energy_narrows_and_converges() {
    let s = builtin("cornell-glossy", 32, 32);
    let reference = reference(s.clone(), 1, 2048.0);
    for method in [Method::LobeAware, Method::NormalAware] {
        let f = frames(&job(s.clone(), method, 7, 1, 1));
        let names: Vec<&str> = f[0].components.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["diffuse", "glossy"], "{method:?}");
        let last = f.last().unwrap();
        let (m, r) = (mean(&last.color), mean(&reference.color));
        assert!((m / r - 1.0).abs() < 0.02, "{method:?}: mean {m} vs {r}");
        for c in 0..2 {
            for k in 1..f.len() {
                let (a, b) = (&f[k - 1].components[c], &f[k].components[c]);
                assert_eq!(f[k].stats.mean_spp, 2f64.powi(k as i32 + 1), "{method:?} pass {}", k + 1);
                let ratio = if f[k].stats.mean_spp > 16.0 { 0.5f32.powf(1.0 / 6.0) } else { 1.0 };
                let pairs = a.filter_width.as_ref().unwrap().iter().zip(b.filter_width.as_ref().unwrap());
                let mut n = 0;
                for (wa, wb) in pairs.filter(|(wa, wb)| **wa > 0.0 && **wb > 0.0) {
                    assert!((wb / wa - ratio).abs() < 1e-4, "{method:?} {c} pass {k}: {wa} -> {wb}");
                    n += 1;
                }
                assert!(n > 200, "{method:?} component {c} pass {k}: {n} pixels filtered");
            }
        }
        let e: Vec<f64> = f.iter().map(|fr| rmse(&fr.color, &reference.color)).collect();
        assert!(e.windows(2).all(|p| p[1] < p[0]), "{method:?}: {e:?}");
        assert!(e[6] < 0.5 * e[2], "{method:?}: {e:?}");
    }
}

/// The filter lowers the error: at equal samples the filtered frame is closer to the converged
/// image than its own unfiltered estimate. On the glossy Cornell box (a point light, 1 bounce,
/// kappa = infinity) indirect light is most of the noise and the gain is large; on the diffuse
/// one (3 bounces, kappa = 100) the area light's direct light, which these methods leave
/// unfiltered, is most of it.
#[test]
fn the_filtered_frame_beats_its_unfiltered_estimate() {
    for (name, bounces, gain) in [("cornell", 3, 0.95), ("cornell-glossy", 1, 0.6)] {
        let s = builtin(name, 32, 32);
        let reference = reference(s.clone(), bounces, 2048.0);
        for method in [Method::LobeAware, Method::NormalAware] {
            let last = frames(&job(s.clone(), method, 5, 5, bounces)).pop().unwrap();
            let (filtered, raw) =
                (rmse(&last.color, &reference.color), rmse(last.unfiltered_color(), &reference.color));
            assert!(filtered < gain * raw, "{name} {method:?}: {filtered} vs unfiltered {raw}");
        }
    }
}

/// Tokuyoshi's Fig. 14(b): on the polished box (lobes of exponent 800 to 5,000 reflecting the
/// lit room) the normal-aware weight lets a flat floor's or a mirror ball's neighbours in whose
/// reflections differ, and blurs them; the lobe-aware weight keeps them apart. Its error is
/// below the normal-aware one's at every pass, at equal samples.
#[test]
fn lobe_aware_beats_normal_aware_on_high_frequency_lobes() {
    let s = builtin("cornell-polished", 64, 48);
    let reference = reference(s.clone(), 1, 2048.0);
    let errors = |method| -> Vec<f64> {
        frames(&job(s.clone(), method, 5, 7, 1)).iter().map(|f| rmse(&f.color, &reference.color)).collect()
    };
    let (lobe, normal) = (errors(Method::LobeAware), errors(Method::NormalAware));
    for (pass, (l, n)) in lobe.iter().zip(&normal).enumerate() {
        assert!(*l < 0.95 * n, "pass {pass}: lobe-aware {l} vs normal-aware {n} ({lobe:?} vs {normal:?})");
    }
}

/// Consistency: as the kernel narrows below a third of a pixel the filtered frame becomes the
/// plain Monte Carlo mean. With the default exponent (1/6) that takes millions of samples, so
/// the mechanism is tested with a kernel that narrows as 1 / n.
#[test]
fn the_filtered_stream_converges_to_the_per_pixel_mean() {
    let s = builtin("cornell-glossy", 12, 9);
    for method in [Method::LobeAware, Method::NormalAware] {
        let mut j = job(s.clone(), method, 6, 3, 1);
        j.indirect.initial_samples = 4;
        j.lobe.refine_exponent = 1.0;
        let last = frames(&j).pop().unwrap();
        let widths = last.filter_width.as_ref().unwrap();
        assert!(
            widths.iter().all(|&w| w <= 0.3),
            "{method:?}: max width {}",
            widths.iter().cloned().fold(0.0, f32::max)
        );
        let e = rmse(&last.color, last.unfiltered_color());
        let scale = mean(&last.color);
        assert!(e < 0.01 * scale, "{method:?}: rmse {e} vs mean {scale}");
    }
}

/// Eq. 13's ASG lobes (`LobeShape::Asg`) through the pipeline: on the glossy Cornell box,
/// whose blocks are seen at grazing angles, the filtered image keeps the energy and beats its
/// unfiltered estimate by as much as the SG lobes do (within 10%).
#[test]
fn asg_lobes_filter_as_well_as_sg_lobes() {
    use crate::methods::lobe_aware::options::LobeShape;
    let s = builtin("cornell-glossy", 32, 32);
    let reference = reference(s.clone(), 1, 2048.0);
    let run = |shape| {
        let mut j = job(s.clone(), Method::LobeAware, 2, 5, 1);
        j.lobe.lobe.shape = shape;
        let last = frames(&j).pop().unwrap();
        let (m, r) = (mean(&last.color), mean(&reference.color));
        assert!((m / r - 1.0).abs() < 0.02, "{shape:?}: mean {m} vs {r}");
        (rmse(&last.color, &reference.color), rmse(last.unfiltered_color(), &reference.color))
    };
    let (asg, raw) = run(LobeShape::Asg);
    let (sg, _) = run(LobeShape::Sg);
    assert!(asg < 0.6 * raw, "asg {asg} vs unfiltered {raw}");
    assert!(asg < 1.1 * sg, "asg {asg} vs sg {sg}");
}

/// Joint upsampling (Sec. 5) at half resolution on the glossy Cornell box: indirect light is
/// traced at the grid's sites and at the pixels Fig. 16 re-renders, and nowhere else (each
/// component's spp map says so); every pixel still takes its camera samples; the frame keeps
/// the energy of plain path tracing; it costs fewer rays than filtering at full resolution; and
/// it does not depend on the thread count.
#[test]
fn upsampled_passes_trace_indirect_light_at_the_sites_and_the_rerendered_pixels() {
    let (w, h) = (32usize, 32usize);
    let s = builtin("cornell-glossy", w as u32, h as u32);
    let reference = reference(s.clone(), 1, 2048.0);
    for method in [Method::LobeAware, Method::NormalAware] {
        let mut up = job(s.clone(), method, 6, 5, 1);
        up.lobe.upsample.factor = 2;
        let last = frames(&up).pop().unwrap();
        let full = frames(&job(s.clone(), method, 6, 5, 1)).pop().unwrap();
        assert!(last.spp.iter().all(|&n| n == 64.0), "{method:?}: every pixel takes the pass's camera samples");
        let diffuse = &last.components[0].spp;
        let (mut sites, mut rerendered, mut upsampled) = (0, 0, 0);
        for (p, &n) in diffuse.iter().enumerate() {
            let site = (p % w).is_multiple_of(2) && (p / w).is_multiple_of(2);
            assert!(n == 0.0 || n == 64.0, "{method:?}: pixel {p} has {n} indirect samples");
            match (site, n > 0.0) {
                (true, true) => sites += 1,
                (false, true) => rerendered += 1,
                (false, false) => upsampled += 1,
                (true, false) => {}
            }
        }
        assert!(sites > 200 && upsampled > 400, "{method:?}: {sites} sites, {upsampled} upsampled");
        // The box's edges and its blocks' silhouettes are re-rendered, not the whole image.
        assert!(rerendered > 10 && rerendered < upsampled / 2, "{method:?}: {rerendered} re-rendered");
        let (m, r) = (mean(&last.color), mean(&reference.color));
        assert!((m / r - 1.0).abs() < 0.03, "{method:?}: mean {m} vs {r}");
        assert!(
            (last.stats.rays_traced as f64) < 0.85 * full.stats.rays_traced as f64,
            "{method:?}: {} rays upsampled, {} at full resolution",
            last.stats.rays_traced,
            full.stats.rays_traced
        );
        let e = rmse(&last.color, &reference.color);
        assert!(e < rmse(last.unfiltered_color(), &reference.color), "{method:?}: filtered {e}");
        let one =
            rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| frames(&up)).pop().unwrap();
        assert_eq!(one.color, last.color, "{method:?}");
    }
}

/// Consistency with upsampling: the first pass whose samples reach `full_resolution_spp`
/// traces every pixel, and from there the stream converges to the plain Monte Carlo mean as
/// without it (a kernel narrowing as 1 / n, as above).
#[test]
fn the_upsampled_stream_returns_to_full_resolution_and_converges() {
    let s = builtin("cornell-glossy", 12, 9);
    for factor in [2, 4] {
        let mut j = job(s.clone(), Method::LobeAware, 6, 3, 1);
        j.indirect.initial_samples = 4;
        j.lobe.refine_exponent = 1.0;
        j.lobe.upsample.factor = factor;
        j.lobe.upsample.full_resolution_spp = 16;
        let f = frames(&j);
        let indirect = |fr: &Frame| fr.components[0].spp.iter().filter(|&&n| n > 0.0).count();
        // Passes of 2, 4 and 8 samples upsample; 16 and on trace every pixel that reflects light.
        assert!(indirect(&f[2]) < indirect(&f[3]), "factor {factor}");
        assert_eq!(indirect(&f[3]), indirect(f.last().unwrap()));
        let last = f.last().unwrap();
        let e = rmse(&last.color, last.unfiltered_color());
        assert!(e < 0.01 * mean(&last.color), "factor {factor}: rmse {e}");
    }
}

/// A camera change cancels the running render; a frame being filtered then ends at once with
/// `Cancelled` (a session's next view waits for it), and the strategy still gives the frame
/// once asked with a live token.
#[test]
fn a_cancelled_render_stops_inside_the_frame() {
    use crate::methods::aaf_indirect::IndirectStrategy;
    use crate::methods::mode::FilterMode;
    use crate::pipeline::job::{CancelToken, RenderError, StopCheck};
    use crate::pipeline::strategy::{PassContext, Strategy};
    use crate::render::gbuffer::GBuffer;
    let j = job(builtin("cornell-glossy", 24, 18), Method::LobeAware, 1, 3, 1);
    let g = Arc::new(GBuffer::build(&j.scene, &j.view));
    let mut st = IndirectStrategy::new(&j, FilterMode::LobeAware, true);
    let (live, cancelled) = (CancelToken::new(), CancelToken::new());
    cancelled.cancel();
    let (go, stop) = (StopCheck::cancel_only(&live), StopCheck::cancel_only(&cancelled));
    let ctx = |stop| PassContext { scene: &j.scene, job: &j, view: &j.view, pass: 0, stop, gbuffer: Some(&g) };
    st.sample(&ctx(&go)).expect("pass 0");
    assert!(matches!(st.frame(&ctx(&stop)), Err(RenderError::Cancelled)));
    let frame = st.frame(&ctx(&go)).expect("a live render's frame");
    assert!(frame.color.iter().flatten().all(|v| v.is_finite()) && frame.color.iter().flatten().any(|&v| v > 0.0));
}

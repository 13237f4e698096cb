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
/// image keeps the energy of plain path tracing; the kernel narrows by 2^(-1/6) per doubling
/// of the samples; and the error against a converged image falls pass by pass.
#[test]
fn the_stream_keeps_the_energy_narrows_and_converges() {
    let s = builtin("cornell-glossy", 32, 32);
    let reference = reference(s.clone(), 1, 2048.0);
    for method in [Method::LobeAware, Method::NormalAware] {
        let f = frames(&job(s.clone(), method, 5, 1, 1));
        let names: Vec<&str> = f[0].components.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["diffuse", "glossy"], "{method:?}");
        let last = f.last().unwrap();
        let (m, r) = (mean(&last.color), mean(&reference.color));
        assert!((m / r - 1.0).abs() < 0.02, "{method:?}: mean {m} vs {r}");
        for c in 0..2 {
            for k in 1..f.len() {
                let (a, b) = (&f[k - 1].components[c], &f[k].components[c]);
                let pairs = a.filter_width.as_ref().unwrap().iter().zip(b.filter_width.as_ref().unwrap());
                let mut n = 0;
                for (wa, wb) in pairs.filter(|(wa, wb)| **wa > 0.0 && **wb > 0.0) {
                    assert!((wb / wa - 0.5f32.powf(1.0 / 6.0)).abs() < 1e-4, "{method:?} {c} pass {k}: {wa} -> {wb}");
                    n += 1;
                }
                assert!(n > 200, "{method:?} component {c} pass {k}: {n} pixels filtered");
            }
        }
        let e: Vec<f64> = f.iter().map(|fr| rmse(&fr.color, &reference.color)).collect();
        assert!(e.windows(2).all(|p| p[1] < p[0]), "{method:?}: {e:?}");
        assert!(e[4] < 0.6 * e[0], "{method:?}: {e:?}");
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
            let last = frames(&job(s.clone(), method, 2, 5, bounces)).pop().unwrap();
            let (filtered, raw) =
                (rmse(&last.color, &reference.color), rmse(last.unfiltered_color(), &reference.color));
            assert!(filtered < gain * raw, "{name} {method:?}: {filtered} vs unfiltered {raw}");
        }
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

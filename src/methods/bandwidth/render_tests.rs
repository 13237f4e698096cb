//! The `bandwidth` method through the pipeline, on small scenes with fixed seeds: it is the
//! plain path tracer where it has nothing to shade, its passes lower the levels to full
//! resolution and converge to the `uniform` image, its frames do not depend on the thread
//! count, and extreme lights and materials give finite, non-negative images.
use crate::methods::tests::{all_frames, builtin, edited_scene, rmse};
use crate::pipeline::job::{Halt, Method, RenderJob};
use crate::render::gbuffer::GBuffer;
use crate::render::scene::Scene;
use std::sync::Arc;

fn job(scene: Arc<Scene>, method: Method, passes: u32, seed: u64, bounces: u32) -> RenderJob {
    let mut j = RenderJob::new(scene, method, Halt::passes(passes));
    (j.seed, j.bounces) = (seed, bounces);
    j
}

fn mean(img: &[[f32; 3]]) -> f64 {
    img.iter().flatten().map(|&v| v as f64).sum::<f64>() / (3 * img.len()) as f64
}

/// The sky-spheres scene at `w` x `h` with its scene file edited.
fn sky_spheres(w: u32, h: u32, edit: impl Fn(&mut serde_json::Value)) -> Arc<Scene> {
    edited_scene(include_str!("../../../scenes/sky-spheres.json"), w, h, edit)
}

/// Without an environment light there is nothing to shade: every sample is the path tracer's
/// own, drawn from the same sample streams, so the frames are `uniform`'s with one path per
/// sample (`uniform.max_splits` 1: bandwidth does not split paths), bit for bit.
#[test]
fn without_an_environment_it_is_the_path_tracer() {
    let s = builtin("cornell", 16, 12);
    // Five passes: the last two would adapt their counts under an environment light.
    let mut plain = job(s.clone(), Method::Uniform, 5, 7, 1);
    plain.uniform.max_splits = 1;
    let (a, b) = (all_frames(&job(s, Method::Bandwidth, 5, 7, 1)), all_frames(&plain));
    assert_eq!(a.len(), 5);
    for (fa, fb) in a.iter().zip(&b) {
        assert_eq!(fa.color, fb.color, "pass {}", fa.stats.pass);
        assert_eq!(fa.spp, fb.spp);
        assert!(fa.shading.is_none() && fa.stats.full_resolution_points == 0);
    }
}

/// Under the sky: pass 0 shades a fraction of the samples and upsamples the rest; each pass
/// lowers the levels by one, so that by the image's coarsest level every sample is shaded;
/// from there the estimate is the pixel's own and the stream converges to the path tracer's
/// image: its mean within 2% and its error falling to that of `uniform` at similar samples.
#[test]
fn the_passes_reach_full_resolution_and_converge_to_uniform() {
    let s = builtin("sky-spheres", 64, 48);
    let reference = all_frames(&job(s.clone(), Method::Uniform, 11, 99, 0)).pop().unwrap();
    let f = all_frames(&job(s.clone(), Method::Bandwidth, 8, 1, 0));
    let first = &f[0];
    let maps = first.shading.as_ref().unwrap();
    assert_eq!((maps.bandwidth.len(), maps.level.len()), (3072, 3072));
    assert!(maps.level.iter().any(|&l| l >= 2.0), "no coarse level: {:?}", maps.level);
    assert!(maps.bandwidth.iter().all(|b| !b.is_nan() && *b >= 0.0));
    let (shaded, full) = (first.stats.shaded_points, first.stats.full_resolution_points);
    assert!(shaded > 0 && shaded < full * 3 / 4, "pass 0 shaded {shaded} of {full}");
    // 64 x 48: the coarsest level is 5, reached by every pixel after 5 passes; from then on
    // every sample of every pixel that sees a surface is shaded (the sky's never are).
    let j = job(s.clone(), Method::Bandwidth, 8, 1, 0);
    let g = GBuffer::build(&s, &j.view);
    let surface = g.pixels.iter().filter(|p| p.is_valid() && !p.emitter).count() as u64;
    assert!(surface > 1500 && surface < 3072, "{surface}");
    for (before, fr) in f[4..].iter().zip(&f[5..]) {
        assert!(fr.shading.as_ref().unwrap().level.iter().all(|&l| l <= 0.0), "pass {}", fr.stats.pass);
        // The pass's samples per pixel (their counts adapt from 4 spp on).
        let added = |p: usize| (fr.spp[p] - before.spp[p]) as u64;
        let on_surface: u64 = (0..3072).filter(|&p| g.pixels[p].is_valid() && !g.pixels[p].emitter).map(added).sum();
        assert_eq!(fr.stats.shaded_points, on_surface, "pass {}", fr.stats.pass);
        assert_eq!(fr.stats.full_resolution_points, (0..3072).map(added).sum::<u64>(), "pass {}", fr.stats.pass);
    }
    let last = f.last().unwrap();
    let (m, r) = (mean(&last.color), mean(&reference.color));
    assert!((m / r - 1.0).abs() < 0.02, "mean {m} vs {r}");
    let e: Vec<f64> = f.iter().map(|fr| rmse(&fr.color, &reference.color)).collect();
    assert!(e[7] < 0.5 * e[1], "{e:?}");
    let uniform = all_frames(&job(s, Method::Uniform, 8, 1, 0));
    let u = uniform.iter().find(|fr| fr.stats.mean_spp >= last.stats.mean_spp).unwrap_or(uniform.last().unwrap());
    let eu = rmse(&u.color, &reference.color);
    assert!(e[7] < 1.5 * eu, "bandwidth {} vs uniform {eu} at {} spp", e[7], u.stats.mean_spp);
}

/// The same render on one thread and on two gives the same frames.
#[test]
fn frames_do_not_depend_on_the_thread_count() {
    let s = builtin("sky-spheres", 24, 16);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| all_frames(&job(s.clone(), Method::Bandwidth, 3, 3, 1)))
    };
    let (a, b) = (run(1), run(2));
    for (fa, fb) in a.iter().zip(&b) {
        assert_eq!(fa.color, fb.color, "pass {}", fa.stats.pass);
        let (ma, mb) = (fa.shading.as_ref().unwrap(), fb.shading.as_ref().unwrap());
        assert_eq!((&ma.bandwidth, &ma.level), (&mb.bandwidth, &mb.level));
    }
}

/// A black sky, a constant one, and spheres of exponent 10^6 seen at grazing angles: finite,
/// non-negative frames, black where the light is; under a constant sky only the texture and
/// the edges have bandwidth, less than under the sky with its sun.
#[test]
fn extreme_lights_and_materials_give_finite_images() {
    let constant = |r: f64| {
        move |j: &mut serde_json::Value| {
            j["lights"][0]["environment"] = serde_json::json!({"constant": {"r": r, "g": r, "b": r}});
        }
    };
    let sharp = |j: &mut serde_json::Value| {
        for m in j["materials"].as_array_mut().unwrap() {
            if let Some(g) = m.get_mut("glossy") {
                g["exponent"] = serde_json::json!({"constant": 1e6});
            }
        }
    };
    let mut medians = Vec::new();
    for (what, scene) in [
        ("sky", sky_spheres(24, 16, |_| {})),
        ("black", sky_spheres(24, 16, constant(0.0))),
        ("constant", sky_spheres(24, 16, constant(1.0))),
        ("sharp", sky_spheres(24, 16, sharp)),
    ] {
        let f = all_frames(&job(scene, Method::Bandwidth, 3, 2, 1));
        for fr in &f {
            assert!(fr.color.iter().flatten().all(|v| v.is_finite() && *v >= 0.0), "{what} pass {}", fr.stats.pass);
            let maps = fr.shading.as_ref().unwrap();
            assert!(maps.level.iter().all(|l| l.is_finite()), "{what}");
        }
        if what == "black" {
            assert!(f.iter().all(|fr| fr.color.iter().flatten().all(|&v| v == 0.0)), "black sky, light seen");
        }
        let mut b = f[0].shading.as_ref().unwrap().bandwidth.clone();
        b.sort_by(f32::total_cmp);
        medians.push(b[b.len() / 2]);
    }
    // sky, black, constant, sharp.
    assert!(medians[2] < medians[0], "constant sky {} vs sky {}", medians[2], medians[0]);
}

/// With the antialiasing levels on, a pixel at level -1 or -2 takes 4 or 16 times the pass's
/// camera samples, and only those pixels do; off (the default), every pixel takes the same.
#[test]
fn antialiasing_levels_multiply_the_camera_samples_where_the_bandwidth_asks() {
    let s = builtin("sky-spheres", 48, 32);
    for antialiasing in [true, false] {
        let mut j = job(s.clone(), Method::Bandwidth, 1, 4, 0);
        j.bandwidth.antialiasing = antialiasing;
        let f = all_frames(&j).pop().unwrap();
        let levels = &f.shading.as_ref().unwrap().level;
        let fine = levels.iter().filter(|&&l| l < 0.0).count();
        assert_eq!(fine > 0, antialiasing, "{fine} pixels below level 0");
        for (spp, &level) in f.spp.iter().zip(levels) {
            let expected = if level < 0.0 { 4f32.powf(-level) } else { 1.0 };
            assert_eq!(*spp, expected, "level {level}");
        }
    }
}

/// From 4 spp on, half of each pass goes where the pixels' samples vary (`counts`): the pass
/// keeps its total, the open sky (its samples vary only with the sky's gradient) keeps little
/// more than the uniform share, the surfaces take the rest; with `adaptive_from_spp` 0 every pixel has the same count.
#[test]
fn camera_samples_go_where_the_samples_vary() {
    let s = builtin("sky-spheres", 64, 48);
    let j = job(s.clone(), Method::Bandwidth, 6, 3, 0);
    let g = GBuffer::build(&s, &j.view);
    let f = all_frames(&j).pop().unwrap();
    let n = f.spp.len();
    assert_eq!(f.spp.iter().sum::<f32>(), 32.0 * n as f32, "the pass keeps its total");
    let base = j.bandwidth.proportional().uniform_share(32) as f32;
    assert!(f.spp.iter().all(|&c| c >= base && c <= 8.0 * 32.0), "{:?}", f.spp);
    // Sky pixels whose 3 x 3 window is all sky, and surface pixels.
    let sky = |p: usize| crate::pipeline::allocation::window(64, 48, p, 1).all(|q| !g.pixels[q].is_valid());
    let mean_of = |keep: &dyn Fn(usize) -> bool| {
        let (sum, k) = (0..n).filter(|&p| keep(p)).fold((0.0, 0), |(s, k), p| (s + f.spp[p], k + 1));
        assert!(k > 100, "{k} pixels");
        sum / k as f32
    };
    let (open_sky, surface) = (mean_of(&sky), mean_of(&|p| g.pixels[p].is_valid()));
    assert!(open_sky < 0.65 * surface && surface > 32.0, "sky {open_sky}, surface {surface}, uniform share {base}");
    let mut even = j.clone();
    even.bandwidth.adaptive_from_spp = 0;
    assert!(all_frames(&even).pop().unwrap().spp.iter().all(|&c| c == 32.0));
}

/// A pass the deadline cuts in its adaptive extras leaves every pixel between two of their
/// sweeps (`allocation::extras_round`), a like fraction of its own way, not a band of pixels
/// done beside pixels not begun. The cut counts stop checks (one per pixel and sweep), so it
/// lands at the same point of the work on any machine.
#[test]
fn a_pass_cut_in_its_extras_leaves_each_pixel_a_like_fraction_of_its_way() {
    use crate::pipeline::allocation::extras_round;
    use crate::pipeline::job::tests::cut_pass_after_checks;
    let s = builtin("sky-spheres", 48, 32);
    let j = job(s, Method::Bandwidth, 5, 4, 0);
    let pixels = 48 * 32;
    // Pass 4 goes from 8 to 16 spp; its uniform share is 8, so its sweeps are one that traces
    // nothing, then the extras' sixteen.
    let base = j.bandwidth.proportional().uniform_share(16);
    assert_eq!(base, 8, "the defaults this test is written for");
    let frames = all_frames(&j);
    let (before, whole) = (&frames[3], &frames[4]);
    let cut = cut_pass_after_checks(4, pixels * 5 / 2, || all_frames(&j)).pop().unwrap();
    assert!(!cut.stats.pass_complete && cut.stats.pass == 4);
    let mut moved = 0;
    for (p, ((&c, &full), &had)) in cut.spp.iter().zip(&whole.spp).zip(&before.spp).enumerate() {
        // A pixel that had more than a sweep's count before the pass waits at what it had.
        let (full, had) = (full as u32, had as u32);
        let (lo, hi) = (extras_round(base, full, 1).max(had), extras_round(base, full, 2).max(had));
        assert!((lo..=hi).contains(&(c as u32)), "pixel {p}: {c} not within {lo}..={hi} of its {full}");
        moved += (c as u32 > lo) as u32;
    }
    assert!(moved > 0 && moved < pixels as u32, "the cut fell inside the second sweep: {moved}");
}

/// Without a deadline the passes trace each pixel's samples in one sweep (nothing but a
/// cancellation can stop them): the same samples and lookups, so the frames are those of a
/// render whose rounds ran under a deadline it never met, bit for bit.
#[test]
fn one_sweep_without_a_deadline_gives_the_frames_of_the_rounds() {
    let j = job(builtin("sky-spheres", 32, 24), Method::Bandwidth, 5, 6, 1);
    crate::methods::tests::assert_one_sweep_equals_the_rounds(&j, 5, 16.0);
}

/// Eq. 4's light directions shared by a tile of pixels (`light_tile`, the default 8) predict
/// what each pixel's own do: the directions come from the same distribution, so the levels
/// agree within one at nearly every pixel and the shaded share of the image is alike. With
/// `light_tile` 1 every pixel draws its own (the paper's analysis).
#[test]
fn light_directions_shared_by_a_tile_predict_the_per_pixel_levels() {
    use super::analysis::analyse;
    let s = builtin("sky-spheres", 96, 64);
    let j = job(s.clone(), Method::Bandwidth, 1, 5, 0);
    let g = GBuffer::build(&s, &j.view);
    assert_eq!(j.bandwidth.light_tile, 8, "the default this test is written for");
    let tiled = analyse(&s, &j.view, &g, &j.bandwidth, j.seed);
    let mut own_opts = j.bandwidth;
    own_opts.light_tile = 1;
    let own = analyse(&s, &j.view, &g, &own_opts, j.seed);
    let n = tiled.level.len();
    let far = tiled.level.iter().zip(&own.level).filter(|(a, b)| a.abs_diff(**b) > 1).count();
    assert!(far * 50 < n, "{far} of {n} pixels' levels differ by more than one");
    let shaded_share = |levels: &[i32]| levels.iter().map(|&l| 0.25f64.powi(l.max(0))).sum::<f64>() / n as f64;
    let (a, b) = (shaded_share(&tiled.level), shaded_share(&own.level));
    assert!((a / b - 1.0).abs() < 0.05, "shaded share {a} tiled, {b} per pixel");
    // And the tiles do change the draws: the two analyses are not the same numbers.
    assert_ne!(tiled.bandwidth, own.bandwidth);
}

/// `shade` takes its lookups a batch at a time; its estimate is, bit for bit, the mean of the
/// terms of one lookup at a time (`environment_terms` with each lookup's own numbers), for
/// counts that fill whole batches and counts that leave a part of one, on the glossy spheres
/// and the diffuse floor.
#[test]
fn batched_lookups_give_the_one_at_a_time_estimate() {
    use super::sample::{shade, LookupStream, MAX_LOOKUPS};
    use crate::render::integrator::environment_terms;
    use crate::render::sampler::PixelSampler;
    use glam::Vec3;
    let s = builtin("sky-spheres", 32, 24);
    let j = job(s.clone(), Method::Bandwidth, 1, 0, 0);
    let env = s.environment().expect("the sky");
    let mut shaded = 0;
    for (x, y) in [(16.5, 12.5), (8.5, 14.5), (24.5, 10.5), (16.5, 22.5), (3.5, 20.5)] {
        let dir = j.view.direction(x, y);
        let Some(hit) = s.intersect(j.view.position, dir, 0.0) else { continue };
        let brdf = s.materials[hit.material as usize].brdf(hit.uv);
        for lookups in 1..=9 {
            let stream = LookupStream { seed: 42, pixel: 7, index: 3 };
            let mut expected = Vec3::ZERO;
            for k in 0..lookups {
                let index = stream.index.wrapping_mul(MAX_LOOKUPS).wrapping_add(k);
                let mut sampler = PixelSampler::new(stream.seed, stream.pixel, index);
                let (ul, ub, ud) = (sampler.next_2d(), sampler.next_1d(), sampler.next_2d());
                for (value, _) in environment_terms(&hit, -dir, &brdf, env, ul, ub, ud).into_iter().flatten() {
                    expected += value;
                }
            }
            let got = shade(&s, env, &hit, -dir, lookups, stream);
            assert_eq!(got, expected / lookups as f32, "pixel ({x}, {y}), {lookups} lookups");
            shaded += (got != Vec3::ZERO) as u32;
        }
    }
    assert!(shaded >= 27, "too few points shaded: {shaded}");
}

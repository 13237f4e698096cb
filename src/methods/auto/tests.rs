//! `auto` through the pipeline, on small scenes with fixed seeds: the parts it reports, its
//! energy against plain Monte Carlo, the narrowing of every filter, the exact unshadowed light,
//! the gain of the filter, and independence from the thread count.
use super::component_names;
use crate::methods::tests::{all_frames, builtin, frames};
use crate::pipeline::frame::Frame;
use crate::pipeline::job::{Halt, Integrand, Method, RenderJob};
use crate::render::light::{polygon_irradiance, EmissionProfile, RectLight};
use crate::render::material::Material;
use crate::render::scene::{CameraDesc, Scene, SceneBuilder};
use crate::render::texture::Texture;
use glam::Vec3;
use std::sync::Arc;

fn job(scene: Arc<Scene>, method: Method, passes: u32, seed: u64, bounces: u32) -> RenderJob {
    let mut j = RenderJob::new(scene, method, Halt::passes(passes));
    (j.seed, j.bounces) = (seed, bounces);
    j
}

fn reference(scene: Arc<Scene>, bounces: u32, spp: f64) -> Frame {
    let mut j = job(scene, Method::Uniform, 30, 99, bounces);
    j.halt.max_mean_spp = spp;
    frames(&j).pop().unwrap()
}

fn mean(img: &[[f32; 3]]) -> f64 {
    img.iter().flatten().map(|&v| v as f64).sum::<f64>() / (3 * img.len()) as f64
}

/// Mean of the positive entries of a width map.
fn mean_width(w: &[f32]) -> f64 {
    let pos: Vec<f64> = w.iter().filter(|&&x| x > 0.0).map(|&x| x as f64).collect();
    pos.iter().sum::<f64>() / pos.len().max(1) as f64
}

/// The area-lit Cornell box (soft shadows, diffuse indirect light) and the glossy one under a
/// point light (diffuse and glossy indirect light): the parts the registry announces, the
/// energy of plain path tracing, every part's filter narrowing pass by pass, and the error
/// against a converged image falling pass by pass.
#[test]
fn the_stream_keeps_the_energy_narrows_and_converges() {
    for (name, parts) in [("cornell", &["shadow", "diffuse"][..]), ("cornell-glossy", &["diffuse", "glossy"][..])] {
        let s = builtin(name, 32, 32);
        let reference = reference(s.clone(), 1, 2048.0);
        let mut j = job(s.clone(), Method::Auto, 5, 1, 1);
        // The same count everywhere, so that every pixel's width narrows by the same factor
        // (`adaptive_counts_...` below renders with the adaptive counts).
        j.auto.adaptive_from_spp = 0;
        assert_eq!(component_names(&j), parts, "{name}");
        let f = all_frames(&j);
        assert_eq!(f.len(), 5);
        for (k, fr) in f.iter().enumerate() {
            let names: Vec<&str> = fr.components.iter().map(|c| c.name.as_str()).collect();
            assert_eq!(names, parts, "{name}");
            assert!(fr.spp.iter().all(|&n| n == (1u32 << (2 * k)) as f32), "{name}: pass {k} has 4^{k} spp everywhere");
            assert!(fr.color.iter().flatten().all(|v| v.is_finite() && *v >= 0.0), "{name}");
        }
        let last = f.last().unwrap();
        let (m, r) = (mean(&last.color), mean(&reference.color));
        assert!((m / r - 1.0).abs() < 0.02, "{name}: mean {m} vs {r}");
        // Once the analysis samples are in (16 spp, pass 2), every filtered part narrows by
        // 4^(-1/6) per pass (the samples grow fourfold), its own width or the cap.
        for (c, part) in parts.iter().enumerate() {
            let widths: Vec<f64> =
                f.iter().map(|fr| mean_width(fr.components[c].filter_width.as_ref().unwrap())).collect();
            assert!(widths.iter().all(|&w| w > 0.0), "{name} {}: widths {widths:?}", part);
            assert!(widths[4] < widths[2], "{name} {}: {widths:?}", part);
            for k in 3..5 {
                let (a, b) = (&f[k - 1].components[c], &f[k].components[c]);
                let pairs = a.filter_width.as_ref().unwrap().iter().zip(b.filter_width.as_ref().unwrap());
                let mut n = 0;
                for (&wa, &wb) in pairs.filter(|(wa, _)| **wa > 0.0) {
                    assert!((wb / wa - 0.25f32.powf(1.0 / 6.0)).abs() < 1e-4, "{name} pass {k}: {wa} -> {wb}");
                    n += 1;
                }
                assert!(n > 20, "{name} {} pass {k}: {n} pixels narrowed", part);
            }
        }
        // Consistency: the error falls pass by pass (to the reference's own noise).
        let e: Vec<f64> = f.iter().map(|fr| rmse_off_lights(&fr.color, &reference)).collect();
        assert!(e.windows(2).all(|p| p[1] < 1.05 * p[0]), "{name}: {e:?}");
        assert!(e[4] < 0.2 * e[0], "{name}: {e:?}");
    }
}

/// `glossy-plates`: plates from Blinn-Phong 10 to 10,000 reflecting an area light, whose glossy
/// direct light `auto` leaves unfiltered and estimates with two strategies (`mis`). Its mean
/// stays plain path tracing's, and its error falls pass by pass like the filtered parts'.
#[test]
fn glossy_reflections_of_an_area_light_keep_the_energy_and_converge() {
    let s = builtin("glossy-plates", 32, 24);
    let reference = reference(s.clone(), 0, 4096.0);
    let f = all_frames(&job(s, Method::Auto, 5, 1, 0));
    let last = f.last().unwrap();
    let (m, r) = (mean(&last.color), mean(&reference.color));
    assert!((m / r - 1.0).abs() < 0.02, "mean {m} vs {r}");
    let e: Vec<f64> = f.iter().map(|fr| rmse_off_lights(&fr.color, &reference)).collect();
    assert!(e.windows(2).all(|p| p[1] < 1.05 * p[0]), "{e:?}");
    assert!(e[4] < 0.25 * e[0], "{e:?}");
}

/// RMSE without the pixels that see a light's surface (whose error is the camera jitter's
/// coverage of its edge, which no filter touches): those above 1 in the reference and their
/// 8 neighbours.
fn rmse_off_lights(a: &[[f32; 3]], reference: &Frame) -> f64 {
    let (w, h) = (reference.width as usize, reference.height as usize);
    let bright = |x: usize, y: usize| reference.color[y * w + x].iter().any(|&v| v > 1.0);
    let near_light = |x: usize, y: usize| {
        (y.saturating_sub(1)..(y + 2).min(h)).any(|ny| (x.saturating_sub(1)..(x + 2).min(w)).any(|nx| bright(nx, ny)))
    };
    let (mut se, mut n) = (0.0, 0usize);
    for y in 0..h {
        for x in 0..w {
            if !near_light(x, y) {
                let (p, q) = (a[y * w + x], reference.color[y * w + x]);
                se += (0..3).map(|c| (p[c] as f64 - q[c] as f64).powi(2)).sum::<f64>();
                n += 3;
            }
        }
    }
    (se / n as f64).sqrt()
}

/// The filter lowers the error: at equal samples (16 spp, pass 2) the filtered frame is closer to the
/// converged image than its own unfiltered estimate, on the area-lit box and on the glossy one,
/// by at least 2x in RMSE.
#[test]
fn the_filter_lowers_the_error_at_equal_samples() {
    for name in ["cornell", "cornell-glossy"] {
        let s = builtin(name, 48, 48);
        let reference = reference(s.clone(), 1, 4096.0);
        let f = all_frames(&job(s, Method::Auto, 3, 3, 1));
        let last = f.last().unwrap();
        let filtered = rmse_off_lights(&last.color, &reference);
        let raw = rmse_off_lights(last.unfiltered_color(), &reference);
        assert!(filtered < raw / 2.0, "{name}: filtered {filtered} vs unfiltered {raw}");
    }
}

/// A Lambertian square (albedo 0.5) of half-side `half` on the y = 0 plane, centred on the
/// origin, under `light`, seen straight down from height `camera_y` (60 degrees, `px` x `px`).
fn square_under(light: RectLight, half: f32, camera_y: f32, px: u32) -> Arc<Scene> {
    let mut b = SceneBuilder::new(CameraDesc {
        position: Vec3::new(0.0, camera_y, 0.0),
        look_at: Vec3::ZERO,
        up: Vec3::Z,
        vertical_fov_deg: 60.0,
        width: px,
        height: px,
    });
    let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.5)) });
    let o = b.new_object();
    let (c, u, v) = (Vec3::new(-half, 0.0, -half), Vec3::new(2.0 * half, 0.0, 0.0), Vec3::new(0.0, 0.0, 2.0 * half));
    b.geometry.push([c, c + u, c + u + v], None, None, m, o);
    b.geometry.push([c, c + u + v, c + v], None, None, m, o);
    b.add_rect_light(light);
    Arc::new(b.build())
}

/// A Lambertian floor (albedo 0.5) under a square uniform light (out of view), nothing else: no occluder, so
/// the visibility is exactly 1 and the direct light is r(x), the closed form (Mehta 2012
/// Eq. 1), at one sample per pixel, without noise. Pixel centres make each pixel one point.
#[test]
fn without_occluders_the_direct_light_is_exact_at_one_sample() {
    let light = RectLight::new(
        Vec3::new(2.0, 1.0, -0.5),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::splat(3.0),
        EmissionProfile::Uniform,
    );
    let scene = square_under(light.clone(), 4.0, 3.0, 12);
    let mut j = job(scene.clone(), Method::Auto, 1, 5, 0);
    j.pixel_centers = true;
    let f = all_frames(&j).pop().unwrap();
    let quad = |l: &RectLight| [l.corner, l.corner + l.edge_u, l.corner + l.edge_u + l.edge_v, l.corner + l.edge_v];
    let crate::render::light::Light::Rect(compiled) = &scene.lights[0] else { unreachable!() };
    let mut lit = 0;
    for y in 0..12u32 {
        for x in 0..12u32 {
            let dir = j.view.direction(x as f32 + 0.5, y as f32 + 0.5);
            let hit = scene.intersect(j.view.position, dir, 0.0).expect("the floor fills the view");
            let exact = 0.5 / std::f64::consts::PI * 3.0 * polygon_irradiance(hit.p, hit.ns, &quad(compiled));
            let got = f.color[(y * 12 + x) as usize][0] as f64;
            assert!((got - exact).abs() <= 1e-5 * exact.max(1e-3), "pixel ({x}, {y}): {got} vs {exact}");
            lit += usize::from(exact > 1e-3);
        }
    }
    assert!(lit > 100, "the light reaches most of the view ({lit})");
}

/// Every pixel's value depends only on the seed, the pixel and the sample index, and the
/// filters only on the image: a pool of 1 and of 2 threads give the same frames, bit for bit.
#[test]
fn frames_do_not_depend_on_the_thread_count() {
    let s = builtin("cornell", 24, 24);
    let j = job(s, Method::Auto, 4, 7, 1);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| all_frames(&j)).into_iter().map(|f| (f.color, f.spp, f.filter_width)).collect::<Vec<_>>()
    };
    assert_eq!(run(1), run(2));
}

/// Ambient occlusion is the indirect paper's extension: `auto` renders it as `aaf` does.
#[test]
fn ambient_occlusion_renders_as_aaf() {
    let s = builtin("cornell", 16, 16);
    let mut a = job(s.clone(), Method::Auto, 3, 2, 0);
    a.integrand = Integrand::AmbientOcclusion { max_distance: f32::INFINITY };
    let mut b = a.clone();
    b.method = Method::Aaf;
    assert_eq!(component_names(&a), ["diffuse"]);
    let (fa, fb) = (all_frames(&a), all_frames(&b));
    assert_eq!(fa.last().unwrap().color, fb.last().unwrap().color);
}

/// From the pass beyond `adaptive_min_spp` (pass 2) on, the area-lit box's penumbrae and edges
/// get more samples than its flat lit and umbral pixels, each pass keeps its mean count (within
/// the rounding), every pixel keeps at least the uniform share, and the stream still converges
/// to the reference with the same energy.
#[test]
fn adaptive_counts_sample_the_penumbrae_and_keep_the_total() {
    let s = builtin("cornell", 32, 32);
    let reference = reference(s.clone(), 0, 4096.0);
    let j = job(s, Method::Auto, 5, 4, 0);
    assert_eq!(j.auto.adaptive_from_spp, 4, "the default this test is written for");
    let f = all_frames(&j);
    for (k, fr) in f.iter().enumerate() {
        let target = (1u32 << (2 * k)) as f32;
        let mean_spp = fr.spp.iter().sum::<f32>() / fr.spp.len() as f32;
        // Pass 1's four samples are all the floor (`adaptive_min_spp`): none adapt yet.
        if target <= j.auto.adaptive_min_spp as f32 {
            assert!(fr.spp.iter().all(|&n| n == target), "pass {k}: {target} samples everywhere");
            continue;
        }
        assert!((mean_spp / target - 1.0).abs() < 0.02, "pass {k}: mean {mean_spp} vs {target}");
        let min = fr.spp.iter().cloned().fold(f32::INFINITY, f32::min);
        let max = fr.spp.iter().cloned().fold(0.0, f32::max);
        let floor = j.auto.proportional().uniform_share(target as u32) as f32;
        assert!(min >= floor && floor < target / 2.0, "pass {k}: min {min}, floor {floor}");
        assert!(max >= 2.0 * target, "pass {k}: max {max}: the penumbrae get more");
    }
    // The pixels with the most samples lie at a shadow's or an object's edge: their
    // neighbourhood's unfiltered values spread.
    let last = f.last().unwrap();
    let raw = last.unfiltered_color();
    let most = (0..raw.len()).max_by(|&a, &b| last.spp[a].total_cmp(&last.spp[b])).unwrap();
    let (w, x, y) = (32usize, most % 32, most / 32);
    let neighbours: Vec<f32> = (y.saturating_sub(2)..(y + 3).min(32))
        .flat_map(|ny| (x.saturating_sub(2)..(x + 3).min(32)).map(move |nx| ny * w + nx))
        .map(|q| raw[q][0])
        .collect();
    let spread =
        neighbours.iter().cloned().fold(0.0, f32::max) - neighbours.iter().cloned().fold(f32::INFINITY, f32::min);
    assert!(spread > 0.1 * raw[most][0].max(1e-3), "pixel {most} is not at a shadow edge: {neighbours:?}");
    let (m, r) = (mean(&last.color), mean(&reference.color));
    assert!((m / r - 1.0).abs() < 0.02, "mean {m} vs {r}");
    let e: Vec<f64> = f.iter().map(|fr| rmse_off_lights(&fr.color, &reference)).collect();
    assert!(e[4] < 0.5 * e[2], "{e:?}");
}

#[test]
fn passes_quadruple_the_samples_up_to_the_cap() {
    let totals: Vec<u32> = (0..7).map(|k| super::pass_target(1, k, 1000.0)).collect();
    assert_eq!(totals, [1, 4, 16, 64, 256, 1000, 1000]);
    assert_eq!(super::pass_target(2, 1, 0.0), 8);
    assert_eq!(super::pass_target(1, 1000, 0.0), u32::MAX);
}

#[test]
fn mu_grows_as_the_sixth_root_of_the_samples() {
    let o = super::AutoOptions::default();
    assert!((o.mu(2.0, 16.0) - 2.0).abs() < 1e-12);
    assert!((o.mu(2.0, 16.0 * 64.0) - 4.0).abs() < 1e-12);
    assert!((o.mu(0.9, 1.0) - 0.9 * 16f64.powf(-1.0 / 6.0)).abs() < 1e-12);
    // No samples count as one.
    assert_eq!(o.mu(1.0, 0.0), o.mu(1.0, 1.0));
}

/// The tabulated growth the widths use gives the same mu and cap, bit for bit, inside its
/// table and past it (counts beyond the image's maximum, or the table's size).
#[test]
fn tabulated_growth_equals_the_direct_one() {
    let o = super::AutoOptions::default();
    for max in [0u32, 5, 300] {
        let g = o.growths(max);
        for n in [0u32, 1, 2, 5, 17, 300, 301, 70_000, 1 << 20] {
            assert_eq!(g.mu(0.9, n), o.mu(0.9, n as f64), "max {max}, n {n}");
            assert_eq!(g.max_sigma(n), o.max_sigma(n as f64), "max {max}, n {n}");
        }
    }
}

/// The reflector distances of the separable box sums equal a visit of every window, on a grid
/// of several objects, with pixels that saw nothing and invalid ones, at several radii.
#[test]
fn neighbourhood_reflectors_equal_a_visit_of_every_window() {
    use super::widths::{neighbourhood_reflectors, Seen};
    use crate::render::test_rng::Rng;
    let (w, h) = (23, 17);
    let mut rng = Rng(13);
    let pixels: Vec<Seen> = (0..w * h)
        .map(|p| {
            let (x, y) = (p % w, p / w);
            let object = if x < 9 {
                0
            } else if y < 8 {
                1
            } else {
                2 + (x + y) as u32 % 2 * u32::from(x > 18)
            };
            let z = (rng.f() > 0.3).then(|| {
                let a = 0.1 + 3.0 * rng.f();
                (a, a + 2.0 * rng.f())
            });
            Seen { valid: rng.f() > 0.1, object, z }
        })
        .collect();
    for radius in [0, 1, 3, 6] {
        let fast = neighbourhood_reflectors(w, h, radius, &|p| pixels[p]);
        for p in 0..w * h {
            let (x, y) = ((p % w) as i64, (p / w) as i64);
            let mut sum = (0u32, 0.0f64, 0.0f64);
            for q in 0..w * h {
                let (qx, qy) = ((q % w) as i64, (q / w) as i64);
                let inside = (qx - x).abs() <= radius as i64 && (qy - y).abs() <= radius as i64;
                if let (true, true, Some((a, b))) =
                    (inside && q != p, pixels[q].object == pixels[p].object, pixels[q].z)
                {
                    sum = (sum.0 + 1, sum.1 + a as f64, sum.2 + b as f64);
                }
            }
            let want =
                (pixels[p].valid && sum.0 > 0).then(|| ((sum.1 / sum.0 as f64) as f32, (sum.2 / sum.0 as f64) as f32));
            match (fast[p], want) {
                (Some(a), Some(b)) => assert!(
                    (a.0 - b.0).abs() <= 1e-6 * b.0 && (a.1 - b.1).abs() <= 1e-6 * b.1,
                    "radius {radius}, pixel {p}: {a:?} vs {b:?}"
                ),
                (a, b) => assert_eq!(a, b, "radius {radius}, pixel {p}"),
            }
        }
    }
}

/// A pass the deadline cuts leaves every pixel within one round of the others (its samples
/// sweep the image in rounds), not a band of pixels at the pass's target beside the rest at
/// the last pass's. Passes 1-3 cut at points spread over their rounds (counted in stop checks,
/// one per pixel and round, so that the cuts land where asked on any machine).
#[test]
fn a_pass_cut_by_the_budget_leaves_even_counts() {
    use crate::pipeline::job::tests::cut_pass_after_checks;
    let mut j = job(builtin("cornell", 96, 72), Method::Auto, 4, 5, 1);
    let pixels = (j.width() * j.height()) as i64;
    for pass in 1..=3 {
        // Up to two and a half rounds: pass 1 has three (1 to 4 samples).
        for k in [1, 4, 6, 8] {
            j.halt = Halt::passes(pass + 2);
            let last = cut_pass_after_checks(pass, pixels * k / 3, || all_frames(&j)).pop().unwrap();
            assert!(!last.stats.pass_complete && last.stats.pass == pass, "pass {pass} cut at {k}/3 rounds");
            let (before, target) = (super::pass_target(1, pass - 1, 0.0), super::pass_target(1, pass, 0.0));
            // Four rounds a pass.
            let step = (target - before).div_ceil(4);
            let lo = last.spp.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = last.spp.iter().copied().fold(0.0f32, f32::max);
            assert!(
                lo >= before as f32 && hi <= target as f32 && hi - lo <= step as f32,
                "pass {pass} cut at {k}/3 rounds: counts from {lo} to {hi}, rounds of {step}"
            );
        }
    }
}

/// A small lit square on a black background, no occluder: the shadow rays see no noise
/// anywhere, yet the pixels across the square's edge vary from sample to sample (its coverage
/// of each). With the measured sigma (`adaptive_measured`) they get the adaptive samples and
/// the flat pixels keep the uniform share; without it the counts stay uniform.
#[test]
fn adaptive_counts_sample_an_object_s_edge_the_shadow_rays_do_not_see() {
    // The camera between a broad light above and the square below it: the square spans pixels
    // 5.07 to 18.93 of 24 each way, so its edges cross columns and rows 5 and 18.
    let (corner, eu, ev) = (Vec3::new(-2.0, 2.0, -2.0), Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 4.0));
    let scene = square_under(RectLight::new(corner, eu, ev, Vec3::splat(1.0), EmissionProfile::Uniform), 0.5, 1.5, 24);
    let mut j = job(scene, Method::Auto, 3, 7, 0);
    let f = all_frames(&j).pop().unwrap();
    let (w, spp) = (24usize, &f.spp);
    assert_eq!(spp.iter().sum::<f32>(), 16.0 * (w * w) as f32, "the pass keeps its total");
    // Within a pixel of an edge (the measured variance is pooled over 3 x 3 pixels).
    let near_edge = |i: usize| i.abs_diff(5) <= 1 || i.abs_diff(18) <= 1;
    let on_square = |i: usize| (4..=19).contains(&i);
    let edge = |p: usize| on_square(p % w) && on_square(p / w) && (near_edge(p % w) || near_edge(p / w));
    let most = (0..w * w).max_by(|&a, &b| spp[a].total_cmp(&spp[b])).unwrap();
    assert!(spp[most] > 32.0 && edge(most), "pixel {most} with {} samples is not at the edge", spp[most]);
    // The square's centre and the background: flat, at the floor (one more where the whole
    // counts round up).
    let floor = j.auto.proportional().uniform_share(16) as f32;
    for p in (0..w * w).filter(|&p| !edge(p)) {
        assert!(spp[p] <= floor + 1.0, "pixel {p} off the edge has {} samples", spp[p]);
    }
    j.auto.adaptive_measured = false;
    assert!(all_frames(&j).pop().unwrap().spp.iter().all(|&n| n == 16.0), "no noise the shadow rays see");
}

/// A pass the deadline cuts in its adaptive extras has taken every pixel a like fraction of
/// the way from the uniform share to its own count (the extras sweep the image in rounds too):
/// cut in round k + 1, each pixel holds the count of round k or k + 1, not its full count in a
/// band of rows beside none in the rest. Direct light, pass 2 (16 samples a pixel, 4 uniform).
#[test]
fn a_pass_cut_in_its_adaptive_extras_leaves_like_fractions() {
    use crate::pipeline::job::tests::cut_pass_after_checks;
    let mut j = job(builtin("cornell", 48, 36), Method::Auto, 3, 5, 0);
    let pixels = (j.width() * j.height()) as i64;
    let full = all_frames(&j).pop().unwrap().spp;
    let uniform = j.auto.proportional().uniform_share(16);
    assert_eq!(uniform, 4, "the defaults this test is written for");
    assert!(full.iter().any(|&n| n >= 32.0), "some pixels adapt");
    let sweeps = crate::pipeline::allocation::EXTRA_ROUNDS;
    let round = |p: usize, k: u32| (uniform + ((full[p] as u32 - uniform) * k).div_ceil(sweeps)) as f32;
    for k in [0, 1, sweeps / 2, sweeps - 1] {
        j.halt = Halt::passes(4);
        // One sweep up to the uniform share (nothing to add: pass 1 left four samples), then
        // k whole rounds of the extras and half of the next.
        let cut = cut_pass_after_checks(2, pixels * (1 + k as i64) + pixels / 2, || all_frames(&j)).pop().unwrap();
        assert!(!cut.stats.pass_complete && cut.stats.pass == 2, "cut in round {}", k + 1);
        for (p, &n) in cut.spp.iter().enumerate() {
            assert!(n >= round(p, k) && n <= round(p, k + 1), "round {}: pixel {p} has {n} of {}", k + 1, full[p]);
        }
    }
}

/// Without a deadline nothing but a cancellation can stop a pass, so the passes trace each
/// pixel's samples in one sweep instead of rounds: the same samples, so every frame is the
/// one a render under a deadline it never meets gives, bit for bit (its rounds ran), with a
/// bounce and with direct light.
#[test]
fn one_sweep_without_a_deadline_gives_the_frames_of_the_rounds() {
    for bounces in [0, 1] {
        let j = job(builtin("cornell", 24, 18), Method::Auto, 4, 3, bounces);
        crate::methods::tests::assert_one_sweep_equals_the_rounds(&j, 4, 16.0);
    }
}

/// A render halted at a mean count stops there with adaptive counts too: each pass's counts
/// sum to its target exactly, so every frame's mean is at least its pass's target and the
/// render halts in the pass that reaches the cap (a mean a sample short of it would repeat the
/// capped pass, forever at some sizes). Odd sizes and caps that are not powers of four.
#[test]
fn a_render_capped_at_a_mean_count_halts_there() {
    use crate::pipeline::frame::HaltReason;
    for (w, h, cap, passes) in [(31, 23, 64.0, 4), (32, 32, 50.0, 4), (17, 29, 16.0, 3)] {
        let mut j = job(builtin("cornell", w, h), Method::Auto, 40, 3, 0);
        j.halt.max_mean_spp = cap;
        let f = all_frames(&j);
        let means: Vec<f64> = f.iter().map(|f| f.stats.mean_spp).collect();
        assert_eq!(f.len(), passes, "{w}x{h} at {cap}: {means:?}");
        assert_eq!(f.last().unwrap().stats.halt_reason, HaltReason::MaxSpp);
        for (k, m) in means.iter().enumerate() {
            assert!(*m >= super::pass_target(1, k as u32, cap) as f64, "{w}x{h} at {cap}: {means:?}");
        }
    }
}

/// Under point lights alone with no bounces `auto` has nothing to filter: it renders as
/// `uniform`, frame for frame and bit for bit, without a G-buffer (no rays beyond uniform's).
/// With a bounce, or with a rectangular light, it filters again.
#[test]
fn nothing_to_filter_renders_as_uniform() {
    let s = builtin("cornell-glossy", 24, 20);
    assert!(s.lights.iter().all(|l| matches!(l, crate::render::light::Light::Point(_))));
    let (a, u) = (job(s.clone(), Method::Auto, 4, 9, 0), job(s.clone(), Method::Uniform, 4, 9, 0));
    assert!(super::renders_as_uniform(&a) && component_names(&a).is_empty());
    let (fa, fu) = (all_frames(&a), all_frames(&u));
    assert_eq!(fa.len(), 4);
    for (x, y) in fa.iter().zip(&fu) {
        assert_eq!((&x.color, &x.spp, x.stats.rays_traced), (&y.color, &y.spp, y.stats.rays_traced));
    }
    assert!(!super::renders_as_uniform(&job(s, Method::Auto, 4, 9, 1)));
    assert!(!super::renders_as_uniform(&job(builtin("cornell", 8, 8), Method::Auto, 4, 9, 0)));
}

/// A pixel whose first block of samples sees two surfaces (two objects, shading normals more
/// than about 25 degrees apart, or a surface and nothing or a light) is an edge and computes r
/// on every sample; one that sees a single surface keeps to the blocks. What later samples see
/// does not change it.
#[test]
fn pixels_on_edges_compute_r_on_every_sample() {
    use super::sample::{r_due, PixelSums};
    let seen = |events: &[(u32, Option<(u32, Vec3)>)]| {
        let mut px = PixelSums::default();
        for &(i, s) in events {
            px.note_seen(i, 16, s);
        }
        px.mixed
    };
    let tilted = |deg: f32| Vec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos());
    assert!(!seen(&[(0, Some((1, Vec3::Z))), (1, Some((1, tilted(10.0)))), (15, Some((1, Vec3::Z)))]));
    assert!(seen(&[(0, Some((1, Vec3::Z))), (1, Some((2, Vec3::Z)))]), "two objects");
    assert!(seen(&[(0, Some((1, Vec3::Z))), (5, Some((1, tilted(30.0))))]), "a crease within one mesh");
    assert!(seen(&[(0, None), (1, Some((1, Vec3::Z)))]), "the background and a surface");
    assert!(!seen(&[(0, None), (1, None)]));
    assert!(!seen(&[(0, Some((1, Vec3::Z))), (16, Some((2, Vec3::Z)))]), "only the first block decides");
    assert!(seen(&[(0, Some((1, Vec3::Z))), (3, Some((2, Vec3::Z))), (4, Some((1, Vec3::Z)))]), "it stays an edge");
    // The blocks: 0-15, then 64-79, 128-143, ...; an edge pixel every sample.
    let due: Vec<u32> = (0..160).filter(|&i| r_due(16, i, false)).collect();
    assert_eq!(due, (0..16).chain(64..80).chain(128..144).collect::<Vec<_>>());
    assert!((0..160).all(|i| r_due(16, i, true)));
}

/// A pixel whose first samples saw two faces of a crease (normals +x and +y) is guided by their
/// mean normal; a pixel that saw one face keeps the G-buffer's guide, as does an invalid one,
/// and samples after the first `r_block` do not count.
#[test]
fn a_pixel_straddling_an_edge_is_guided_by_the_mean_of_its_normals() {
    use super::sample::PixelSums;
    use super::straddling_guide;
    use crate::methods::lobe_aware::packed::PackedGuide;
    let guide = PackedGuide { axis: [1.0, 0.0, 0.0], sharpness: 2.0, ln_sharpness: 2f32.ln(), depth: 3.0, valid: 1.0 };
    let mut straddling = PixelSums::default();
    for i in 0..4 {
        straddling.note_seen(i, 16, Some((0, if i % 2 == 0 { Vec3::X } else { Vec3::Y })));
    }
    straddling.note_seen(16, 16, Some((0, Vec3::Z)));
    let mut flat = PixelSums::default();
    for i in 0..4 {
        flat.note_seen(i, 16, Some((0, Vec3::X)));
    }
    assert!(straddling.mixed && !flat.mixed);
    let out: Vec<PackedGuide> = [(guide, straddling), (guide, flat), (PackedGuide::INVALID, straddling)]
        .iter()
        .map(|(g, s)| straddling_guide(g, s))
        .collect();
    let h = std::f32::consts::FRAC_1_SQRT_2;
    assert!(out[0].axis.iter().zip([h, h, 0.0]).all(|(a, b)| (a - b).abs() < 1e-6), "{:?}", out[0].axis);
    assert_eq!(PackedGuide { axis: guide.axis, ..out[0] }, guide, "only the axis changes");
    assert_eq!(out[1], guide);
    assert_eq!(out[2], PackedGuide::INVALID);
}

/// In a penumbra a camera sample takes `penumbra_rays` light samples, each weighing a quarter:
/// at equal camera samples (16 spp) the unfiltered direct light in `grids`' penumbrae (bars
/// over a floor under a Gaussian light) has less noise, more rays are traced, and the image
/// keeps the reference's energy. (In the area-lit box at this size the penumbrae are a pixel
/// or two wide, and the pixel's footprint, which more light samples leave alone, dominates.)
#[test]
fn penumbra_rays_lower_the_noise_at_equal_samples_and_keep_the_energy() {
    let s = builtin("grids", 48, 36);
    let reference = reference(s.clone(), 0, 1024.0);
    let (w, h) = (reference.width as usize, reference.height as usize);
    // The penumbrae: pixels whose converged light differs from a neighbour's by over 20%.
    let lum = |p: usize| reference.color[p].iter().sum::<f32>();
    let penumbra: Vec<usize> = (0..w * h)
        .filter(|&p| {
            let (x, y) = (p % w, p / w);
            let near = [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)];
            near.iter().any(|&(nx, ny)| nx < w && ny < h && (lum(ny * w + nx) - lum(p)).abs() > 0.2 * lum(p).max(0.05))
        })
        .collect();
    assert!(penumbra.len() > 40, "{} pixels", penumbra.len());
    let run = |rays: u32| {
        let (mut se, mut traced, mut energy) = (0.0f64, 0u64, 0.0f64);
        for seed in 1..=4 {
            let mut j = job(s.clone(), Method::Auto, 3, seed, 0);
            (j.auto.penumbra_rays, j.auto.penumbra_max_width) = (rays, f64::INFINITY);
            let f = all_frames(&j).pop().unwrap();
            let raw = f.unfiltered_color();
            se += penumbra
                .iter()
                .map(|&p| (0..3).map(|c| (raw[p][c] - reference.color[p][c]).powi(2) as f64).sum::<f64>())
                .sum::<f64>();
            traced += f.stats.rays_traced;
            energy += mean(&f.color) / 4.0;
        }
        ((se / (12 * penumbra.len()) as f64).sqrt(), traced, energy)
    };
    let (one, four) = (run(1), run(4));
    assert!(four.0 < 0.8 * one.0, "penumbra RMSE {} with 4 rays against {} with 1", four.0, one.0);
    assert!(four.1 as f64 > 1.1 * one.1 as f64, "rays {} against {}", four.1, one.1);
    let r = mean(&reference.color);
    for (rays, (_, _, m)) in [(1, one), (4, four)] {
        assert!((m / r - 1.0).abs() < 0.02, "{rays} rays: mean {m} vs {r}");
    }
}

/// The penumbra marks are set by the first pass, by the one that completes the analysis
/// samples, and by every one after; passes in between keep the first pass's.
#[test]
fn the_marks_skip_the_passes_inside_the_analysis_samples() {
    use super::{pass_target, refreshes_marks};
    let schedule = |initial: u32, analysis: u32| -> Vec<bool> {
        let targets: Vec<u32> = (0..5).map(|p| pass_target(initial, p, 0.0)).collect();
        (0..5).map(|p| refreshes_marks(if p == 0 { 0 } else { targets[p - 1] }, targets[p], analysis)).collect()
    };
    assert_eq!(schedule(1, 8), [true, false, true, true, true]);
    assert_eq!(schedule(1, 64), [true, false, false, true, true]);
    assert_eq!(schedule(8, 8), [true; 5]);
    assert_eq!(schedule(1, 1), [true; 5]);
}

/// The k light samples of a camera sample: the first is its own point, all lie in [0, 1)^2, and
/// their first coordinates are k apart by 1 / k (modulo 1), so they spread over the light.
#[test]
fn a_camera_sample_s_light_samples_spread_over_the_square() {
    use super::sample::lattice_shift;
    for u in [[0.0f32, 0.0], [0.3, 0.9], [0.999_999_9, 0.999_999_9], [0.5, 0.25]] {
        for k in 1..=8u32 {
            assert_eq!(lattice_shift(u, 0, k), u);
            let mut firsts: Vec<f32> = (0..k).map(|j| lattice_shift(u, j, k)[0]).collect();
            for j in 0..k {
                let v = lattice_shift(u, j, k);
                assert!(v.iter().all(|&c| (0.0..1.0).contains(&c)), "{u:?} ray {j} of {k}: {v:?}");
            }
            firsts.sort_by(f32::total_cmp);
            for pair in firsts.windows(2) {
                assert!((pair[1] - pair[0] - 1.0 / k as f32).abs() < 1e-5, "{u:?}, k {k}: {firsts:?}");
            }
        }
    }
}

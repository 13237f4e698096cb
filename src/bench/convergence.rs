//! Error against time and samples: renders a scene with each method, measures every frame's
//! RMSE, relative MSE and FLIP against a high-spp plain Monte Carlo reference, and derives equal-error speedups over
//! uniform unfiltered Monte Carlo (the papers' Fig. 6c / Fig. 10a measurements).
use crate::pipeline::frame::Frame;
use crate::pipeline::job::{CancelToken, Halt, Method, RenderJob};
use crate::pipeline::progressive::render;
use crate::render::scene::Scene;
use std::sync::Arc;

/// One frame of one method's progressive render.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub method: Method,
    pub pass: u32,
    pub mean_spp: f64,
    /// Wall seconds from the request to this frame.
    pub seconds: f64,
    /// Seconds spent in the method's own work (sample rates, filtering) so far.
    pub method_seconds: f64,
    /// Process CPU seconds from the request to this frame (all threads), where measurable.
    pub cpu_seconds: Option<f64>,
    pub rays: u64,
    pub rmse: f64,
    /// Mean over pixels and channels of (x - ref)^2 / (ref^2 + 0.01).
    pub rel_mse: f64,
    /// Mean LDR-FLIP error (`flip`), in [0, 1].
    pub flip: f64,
}

pub fn job(
    scene: Arc<Scene>,
    method: Method,
    max_passes: u32,
    max_mean_spp: f64,
    seed: u64,
    bounces: u32,
) -> RenderJob {
    let halt = Halt { max_passes, max_mean_spp, time_budget: None, target_error: None };
    RenderJob { seed, bounces, ..RenderJob::new(scene, method, halt) }
}

/// The last frame of a render.
pub fn final_frame(job: &RenderJob) -> Option<Frame> {
    let mut last = None;
    render(job, &CancelToken::new(), &mut |f| {
        if f.stats.is_final {
            last = Some(f.clone());
        }
        true
    })
    .ok()?;
    last
}

/// Which pixels the errors count: all but those whose reference exceeds `exclude_above` in some
/// channel (a light in view) and their 8 neighbours (its edge, whose error is the camera
/// jitter's coverage, which no filter touches), as `bench/race.py` leaves them out.
pub fn kept_pixels(reference: &Frame, exclude_above: Option<f32>) -> Vec<bool> {
    let (w, h) = (reference.width as usize, reference.height as usize);
    let Some(t) = exclude_above else { return vec![true; w * h] };
    let bright: Vec<bool> = reference.color.iter().map(|c| c.iter().any(|&v| v > t)).collect();
    (0..w * h)
        .map(|p| {
            let (x, y) = ((p % w) as isize, (p / w) as isize);
            !(-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (nx, ny) = (x + dx, y + dy);
                    nx >= 0
                        && ny >= 0
                        && (nx as usize) < w
                        && (ny as usize) < h
                        && bright[ny as usize * w + nx as usize]
                })
            })
        })
        .collect()
}

/// RMSE over the kept pixels' channels.
pub fn rmse_kept(a: &Frame, b: &Frame, keep: &[bool]) -> f64 {
    mean_over(a, b, |p| keep[p], squared).sqrt()
}

/// Relative MSE (`rel_mse`) over the kept pixels.
pub fn rel_mse_kept(a: &Frame, b: &Frame, keep: &[bool]) -> f64 {
    mean_over(a, b, |p| keep[p], relative)
}

/// Mean over pixels and channels of (x - ref)^2 / (ref^2 + 0.01).
pub fn rel_mse(a: &Frame, b: &Frame) -> f64 {
    mean_over(a, b, |_| true, relative)
}

pub fn rmse(a: &Frame, b: &Frame) -> f64 {
    mean_over(a, b, |_| true, squared).sqrt()
}

fn squared(d: f64, _reference: f64) -> f64 {
    d * d
}

fn relative(d: f64, reference: f64) -> f64 {
    d * d / (reference * reference + 0.01)
}

/// The mean over the pixels `keep` takes and their channels of `f(x - ref, ref)`.
fn mean_over(a: &Frame, b: &Frame, keep: impl Fn(usize) -> bool, f: fn(f64, f64) -> f64) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (_, (x, y)) in a.color.iter().zip(&b.color).enumerate().filter(|(p, _)| keep(*p)) {
        for c in 0..3 {
            sum += f(x[c] as f64 - y[c] as f64, y[c] as f64);
        }
        n += 3;
    }
    sum / n.max(1) as f64
}

/// Every frame of `job` as a point on its error curve, and the last frame. FLIP is computed
/// after the render (it is slower than the other metrics, and must not count in its seconds),
/// on the colour kept of each frame.
pub fn sweep(job: &RenderJob, reference: &Frame, keep: &[bool]) -> (Vec<Point>, Option<Frame>) {
    let mut points = Vec::new();
    let mut colours = Vec::new();
    let cpu0 = super::process_cpu_seconds();
    let _ = render(job, &CancelToken::new(), &mut |f| {
        colours.push(Frame { width: f.width, height: f.height, color: f.color.clone(), ..Default::default() });
        points.push(Point {
            method: job.method,
            pass: f.stats.pass,
            mean_spp: f.stats.mean_spp,
            seconds: f.stats.elapsed_seconds,
            method_seconds: f.stats.method_seconds,
            cpu_seconds: cpu0.and_then(|c| super::process_cpu_seconds().map(|n| n - c)),
            rays: f.stats.rays_traced,
            rmse: rmse_kept(f, reference, keep),
            rel_mse: rel_mse_kept(f, reference, keep),
            flip: 0.0,
        });
        true
    });
    for (p, c) in points.iter_mut().zip(&colours) {
        p.flip = super::flip::mean_flip_kept(c, reference, keep);
    }
    (points, colours.pop())
}

/// Where the baseline curve reaches `error`, by linear interpolation of log(x) against
/// log(error) between the two baseline points that bracket it; `None` outside its range.
pub fn at_error(base: &[Point], error: f64, x: impl Fn(&Point) -> f64) -> Option<f64> {
    at_metric(base, error, |q| q.rmse, x)
}

/// `at_error` on another error measure: the baseline's `x` where its `metric` equals `value`.
pub fn at_metric(base: &[Point], value: f64, metric: impl Fn(&Point) -> f64, x: impl Fn(&Point) -> f64) -> Option<f64> {
    base.windows(2).find_map(|w| {
        let (a, b) = (&w[0], &w[1]);
        let (ea, eb) = (metric(a).ln(), metric(b).ln());
        let e = value.ln();
        if !((ea >= e && e >= eb) || (ea <= e && e <= eb)) || ea == eb {
            return None;
        }
        let t = (e - ea) / (eb - ea);
        Some((x(a).ln() + t * (x(b).ln() - x(a).ln())).exp())
    })
}

/// Equal-error speedup of `p` over the baseline curve: (in samples, in seconds).
pub fn speedup(base: &[Point], p: &Point) -> (Option<f64>, Option<f64>) {
    (
        at_error(base, p.rmse, |q| q.mean_spp).map(|s| s / p.mean_spp),
        at_error(base, p.rmse, |q| q.seconds).map(|s| s / p.seconds),
    )
}

/// Equal-time speedup of `p` over the baseline curve at equal relative MSE: every pixel's
/// error weighed by its own value, so a few bright pixels (a sun's glints) cannot carry it as
/// they carry the RMSE.
pub fn relative_speedup(base: &[Point], p: &Point) -> Option<f64> {
    at_metric(base, p.rel_mse, |q| q.rel_mse, |q| q.seconds).map(|s| s / p.seconds)
}

/// Whether the error keeps falling along the curve: no step rises by more than `slack`, and
/// over the second half of the curve log(RMSE) falls at least 0.15 per unit of log(spp)
/// (plain Monte Carlo falls 0.5; a method that stops improving, like a fixed-width filter
/// whose bias takes over, does not qualify).
pub fn consistent(points: &[Point], slack: f64) -> bool {
    let monotone = points.windows(2).all(|w| w[1].rmse <= w[0].rmse * (1.0 + slack));
    let half = &points[points.len() / 2..];
    let slope = match (half.first(), half.last()) {
        (Some(a), Some(b)) if b.mean_spp > a.mean_spp => (b.rmse / a.rmse).ln() / (b.mean_spp / a.mean_spp).ln(),
        _ => return monotone,
    };
    monotone && slope <= -0.15
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(spp: f64, secs: f64, rmse: f64) -> Point {
        Point {
            method: Method::Uniform,
            pass: 0,
            mean_spp: spp,
            seconds: secs,
            method_seconds: 0.0,
            cpu_seconds: None,
            rays: 0,
            rmse,
            rel_mse: 0.0,
            flip: 0.0,
        }
    }

    #[test]
    fn a_light_and_its_edge_are_left_out_and_the_rest_counts_as_before() {
        let mut reference = Frame { width: 5, height: 4, color: vec![[0.5; 3]; 20], ..Default::default() };
        reference.color[2 * 5 + 2] = [9.0, 0.1, 0.1];
        reference.color[0] = [0.2, 3.0, 0.2];
        let keep = kept_pixels(&reference, Some(1.0));
        // The pixel at (2, 2) and its 8 neighbours; the corner and its 3, of which (1, 1) is
        // one of the first nine.
        assert_eq!(keep.iter().filter(|k| !**k).count(), 9 + 4 - 1);
        assert_eq!([keep[4], keep[19], keep[6], keep[13], keep[7]], [true, true, false, false, false]);
        assert!(kept_pixels(&reference, None).iter().all(|k| *k));
        // With every pixel kept, the plain metrics.
        let mut test = reference.clone();
        test.color[7] = [0.7, 0.5, 0.5];
        let all = vec![true; 20];
        assert_eq!(rmse_kept(&test, &reference, &all), rmse(&test, &reference));
        assert_eq!(rel_mse_kept(&test, &reference, &all), rel_mse(&test, &reference));
        // Pixel 7 is next to the light: left out, no error remains.
        assert_eq!(rmse_kept(&test, &reference, &keep), 0.0);
    }

    #[test]
    fn equal_error_interpolates_on_the_log_log_curve() {
        // Uniform MC: error ~ 1/sqrt(spp).
        let base: Vec<Point> = (0..8).map(|k| (1u32 << k) as f64).map(|s| pt(s, s * 0.1, 1.0 / s.sqrt())).collect();
        let p = pt(4.0, 0.2, 1.0 / 32f64.sqrt());
        let (s, t) = speedup(&base, &p);
        assert!((s.unwrap() - 8.0).abs() < 1e-9, "{s:?}");
        assert!((t.unwrap() - 16.0).abs() < 1e-9, "{t:?}");
        assert_eq!(speedup(&base, &pt(1.0, 1.0, 1e-9)), (None, None));
        // The same on the relative MSE (here 1/spp): the time speedup reads that measure alone.
        let mut rel = base.clone();
        rel.iter_mut().for_each(|q| (q.rmse, q.rel_mse) = (1.0, 1.0 / q.mean_spp));
        let mut q = pt(4.0, 0.2, 1.0);
        q.rel_mse = 1.0 / 32.0;
        assert!((relative_speedup(&rel, &q).unwrap() - 16.0).abs() < 1e-9);
        assert_eq!(relative_speedup(&rel, &pt(1.0, 1.0, 1.0)), None);
        assert!(consistent(&base, 0.0));
        // A plateau (bias taking over) is not consistent, nor is a rise.
        let plateau: Vec<Point> =
            (0..6).map(|k| (1u32 << k) as f64).map(|s| pt(s, s, 0.01 + 0.01 / s.sqrt())).collect();
        assert!(!consistent(&plateau, 0.02));
        let rising = vec![pt(1.0, 1.0, 0.1), pt(2.0, 2.0, 0.2)];
        assert!(!consistent(&rising, 0.02));
    }
}

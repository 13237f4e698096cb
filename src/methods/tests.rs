//! What the methods' tests share (test code: `tests/layers.rs` does not hold it to the layers).
use crate::pipeline::frame::Frame;
use crate::pipeline::job::{CancelToken, Method, RenderJob};
use crate::pipeline::progressive::render;
use crate::render::scene::Scene;
use std::sync::Arc;

/// The frames of `j`, without the AAF family's preview (pass 0): frame k is pass k + 1, the
/// k-th frame of the analysis proper. `uniform` has no preview and keeps every frame.
pub fn frames(j: &RenderJob) -> Vec<Frame> {
    let mut out = Vec::new();
    render(j, &CancelToken::new(), &mut |f| {
        if j.method == Method::Uniform || f.stats.pass > 0 {
            out.push(f.clone());
        }
        true
    })
    .expect("render");
    out
}

/// A built-in scene compiled at `w` x `h`.
pub fn builtin(name: &str, w: u32, h: u32) -> Arc<Scene> {
    let mut s = crate::scene::builtin::get(name).unwrap();
    let cam = s.camera.as_mut().unwrap();
    (cam.width, cam.height) = (w, h);
    Arc::new(crate::scene::compile(&s, &crate::scene::SceneLimits::default(), None).unwrap())
}

/// RMSE over the three channels of every pixel.
pub fn rmse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let se: f64 = a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |c| (x[c] as f64 - y[c] as f64).powi(2))).sum();
    (se / (3 * a.len()) as f64).sqrt()
}

/// Every frame of a render, pass 0 included.
pub fn all_frames(j: &RenderJob) -> Vec<Frame> {
    let mut out = Vec::new();
    render(j, &CancelToken::new(), &mut |f| {
        out.push(f.clone());
        true
    })
    .expect("render");
    out
}

/// A scene file's text, edited as JSON and compiled at `w` x `h`.
pub fn edited_scene(text: &str, w: u32, h: u32, edit: impl Fn(&mut serde_json::Value)) -> Arc<Scene> {
    let mut json: serde_json::Value = serde_json::from_str(text).unwrap();
    json["camera"]["width"] = w.into();
    json["camera"]["height"] = h.into();
    edit(&mut json);
    let s = crate::scene::json::parse_scene(&json.to_string(), "edited scene").unwrap();
    Arc::new(crate::scene::compile(&s, &crate::scene::SceneLimits::default(), None).unwrap())
}

/// Asserts that `j` (no deadline: each pass in one sweep, `StopCheck::can_cut`) gives, bit for
/// bit, the frames of the same render under a deadline it never meets (each pass in rounds),
/// and that its last pass adapted its counts (a mean of `even_spp` not spread evenly), so
/// that the rounds had extras to sweep.
pub fn assert_one_sweep_equals_the_rounds(j: &RenderJob, passes: usize, even_spp: f32) {
    let mut far = j.clone();
    far.halt.time_budget = Some(std::time::Duration::from_secs(3600));
    let (one, rounds) = (all_frames(j), all_frames(&far));
    assert_eq!((one.len(), rounds.len()), (passes, passes));
    assert!(one.last().unwrap().spp.iter().any(|&n| n != even_spp), "the last pass adapts its counts");
    for (a, b) in one.iter().zip(&rounds) {
        assert_eq!((&a.color, &a.spp), (&b.color, &b.spp), "pass {}", a.stats.pass);
    }
}

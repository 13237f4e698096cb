//! What the methods' tests share (test code: `tests/layers.rs` does not hold it to the layers).
use crate::pipeline::frame::Frame;
use crate::pipeline::job::{CancelToken, Method, RenderJob};
use crate::pipeline::progressive::render;

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

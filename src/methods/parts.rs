//! The AAF family splits the light into the parts a scene has: area-light direct light (soft
//! shadows, `aaf_shadows`, when the scene has rectangular lights) and indirect light
//! (`aaf_indirect`, when the request asks for bounces, or for ambient occlusion). Each part runs
//! its own strategy on the shared G-buffer and the frames add up; a scene with neither renders
//! as `uniform`. Tokuyoshi's lobe- and normal-aware filters (`lobe_aware`) run inside the
//! indirect strategy, which then owns direct light too.
use super::aaf_indirect::IndirectStrategy;
use super::aaf_shadows::ShadowStrategy;
use super::mode::FilterMode;
use super::uniform::Uniform;
use crate::pipeline::job::{Integrand, RenderJob};
use crate::pipeline::strategy::{Strategy, SumOfParts};
use crate::render::light::Light;

/// Which parts of the light a method of this family renders for `job` in `mode`: (soft
/// shadows, indirect). Tokuyoshi's filters are for indirect light only: in their modes the
/// indirect strategy also owns direct light, by plain sampling.
pub fn parts(job: &RenderJob, mode: FilterMode) -> (bool, bool) {
    let ao = matches!(job.integrand, Integrand::AmbientOcclusion { .. });
    let shadows = !ao && !mode.indirect_owns_direct() && job.scene.lights.iter().any(|l| matches!(l, Light::Rect(_)));
    (shadows, ao || job.bounces > 0)
}

/// The strategy of a method of this family in `mode`.
pub fn build(job: &RenderJob, mode: FilterMode) -> Box<dyn Strategy> {
    match parts(job, mode) {
        (false, false) => Box::new(Uniform::new(job)),
        (true, false) => Box::new(ShadowStrategy::new(job, mode)),
        (false, true) => Box::new(IndirectStrategy::new(job, mode, true)),
        (true, true) => Box::new(SumOfParts {
            parts: vec![Box::new(ShadowStrategy::new(job, mode)), Box::new(IndirectStrategy::new(job, mode, false))],
        }),
    }
}

/// The per-component maps a frame of `job` in `mode` carries, in order.
pub fn component_names(job: &RenderJob, mode: FilterMode) -> Vec<&'static str> {
    let (shadows, indirect) = parts(job, mode);
    let ao = matches!(job.integrand, Integrand::AmbientOcclusion { .. });
    let mut names = Vec::new();
    if shadows {
        names.push("shadow");
    }
    if indirect {
        names.push("diffuse");
        if !ao && job.scene.glossy {
            names.push("glossy");
        }
    }
    names
}

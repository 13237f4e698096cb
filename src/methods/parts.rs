//! The AAF family splits the light into the parts a scene has: area-light direct light (soft
//! shadows, `aaf_shadows`, when the scene has rectangular lights) and indirect light
//! (`aaf_indirect`, when the request asks for bounces, or for ambient occlusion). Each part runs
//! its own strategy on the shared G-buffer and the frames add up; a scene with neither renders
//! as `uniform`.
use super::aaf_indirect::IndirectStrategy;
use super::aaf_shadows::ShadowStrategy;
use super::mode::FilterMode;
use super::uniform::Uniform;
use crate::pipeline::job::{Integrand, RenderJob};
use crate::pipeline::strategy::{Strategy, SumOfParts};
use crate::render::light::Light;

/// Which parts of the light the AAF family renders for `job`: (soft shadows, indirect).
pub fn parts(job: &RenderJob) -> (bool, bool) {
    let ao = matches!(job.integrand, Integrand::AmbientOcclusion { .. });
    let shadows = !ao && job.scene.lights.iter().any(|l| matches!(l, Light::Rect(_)));
    (shadows, ao || job.bounces > 0)
}

/// The strategy of an AAF-family method in `mode`.
pub fn build(job: &RenderJob, mode: FilterMode) -> Box<dyn Strategy> {
    match parts(job) {
        (false, false) => Box::new(Uniform::new(job)),
        (true, false) => Box::new(ShadowStrategy::new(job, mode)),
        (false, true) => Box::new(IndirectStrategy::new(job, mode, true)),
        (true, true) => Box::new(SumOfParts {
            parts: vec![Box::new(ShadowStrategy::new(job, mode)), Box::new(IndirectStrategy::new(job, mode, false))],
        }),
    }
}

/// The per-component maps an AAF-family frame of `job` carries, in order.
pub fn component_names(job: &RenderJob) -> Vec<&'static str> {
    let (shadows, indirect) = parts(job);
    let ao = matches!(job.integrand, Integrand::AmbientOcclusion { .. });
    let mut names = Vec::new();
    if shadows {
        names.push("shadow");
    }
    if indirect {
        names.push("diffuse");
        if !ao && IndirectStrategy::has_glossy(&job.scene) {
            names.push("glossy");
        }
    }
    names
}

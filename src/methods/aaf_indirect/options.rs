//! The options of AAF indirect light: plain data the render job carries (`pipeline::job`).
use super::params::IndirectConstants;
use crate::render::filter::FilterOptions;

/// Parameters; the defaults are the paper's (Sec. 4-6).
#[derive(Clone, Debug, PartialEq)]
pub struct IndirectOptions {
    pub constants: IndirectConstants,
    /// Filter scale of passes 0 to 2; pass k >= 2 uses mu0 * 2^(k-2) (the paper renders its
    /// images at 0.9).
    pub mu0: f64,
    /// Samples per pixel of the initial analysis (Sec. 5: 16, stratified 4 x 4 by the Sobol
    /// sampler), taken over passes 0 and 1.
    pub initial_samples: u32,
    /// Samples per pixel of pass 0, the preview: the first of the initial samples, filtered
    /// with the reflector distances they found, so that a first frame comes at once; pass 1
    /// completes the initial samples (the paper renders them whole before any image).
    pub preview_samples: u32,
    /// Multiplies the filter's standard deviation (1: the paper; 0.25: the authors' code).
    pub kernel_scale: f64,
    /// Divide the projected pixel size by |n . view| (the paper's d "accounts for
    /// foreshortening", footnote 7). Off by default, as in the authors' code and methods.md
    /// §0.1: the filter is isotropic, and a foreshortened d (the footprint's long axis) keeps
    /// it several pixels wide across the short axis of grazing surfaces, so the stream reaches
    /// the per-pixel mean there only about 1/|n . view| times later in mu.
    pub foreshortening: bool,
    /// 10-degree normal threshold (Sec. 6), world distances, radius up to 50 pixels.
    pub filter: FilterOptions,
    /// Filter width in pixels of the `uniform-filtered` baseline.
    pub fixed_filter_px: f64,
}

impl Default for IndirectOptions {
    fn default() -> Self {
        IndirectOptions {
            constants: IndirectConstants::default(),
            mu0: 0.9,
            initial_samples: 16,
            preview_samples: 1,
            kernel_scale: 1.0,
            foreshortening: false,
            filter: FilterOptions {
                max_normal_angle_deg: 10.0,
                object_id_check: false,
                max_radius: 50,
                tangent_plane: false,
            },
            fixed_filter_px: 4.0,
        }
    }
}

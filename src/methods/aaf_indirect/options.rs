//! The options of AAF indirect light: plain data the render job carries (`pipeline::job`).
use super::params::IndirectConstants;
use crate::pipeline::settings::{Settable, Setting, Value};
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

/// `--set indirect.NAME=VALUE`: the paper's constants and the schedule. The limits keep a test
/// render at each of them to seconds (mu and the sample bounds set the samples).
impl Settable for IndirectOptions {
    const GROUP: &'static str = "indirect";

    fn settings() -> &'static [Setting] {
        const SETTINGS: &[Setting] = &[
            Setting::number("alpha", 0.01, 10.0),
            Setting::number("omega_h_diffuse", 0.1, 100.0),
            Setting::number("gamma_diffuse", 0.01, 10.0),
            Setting::number("min_samples", 1.0, 256.0),
            Setting::number("max_samples", 1.0, 1000.0),
            Setting::number("z_min_fraction", 0.0, 1.0),
            Setting::number("mu0", 0.1, 8.0),
            Setting::integer("initial_samples", 1, 64),
            Setting::integer("preview_samples", 1, 64),
            Setting::number("kernel_scale", 0.0, 16.0),
            Setting::flag("foreshortening"),
            Setting::number("fixed_filter_px", 0.0, 32.0),
        ];
        SETTINGS
    }

    fn apply(&mut self, name: &str, v: Value) {
        match name {
            "alpha" => self.constants.alpha = v.number(),
            "omega_h_diffuse" => self.constants.omega_h_diffuse = v.number(),
            "gamma_diffuse" => self.constants.gamma_diffuse = v.number(),
            "min_samples" => self.constants.min_samples = v.number(),
            "max_samples" => self.constants.max_samples = v.number(),
            "z_min_fraction" => self.constants.z_min_fraction = v.number(),
            "mu0" => self.mu0 = v.number(),
            "initial_samples" => self.initial_samples = v.integer() as u32,
            "preview_samples" => self.preview_samples = v.integer() as u32,
            "kernel_scale" => self.kernel_scale = v.number(),
            "foreshortening" => self.foreshortening = v.flag(),
            "fixed_filter_px" => self.fixed_filter_px = v.number(),
            _ => unreachable!("{name} is in `settings`"),
        }
    }
}

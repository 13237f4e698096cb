//! What a pass produces: the displayed image plus the maps the method chose, and run metadata.
use crate::render::aovs::Aovs;
use std::sync::Arc;

/// Why a render stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum HaltReason {
    /// Not halted (an intermediate frame).
    #[default]
    None,
    MaxPasses,
    MaxSpp,
    /// The time budget ended the render; `FrameStats::pass_complete` says whether the last
    /// pass got all its samples.
    TimeBudget,
    /// The render's own estimate of its relative RMSE reached the target.
    NoiseTarget,
}

/// Numbers describing one frame of a progressive render.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// 0-based pass index.
    pub pass: u32,
    pub mean_spp: f64,
    /// All rays traced so far (camera, shadow and bounce rays).
    pub rays_traced: u64,
    pub elapsed_seconds: f64,
    pub is_final: bool,
    pub halt_reason: HaltReason,
    /// Non-finite samples dropped so far.
    pub dropped_samples: u64,
    /// Seconds spent so far in the method's own work (sample rates, filter), not in tracing.
    pub method_seconds: f64,
    /// Whether every pixel got this pass's samples (false when the deadline cut the pass: the
    /// frame still estimates every pixel, some with the samples of the passes before).
    pub pass_complete: bool,
    /// The render's own estimate of this frame's relative RMSE (`pipeline::noise`); None for
    /// the first frame, which has nothing to compare with.
    pub estimated_error: Option<f64>,
    /// For methods that shade at a reduced rate (`bandwidth`): camera samples shaded in this
    /// pass, and camera samples traced in it (what shading at full resolution would shade).
    /// Both 0 for methods that shade every sample.
    pub shaded_points: u64,
    pub full_resolution_points: u64,
}

/// One progressively refined frame. Pixels are row-major, top row first.
#[derive(Clone, Debug, Default)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// The displayed colour (filtered where the method filters).
    pub color: Vec<[f32; 3]>,
    /// The per-pixel Monte Carlo mean before filtering; `None` when the method does not filter
    /// (then it equals `color`).
    pub unfiltered: Option<Vec<[f32; 3]>>,
    /// Samples per pixel accumulated so far.
    pub spp: Vec<f32>,
    /// Filter width (standard deviation, in pixels) used at each pixel; `None` when the method
    /// does not filter (all zero).
    pub filter_width: Option<Vec<f32>>,
    /// Per-component maps of methods that sample and filter parts of the light separately
    /// (AAF: `shadow`, `diffuse`, `glossy`); empty for the others. `spp` above is their total.
    pub components: Vec<ComponentMaps>,
    /// Denoiser inputs (first-hit albedo, normal, depth) when the job asks for them: the same
    /// for every frame of a render, so shared.
    pub aovs: Option<Arc<Aovs>>,
    /// The maps of methods that shade at a predicted rate (`bandwidth`); `None` for the others.
    pub shading: Option<ShadingMaps>,
    pub stats: FrameStats,
}

/// Where a method that predicts bandwidth (Bagher et al. 2012) shaded, and how finely.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadingMaps {
    /// The predicted image-space bandwidth `b_p` (Eq. 5), cycles per pixel: 0.5 is the pixel
    /// rate; infinite where not band-limited.
    pub bandwidth: Vec<f32>,
    /// The level of this pass (Eq. 9's, lowered by the passes): a spacing exponent, 0 for every
    /// pixel, k for every 2^k-th, -1 and -2 for 4 and 16 times the camera samples.
    pub level: Vec<f32>,
    /// Seconds the render spent predicting bandwidth (the analysis, before pass 0's samples).
    pub analysis_seconds: f64,
}

/// The samples and filter width one component of the light received at each pixel.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ComponentMaps {
    /// `shadow` (area-light direct light), `diffuse` or `glossy` (indirect light).
    pub name: String,
    pub spp: Vec<f32>,
    /// Filter width (standard deviation, in pixels); `None` when the component is unfiltered.
    pub filter_width: Option<Vec<f32>>,
}

impl Frame {
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The unfiltered colour, which is `color` itself for unfiltered methods.
    pub fn unfiltered_color(&self) -> &[[f32; 3]] {
        self.unfiltered.as_deref().unwrap_or(&self.color)
    }

    /// The filter width at pixel `i` (0 where unfiltered).
    pub fn filter_width_at(&self, i: usize) -> f32 {
        self.filter_width.as_ref().map_or(0.0, |w| w[i])
    }
}

/// The camera as the request stated it, for output metadata.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraInfo {
    pub position: [f32; 3],
    pub look_at: [f32; 3],
    pub up: [f32; 3],
    pub vertical_fov_deg: f32,
}

/// What produced a frame: recorded in output file headers.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderInfo {
    /// Built-in scene name or scene file path.
    pub scene: String,
    /// Method name as on the CLI (`uniform`, ...).
    pub method: String,
    pub seed: u64,
    pub bounces: u32,
    pub camera: CameraInfo,
}

//! Options of the lobe-aware filter (Tokuyoshi 2015) and of its normal-aware baseline.
use super::filter::Gather;
use crate::pipeline::settings::{Settable, Setting, Value};

/// How a pixel's lobe is built (App. B), and where the warp degenerates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeOptions {
    /// Lower clamp of `n.psi` in the warp `lambda' / (4 n.psi)` (BakingLab's 0.1).
    pub min_cos_view: f64,
    /// Cap of any lobe's sharpness.
    pub max_sharpness: f64,
    /// The glossy lobes' shape: one SG (Eq. 12, the paper's main form) or an ASG (Eq. 13).
    pub shape: LobeShape,
}

/// The glossy lobes' shape (Sec. 4.1 and 4.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LobeShape {
    /// An SG with App. B's warp, compared by Eq. 12.
    #[default]
    Sg,
    /// An ASG (the warp's two stretches kept apart), compared by Eq. 13 where both lobes are
    /// high-frequency and by Eq. 12 elsewhere (`asg::ln_weight`). The paper's option for
    /// non-low-frequency lobes: dearer per weight. Only the f64 gather (`filter`) reads it;
    /// `auto`'s packed gather keeps Eq. 12.
    Asg,
}

impl Default for LobeOptions {
    fn default() -> Self {
        LobeOptions { min_cos_view: 0.1, max_sharpness: 1e6, shape: LobeShape::Sg }
    }
}

/// The weights' parameters (Sec. 3, Eq. 9-10, Eq. 3, Eq. 4; values of Sec. 5 and methods.md §3.4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightOptions {
    /// The power beta of `w = q^beta` (Figs. 14 and D.2 use 20).
    pub beta: f64,
    /// The smoothing kernel's sharpness kappa (Eq. 9): infinite for one-bounce light, 100 for
    /// multi-bounce path tracing and for upsampling.
    pub kappa: f64,
    /// The normal-aware baseline's variance sigma_n^2 (Eq. 4; Fig. 14 uses 0.01).
    pub sigma_n2: f64,
    /// The depth weight's variance sigma_z^2 (Eq. 3), relative to the centre pixel's depth
    /// squared, so that it does not depend on the scene's units.
    pub sigma_z2_relative: f64,
}

impl Default for WeightOptions {
    fn default() -> Self {
        WeightOptions { beta: 20.0, kappa: 100.0, sigma_n2: 0.01, sigma_z2_relative: 0.01 }
    }
}

impl WeightOptions {
    /// kappa for a render of `bounces` indirect bounces (Sec. 4.1: the first bounce's noise
    /// is beta's to control, later bounces' kappa's).
    pub fn kappa_for(bounces: u32) -> f64 {
        if bounces <= 1 {
            f64::INFINITY
        } else {
            100.0
        }
    }
}

/// Everything the `lobe-aware` and `normal-aware` methods take.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeAwareOptions {
    pub lobe: LobeOptions,
    pub weights: WeightOptions,
    /// kappa (Eq. 9) from the render's bounces (`WeightOptions::kappa_for`) rather than
    /// `weights.kappa`.
    pub kappa_from_bounces: bool,
    /// Standard deviation of the screen-space kernel f of the first passes, in pixels (the
    /// paper's 8 px radius at 3 sigma).
    pub sigma0_px: f64,
    /// The kernel narrows as sigma0 (n / n0)^(-refine_exponent) with the samples per pixel n, so
    /// that the stream converges to the unfiltered Monte Carlo mean; 1/6 balances a bias that
    /// grows as sigma^2 against a variance falling as 1 / (n sigma^2).
    pub refine_exponent: f64,
    /// Kernel radius cap in pixels (the paper times 8 and 16).
    pub max_radius: usize,
    /// The full 2-D gather of Eq. 1 or its separable approximation (the default).
    pub gather: Gather,
    /// Indirect light traced at reduced resolution and upsampled (Sec. 5; off by default).
    pub upsample: UpsampleOptions,
}

/// Joint upsampling (Sec. 5) and the adaptive re-render (Fig. 16) of the lobe- and
/// normal-aware methods: indirect light traced at the sites of a grid every `factor` pixels,
/// filtered there, and upsampled to the other pixels; pixels whose upsampling weights sum below
/// `rerender_below` trace their own. Every pixel still traces its own camera rays and direct
/// light. Passes whose samples per pixel reach `full_resolution_spp` trace indirect light at
/// every pixel, so that the stream converges to the unfiltered Monte Carlo mean.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpsampleOptions {
    /// 1 (no upsampling), 2 (half resolution) or 4 (quarter), up to `MAX_UPSAMPLE_FACTOR`.
    pub factor: u32,
    /// The first pass whose samples per pixel reach this traces every pixel.
    pub full_resolution_spp: u32,
    /// Fig. 16's threshold on the weight sum.
    pub rerender_below: f64,
    /// kappa (Eq. 9) of the upsampling weights' lobes (Sec. 5: 100).
    pub kappa: f64,
}

/// The largest upsampling factor: an 8 x 8 block is already coarser than the filter's kernel.
pub const MAX_UPSAMPLE_FACTOR: u32 = 8;

impl Default for UpsampleOptions {
    fn default() -> Self {
        UpsampleOptions { factor: 1, full_resolution_spp: 256, rerender_below: 0.25, kappa: 100.0 }
    }
}

impl UpsampleOptions {
    /// Whether a pass that brings every pixel to `spp` samples traces indirect light at the
    /// sites only.
    pub fn active(&self, spp: u32) -> bool {
        self.factor > 1 && spp < self.full_resolution_spp
    }
}

impl Default for LobeAwareOptions {
    fn default() -> Self {
        LobeAwareOptions {
            lobe: LobeOptions::default(),
            weights: WeightOptions::default(),
            kappa_from_bounces: true,
            sigma0_px: 8.0 / 3.0,
            refine_exponent: 1.0 / 6.0,
            max_radius: 16,
            gather: Gather::Separable,
            upsample: UpsampleOptions::default(),
        }
    }
}

impl LobeAwareOptions {
    /// The screen kernel's standard deviation at `spp` samples per pixel of which the first
    /// `initial` are the first pass's.
    pub fn sigma_px(&self, spp: f64, initial: f64) -> f64 {
        self.sigma0_px * (spp / initial.max(1.0)).max(1.0).powf(-self.refine_exponent)
    }

    /// kappa for a render of `bounces` bounces.
    pub fn kappa(&self, bounces: u32) -> f64 {
        if self.kappa_from_bounces {
            WeightOptions::kappa_for(bounces)
        } else {
            self.weights.kappa
        }
    }
}

impl Settable for LobeAwareOptions {
    const GROUP: &'static str = "lobe";

    fn settings() -> &'static [Setting] {
        const SETTINGS: &[Setting] = &[
            Setting::number("sigma0_px", 0.0, 16.0),
            Setting::number("refine_exponent", 0.0, 1.0),
            Setting::integer("max_radius", 1, 64),
            Setting::flag("kappa_from_bounces"),
            Setting::choice("gather", &["separable", "full"]),
            Setting::number("weights.beta", 0.0, 1000.0),
            Setting::number("weights.kappa", 0.01, 1e6),
            Setting::number("weights.sigma_n2", 1e-6, 100.0),
            Setting::number("weights.sigma_z2_relative", 0.0, 100.0),
            Setting::number("lobe.min_cos_view", 1e-3, 1.0),
            Setting::number("lobe.max_sharpness", 1.0, 1e12),
            Setting::choice("lobe.shape", &["sg", "asg"]),
            Setting::integer("upsample.factor", 1, MAX_UPSAMPLE_FACTOR as u64),
            Setting::integer("upsample.full_resolution_spp", 1, 1 << 20),
            Setting::number("upsample.rerender_below", 0.0, 1.0),
            Setting::number("upsample.kappa", 0.01, 1e6),
        ];
        SETTINGS
    }

    fn apply(&mut self, name: &str, v: Value) {
        match name {
            "sigma0_px" => self.sigma0_px = v.number(),
            "refine_exponent" => self.refine_exponent = v.number(),
            "max_radius" => self.max_radius = v.integer() as usize,
            "kappa_from_bounces" => self.kappa_from_bounces = v.flag(),
            "gather" => self.gather = [Gather::Separable, Gather::Full][v.choice()],
            "weights.beta" => self.weights.beta = v.number(),
            "weights.kappa" => self.weights.kappa = v.number(),
            "weights.sigma_n2" => self.weights.sigma_n2 = v.number(),
            "weights.sigma_z2_relative" => self.weights.sigma_z2_relative = v.number(),
            "lobe.min_cos_view" => self.lobe.min_cos_view = v.number(),
            "lobe.max_sharpness" => self.lobe.max_sharpness = v.number(),
            "lobe.shape" => self.lobe.shape = [LobeShape::Sg, LobeShape::Asg][v.choice()],
            "upsample.factor" => self.upsample.factor = v.integer() as u32,
            "upsample.full_resolution_spp" => self.upsample.full_resolution_spp = v.integer() as u32,
            "upsample.rerender_below" => self.upsample.rerender_below = v.number(),
            "upsample.kappa" => self.upsample.kappa = v.number(),
            _ => unreachable!("{name} is in `settings`"),
        }
    }
}

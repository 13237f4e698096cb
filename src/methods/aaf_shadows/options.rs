//! The options of AAF soft shadows: plain data the render job carries (`pipeline::job`), so it
//! imports only the core and the method's own constants.
use super::params::AafConstants;
use crate::pipeline::settings::{Settable, Setting, Value};
use crate::render::filter::FilterOptions;

/// Parameters. k, alpha, the 9 sparse samples, the 5-pixel fill and the 20-degree normal check
/// are the paper's (Sec. 6), and the 20-degree check the authors' code's. mu runs 1, 1, 2, 4,
/// 8, ...: the preview (1 sample) and the sparse samples (9) filtered at `first_mu` = 1, the
/// critical filter of Sec. 5, then the paper's mu = 2 (mu0) with Eq. 21's samples, doubling
/// each pass. At 9 samples the filtered error is mostly
/// variance where the light holds its tails (`grids-3sigma`: 60 times the bias at mu = 2),
/// so the wider filter of mu = 1 pays there; where the error is bias (`curved`), it costs.
/// BENCHMARKS.md has both. Starting Eq. 21's passes at mu = 1 was measured worse on `curved`
/// (bias about 100 times the variance at mu = 1).
#[derive(Clone, Debug, PartialEq)]
pub struct AafOptions {
    pub constants: AafConstants,
    /// mu of pass 2, the first with Eq. 21's samples; pass k >= 2 uses mu0 * 2^(k-2) (Sec. 5.2).
    /// The paper's is 2.
    pub mu0: f64,
    /// mu of the first two frames, the preview and the 9 sparse samples filtered: fewer
    /// samples than Eq. 21 asks for at mu0 wherever there is a penumbra.
    pub first_mu: f64,
    /// Which sigma of a Gaussian light Eqs. 13 and 15 take (`LightSigma`).
    pub light_sigma: LightSigma,
    /// Multiplies mu for uniform (non-Gaussian) lights: the paper needed mu = 3 where it used
    /// mu = 2 for Gaussian lights (Sec. 7, Fig. 11b), i.e. 1.5.
    pub uniform_light_mu_scale: f64,
    /// Samples per pixel and light of the sparse analysis (Sec. 6: 9), taken over the first two
    /// passes: `preview_samples` in pass 0, the rest in pass 1.
    pub sparse_samples: u32,
    /// Samples per pixel and light of pass 0, the preview: the first of the sparse samples,
    /// filtered with the slopes they found, so that a first frame comes at once (not the
    /// paper's, which renders the sparse pass whole before any image).
    pub preview_samples: u32,
    /// Most samples per pixel and light at mu = 1; the cap grows as mu^2, like n itself.
    pub cap: f64,
    /// Unoccluded pixels take the mean slopes of occluded pixels within this radius (Sec. 6).
    pub fill_radius: u32,
    /// Divide the projected pixel size by |n . view| (the paper's d "accounts for
    /// foreshortening"); the authors' code left it out.
    pub foreshortening: bool,
    pub filter: FilterOptions,
    /// Filter width in pixels of the `uniform-filtered` baseline.
    pub fixed_filter_px: f64,
    /// Antialiasing with jittered samples (not the paper's: it shades pixel centres): a pixel
    /// also gets the samples its own spread of r(x) and of the other light asks for, so that
    /// their standard error is at most this fraction of the image's mean value at mu0, halving
    /// as mu doubles. 0 turns it off.
    pub antialias_error: f64,
}

impl Default for AafOptions {
    fn default() -> Self {
        AafOptions {
            constants: AafConstants::default(),
            mu0: 2.0,
            first_mu: 1.0,
            light_sigma: LightSigma::Emitted,
            uniform_light_mu_scale: 1.5,
            sparse_samples: 9,
            preview_samples: 1,
            cap: 100.0,
            fill_radius: 5,
            foreshortening: true,
            filter: FilterOptions::default(),
            fixed_filter_px: 2.0,
            antialias_error: 0.1,
        }
    }
}

/// The sigma of a Gaussian light in the filter width (Eq. 13) and the sample count (Eq. 15).
/// The paper's analysis takes the light to be a Gaussian of standard deviation sigma
/// (Sec. 4: Omega_L = 1/sigma, effective width 2 sigma). A rectangle cuts that Gaussian off,
/// and what it emits is narrower than sigma: the authors' rectangle spans +-1 sigma, and the
/// light it emits has a standard deviation of 0.54 sigma, as wide as a uniform light of the
/// same size (0.58).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightSigma {
    /// The standard deviation of the emitted power (`RectLight::emission_std`): the Gaussian
    /// the paper models is the one that spreads like the light does. Equal to sigma for a
    /// light that holds its tails (0.987 sigma at +-3 sigma).
    Emitted,
    /// The profile's own sigma, whatever the rectangle cuts off: the authors' code.
    Profile,
}

/// `--set aaf.NAME=VALUE`: the paper's constants and the schedule. The limits keep a test
/// render at each of them to seconds (mu and the cap set the samples, as mu^2 times the cap).
impl Settable for AafOptions {
    const GROUP: &'static str = "aaf";

    fn settings() -> &'static [Setting] {
        const SETTINGS: &[Setting] = &[
            Setting::number("k", 0.1, 20.0),
            Setting::number("alpha", 0.1, 10.0),
            Setting::number("mu0", 0.25, 8.0),
            Setting::number("first_mu", 0.25, 8.0),
            Setting::choice("light_sigma", &["emitted", "profile"]),
            Setting::number("uniform_light_mu_scale", 0.25, 8.0),
            Setting::integer("sparse_samples", 1, 64),
            Setting::integer("preview_samples", 1, 64),
            Setting::number("cap", 1.0, 1000.0),
            Setting::integer("fill_radius", 0, 16),
            Setting::flag("foreshortening"),
            Setting::number("fixed_filter_px", 0.0, 32.0),
            Setting::number("antialias_error", 0.0, 1.0),
        ];
        SETTINGS
    }

    fn apply(&mut self, name: &str, v: Value) {
        match name {
            "k" => self.constants.k = v.number(),
            "alpha" => self.constants.alpha = v.number(),
            "mu0" => self.mu0 = v.number(),
            "first_mu" => self.first_mu = v.number(),
            "light_sigma" => self.light_sigma = [LightSigma::Emitted, LightSigma::Profile][v.choice()],
            "uniform_light_mu_scale" => self.uniform_light_mu_scale = v.number(),
            "sparse_samples" => self.sparse_samples = v.integer() as u32,
            "preview_samples" => self.preview_samples = v.integer() as u32,
            "cap" => self.cap = v.number(),
            "fill_radius" => self.fill_radius = v.integer() as u32,
            "foreshortening" => self.foreshortening = v.flag(),
            "fixed_filter_px" => self.fixed_filter_px = v.number(),
            "antialias_error" => self.antialias_error = v.number(),
            _ => unreachable!("{name} is in `settings`"),
        }
    }
}

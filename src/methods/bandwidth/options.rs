//! Options of the `bandwidth` method (Bagher et al. 2012): the analysis' constants, the shading
//! budget and the upsampling weights. Plain data, so that `pipeline::job` can hold it.
use super::illumination::WaveletOptions;
use super::upsample::UpsampleOptions;
use super::vector::{BrdfClip, Propagation};
use super::wavelet::Basis;
use crate::pipeline::allocation::Proportional;
use crate::pipeline::settings::{Settable, Setting, Value};

/// How the shaded, unshadowed light `S_hat` meets the shadows each camera sample traces (the
/// paper shades unshadowed light; wedge's images have shadows).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Visibility {
    /// `S_hat * sum(shadowed) / sum(unshadowed)` over the pixel's samples, per channel (the
    /// ratio estimator of Heitz et al. 2018): exact where a pixel is wholly lit or wholly in
    /// shadow, consistent (biased by O(1/n)) in penumbrae.
    #[default]
    Ratio,
    /// `S_hat + mean(shadowed - unshadowed)`: unbiased, but in shadow the difference carries
    /// the full noise of the unshadowed samples.
    ControlVariate,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandwidthOptions {
    /// Light directions per pixel of Eq. 4 (`n_b`; the paper's Fig. 12 finds 16 enough).
    pub light_samples: u32,
    /// Eq. 4 divided by its own weights (`L rho cos`) rather than by `sum L` as printed.
    pub normalised: bool,
    /// `|M| nu` (bounding boxes, default) or the paper's signed `M nu`.
    pub propagation: Propagation,
    /// How the BRDF band-limits a reflection (`vector::BrdfClip`).
    pub brdf_clip: BrdfClip,
    /// Eq. 9 read with Shannon's rate: the spacing is `1 / (2 b_p)` pixels for `b_p` in cycles
    /// per pixel (the bandwidth is a half-extent, so two samples per cycle suffice). Off, Eq. 9
    /// as printed: spacing `1 / b_p` with `b_p` in radians per pixel (the wavelets' `2 pi /
    /// period`), which shades pi times more densely than Nyquist asks.
    pub nyquist: bool,
    /// How the environment's and the BRDFs' bandwidths are estimated.
    pub wavelets: WaveletOptions,
    /// Textures' estimates: the amplitude basis by default, the one in which a checker's edges
    /// read sharper than its squares (methods.md §4.1).
    pub texture_wavelets: WaveletOptions,
    /// Raster resolution of a checker square for its wavelet estimate (at most
    /// `texture::MAX_TEXELS_PER_SQUARE`). The edges read as the raster's finest level, so this
    /// is the bandwidth they get; 2 reads a checker at the scale of its squares and leaves its
    /// edges to the image-space edge test.
    pub texels_per_square: u32,
    /// Allow the antialiasing levels -1 and -2 (4 and 16 times the pass's camera samples)
    /// where the bandwidth is above the pixel rate. Off by default: every pass jitters its
    /// camera samples over the pixel anyway, so the levels only move samples to those pixels,
    /// and at equal time that cost more error elsewhere than it saved (BENCHMARKS.md).
    pub antialiasing: bool,
    /// Analyse the pixels of grid 1 (every second pixel along x and y) first, and the others
    /// only where their neighbours there ask for a spacing under 8 pixels or an edge is near;
    /// elsewhere a pixel takes its neighbours' results (`analysis::coarse_then_fine`). A
    /// departure (the paper analyses every pixel): in smooth regions three pixels in four skip
    /// the 16 light directions of Eq. 4.
    pub coarse_analysis: bool,
    /// Mean lookups (pairs of light- and BRDF-sampled directions, no rays) per camera sample
    /// of a shaded pixel, shared out by the variance bound (Eq. 8); `N_tot` of Sec. 2.3 is
    /// this times the shaded samples of the pass.
    pub lookups_per_sample: f64,
    /// Multiply a shaded sample's lookups by the square root of its pixel's influence (the
    /// summed squared weight with which its `S_hat` reaches the pixels that take it,
    /// `grid::Upsampling::influence`), a departure: Eq. 8 shares the budget as if every shaded
    /// point were one pixel, but a parent's noise reaches all its children, and minimising the
    /// image's summed error `sum I_p V_p / N_p` for a given cost `sum N_p` gives
    /// `N_p ~ sqrt(I_p V_p)`. At full resolution every influence is 1 and nothing changes.
    pub lookups_by_influence: bool,
    /// No shaded sample gets more lookups than this.
    pub max_lookups: u32,
    /// Levels every pass lowers all levels by, so that the render reaches full resolution
    /// (and from there converges to the `uniform` image) after `coarsest / level_step` passes.
    pub level_step: u32,
    /// The upsampling weights' scales (Sec. 3.2, unspecified in the paper).
    pub upsample: UpsampleOptions,
    /// Take values only from parents on the pixel's own object with its own BRDF parameters (a
    /// departure: a sphere resting on a floor touches it at equal depth, where the depth
    /// weight cannot tell them apart, and a parent across a texture's edge would bring the
    /// other side's albedo; the pixel's own edge test sees only its 4-neighbours).
    pub same_object: bool,
    pub visibility: Visibility,
    /// From the pass whose mean count reaches this many camera samples per pixel on,
    /// `adaptive_share` of each pass goes to the pixels whose samples vary most (`counts`, a
    /// departure: the paper samples every pixel alike and shares out only its lookups); 0: the
    /// same count everywhere. Off with `antialiasing`, whose levels set the counts themselves.
    pub adaptive_from_spp: u32,
    /// That share, in [0, 1]; the rest is spread evenly, so that every pixel converges.
    pub adaptive_share: f64,
    /// Every pixel gets at least this many samples of a pass before its adaptive part.
    pub adaptive_min_spp: u32,
    /// No pixel asks for more than this many times the pass's mean count.
    pub adaptive_max_ratio: f64,
    /// Eq. 4's `n_b` light directions are drawn once per square tile of this many pixels a
    /// side and shared by its pixels (a departure: the paper draws them per pixel); 1: per
    /// pixel. The directions are what the environment's distribution gives, the same for
    /// every pixel in expectation; drawing them per pixel was most of the analysis' time.
    pub light_tile: u32,
}

impl BandwidthOptions {
    /// How the adaptive passes share out their camera samples.
    pub fn proportional(&self) -> Proportional {
        Proportional { share: self.adaptive_share, min_spp: self.adaptive_min_spp, max_ratio: self.adaptive_max_ratio }
    }
}

impl Default for BandwidthOptions {
    fn default() -> Self {
        BandwidthOptions {
            light_samples: 16,
            normalised: true,
            propagation: Propagation::BoundingBox,
            brdf_clip: BrdfClip::Spectrum,
            nyquist: true,
            wavelets: WaveletOptions::default(),
            texture_wavelets: WaveletOptions { basis: Basis::Amplitude, ..WaveletOptions::default() },
            texels_per_square: 2,
            antialiasing: false,
            coarse_analysis: true,
            lookups_per_sample: 4.0,
            lookups_by_influence: true,
            max_lookups: 256,
            level_step: 1,
            upsample: UpsampleOptions::default(),
            same_object: true,
            visibility: Visibility::Ratio,
            adaptive_from_spp: 4,
            adaptive_share: 0.5,
            adaptive_min_spp: 4,
            adaptive_max_ratio: 8.0,
            light_tile: 8,
        }
    }
}

impl Settable for BandwidthOptions {
    const GROUP: &'static str = "bandwidth";

    fn settings() -> &'static [Setting] {
        const SETTINGS: &[Setting] = &[
            Setting::integer("light_samples", 1, 256),
            Setting::flag("normalised"),
            Setting::choice("propagation", &["bounding-box", "signed"]),
            Setting::choice("brdf_clip", &["spectrum", "angle"]),
            Setting::flag("nyquist"),
            Setting::integer("texels_per_square", 1, super::texture::MAX_TEXELS_PER_SQUARE as u64),
            Setting::flag("antialiasing"),
            Setting::flag("coarse_analysis"),
            Setting::number("lookups_per_sample", 0.25, 256.0),
            Setting::flag("lookups_by_influence"),
            Setting::integer("max_lookups", 1, 65536),
            Setting::integer("level_step", 1, 16),
            Setting::flag("same_object"),
            Setting::choice("visibility", &["ratio", "control-variate"]),
            Setting::integer("adaptive_from_spp", 0, 1 << 20),
            Setting::number("adaptive_share", 0.0, 1.0),
            Setting::integer("adaptive_min_spp", 0, 1 << 20),
            Setting::number("adaptive_max_ratio", 1.0, 1000.0),
            Setting::integer("light_tile", 1, 64),
        ];
        SETTINGS
    }

    fn apply(&mut self, name: &str, v: Value) {
        match name {
            "light_samples" => self.light_samples = v.integer() as u32,
            "normalised" => self.normalised = v.flag(),
            "propagation" => {
                self.propagation = [Propagation::BoundingBox, Propagation::Signed][v.choice()];
            }
            "brdf_clip" => self.brdf_clip = [BrdfClip::Spectrum, BrdfClip::Angle][v.choice()],
            "nyquist" => self.nyquist = v.flag(),
            "texels_per_square" => self.texels_per_square = v.integer() as u32,
            "antialiasing" => self.antialiasing = v.flag(),
            "coarse_analysis" => self.coarse_analysis = v.flag(),
            "lookups_per_sample" => self.lookups_per_sample = v.number(),
            "lookups_by_influence" => self.lookups_by_influence = v.flag(),
            "max_lookups" => self.max_lookups = v.integer() as u32,
            "level_step" => self.level_step = v.integer() as u32,
            "same_object" => self.same_object = v.flag(),
            "visibility" => self.visibility = [Visibility::Ratio, Visibility::ControlVariate][v.choice()],
            "adaptive_from_spp" => self.adaptive_from_spp = v.integer() as u32,
            "adaptive_share" => self.adaptive_share = v.number(),
            "adaptive_min_spp" => self.adaptive_min_spp = v.integer() as u32,
            "adaptive_max_ratio" => self.adaptive_max_ratio = v.number(),
            "light_tile" => self.light_tile = v.integer() as u32,
            _ => unreachable!("{name} is in `settings`"),
        }
    }
}

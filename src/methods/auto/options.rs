//! Options of `auto` (plain data: the job carries them).
use crate::pipeline::allocation::Proportional;
use crate::pipeline::settings::{Settable, Setting, Value};

/// How `auto` sets its filters (methods.md §5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoOptions {
    /// The samples per pixel at which each part is filtered at its AAF paper's mu0 (the
    /// papers' operating point): at n samples the filters use mu = mu0 (n / n_ref)^(1/6).
    pub reference_spp: f64,
    /// The exponent of that growth: 1/6 balances a bias growing as the width squared against
    /// a variance falling as 1 / (n width^2).
    pub refine_exponent: f64,
    /// Scale of the soft-shadow widths (Mehta 2012 Eq. 13). Above 1: the paper sets its widths
    /// for the sample counts of its Eq. 21, tens to hundreds per pixel, where a preview has a few,
    /// and at a few samples the visibility's noise outweighs the wider filter's bias in
    /// penumbrae (measured on area- and Gaussian-lit scenes: BENCHMARKS.md, "Denoising").
    pub shadow_width_scale: f64,
    /// Scale of the indirect widths (Mehta 2013 Eqs. 15-16), diffuse and glossy.
    pub indirect_width_scale: f64,
    /// The samples per pixel whose shadow and bounce rays feed the frequency analysis (slopes,
    /// reflector distances): the first ones, as the papers' sparse and initial rays.
    pub analysis_spp: u32,
    /// Radius in pixels of the neighbourhood whose reflector distances set a pixel's indirect
    /// width (their mean, the pixel's own left out), so that no width follows its own samples.
    pub reflector_radius: usize,
    /// The widest screen kernel (standard deviation in pixels) at `reference_spp`, narrowing
    /// with the samples as mu grows: the AAF widths ask for wide kernels on smooth surfaces
    /// that no number of samples would narrow (its bandlimit, Mehta 2013 Eq. 15, is a lower
    /// bound); this cap is what makes every filter narrow as the samples grow (consistency).
    pub max_sigma_px: f64,
    /// The gather's radius cap in pixels (the kernel is cut there at the first frames).
    pub max_radius: usize,
    /// Tokuyoshi's Eq. 12 power beta.
    pub beta: f64,
    /// Tokuyoshi's Eq. 3 variance relative to the centre's depth squared.
    pub sigma_z2_relative: f64,
    /// r(x), the exact unshadowed light, is computed on the first this many samples of a pixel,
    /// then on one block of as many in four (methods.md §5.1).
    pub r_block: u32,
    /// Light samples (shadow rays) per camera sample in a pixel whose earlier samples saw the
    /// light both blocked and unblocked: a penumbra, where visibility rather than the pixel's
    /// footprint is the noise and a light sample costs a fraction of a camera sample (the
    /// soft-shadow paper samples its lights per pixel too, Mehta 2012 Sec. 5). 1: one per
    /// camera sample everywhere.
    pub penumbra_rays: u32,
    /// ... only where the light's visibility filter (standard deviation) is narrower than this
    /// many pixels: a wider one averages the visibility's noise over its neighbours already.
    pub penumbra_max_width: f64,
    /// From the pass whose mean count reaches this many samples per pixel on, part of each
    /// pass's samples goes to the pixels whose shadowed direct light is noisiest (`counts.rs`);
    /// 0: the same count everywhere throughout.
    pub adaptive_from_spp: u32,
    /// Radius in pixels of the neighbourhood whose shadow rays give a pixel's visibility
    /// variance (`counts.rs`): 0, the pixel's own.
    pub adaptive_radius: usize,
    /// That part, in [0, 1]; the rest is spread evenly, so that every pixel converges.
    pub adaptive_share: f64,
    /// No pixel asks for more than this many times the pass's mean count.
    pub adaptive_max_ratio: f64,
    /// A pixel's sigma is also at least the standard deviation of its own samples' plain
    /// values, their variance averaged over its 3 x 3 neighbourhood (`counts.rs`): noise the
    /// shadow rays do not see, antialiasing at the edges of objects above all.
    pub adaptive_measured: bool,
    /// Every pixel gets at least this many samples (at most the pass's mean) before the
    /// adaptive part of a pass (`allocation::Proportional::uniform_share`).
    pub adaptive_min_spp: u32,
    /// From this many samples on, a pixel's frame value is mixed with its own unfiltered mean as
    /// far as the filter's bias, read off their difference, outweighs the mean's variance
    /// (`blend.rs`); 0: never. Fewer samples' variance misses the tail of the indirect light too
    /// often to be trusted.
    pub blend_from_spp: u32,
    /// The diffuse indirect light is also filtered at this fraction of each width, and each
    /// pixel leans towards that frame where the neighbourhood shows the wide filter's bias
    /// (`scales.rs`); 0: one scale.
    pub narrow_scale: f64,
    /// From this many samples per pixel on (fewer samples' variance is too unreliable to weigh
    /// a bias against).
    pub narrow_from_spp: u32,
    /// At pixels within 2 px of a change of the surface normal (a room's creases, objects'
    /// edges: `scales::creases`), the narrow scale starts at this count instead, if lower.
    /// There lies most of the wide filter's bias, so the test's noise costs less than it gains;
    /// elsewhere 16 samples' variance let it take noise for bias.
    pub narrow_crease_from_spp: u32,
    /// The second frame's gather fits a line through its taps (`PackedOptions::linear`) rather
    /// than taking their mean: beside a crease, where the lobe weight leaves the taps on one
    /// side, the mean keeps the light's slope into the corner as a bias.
    pub narrow_linear: bool,
}

impl AutoOptions {
    /// How the adaptive passes share out their samples.
    pub fn proportional(&self) -> Proportional {
        Proportional { share: self.adaptive_share, min_spp: self.adaptive_min_spp, max_ratio: self.adaptive_max_ratio }
    }
}

impl Default for AutoOptions {
    fn default() -> Self {
        AutoOptions {
            reference_spp: 16.0,
            refine_exponent: 1.0 / 6.0,
            shadow_width_scale: 1.5,
            indirect_width_scale: 1.0,
            analysis_spp: 8,
            reflector_radius: 3,
            max_sigma_px: 4.0,
            max_radius: 12,
            beta: 20.0,
            sigma_z2_relative: 0.01,
            r_block: 16,
            penumbra_rays: 4,
            penumbra_max_width: 1.0,
            adaptive_from_spp: 4,
            adaptive_radius: 2,
            adaptive_share: 0.9,
            adaptive_max_ratio: 8.0,
            adaptive_measured: true,
            adaptive_min_spp: 4,
            blend_from_spp: 64,
            narrow_scale: 0.5,
            narrow_from_spp: 32,
            narrow_crease_from_spp: 16,
            narrow_linear: true,
        }
    }
}

impl AutoOptions {
    /// mu at `spp` samples per pixel for a part whose operating point is `mu0`.
    pub fn mu(&self, mu0: f64, spp: f64) -> f64 {
        mu0 * self.growth(spp)
    }

    /// (spp / reference_spp)^refine_exponent: how far mu has grown, and the cap narrowed.
    fn growth(&self, spp: f64) -> f64 {
        (spp.max(1.0) / self.reference_spp.max(1e-9)).powf(self.refine_exponent)
    }

    /// The widest screen kernel at `spp` samples per pixel (pixels).
    pub fn max_sigma(&self, spp: f64) -> f64 {
        self.max_sigma_px / self.growth(spp)
    }

    /// `growth` at every whole count up to `max_spp` (at most `Growths::TABLE` entries), for
    /// the per-pixel widths: a `powf` per pixel and width costs more than the width's own
    /// arithmetic, and the counts of an image take few values.
    pub fn growths(&self, max_spp: u32) -> Growths<'_> {
        let table = (0..=max_spp.min(Growths::TABLE)).map(|n| self.growth(n as f64)).collect();
        Growths { opts: self, table }
    }
}

/// `AutoOptions::growth` by whole sample count, tabulated (`AutoOptions::growths`).
pub struct Growths<'a> {
    opts: &'a AutoOptions,
    table: Vec<f64>,
}

impl Growths<'_> {
    const TABLE: u32 = 1 << 16;

    fn at(&self, spp: u32) -> f64 {
        self.table.get(spp as usize).copied().unwrap_or_else(|| self.opts.growth(spp as f64))
    }

    /// `AutoOptions::mu` at `spp` samples.
    pub fn mu(&self, mu0: f64, spp: u32) -> f64 {
        mu0 * self.at(spp)
    }

    /// `AutoOptions::max_sigma` at `spp` samples.
    pub fn max_sigma(&self, spp: u32) -> f64 {
        self.opts.max_sigma_px / self.at(spp)
    }
}

impl Settable for AutoOptions {
    const GROUP: &'static str = "auto";

    fn settings() -> &'static [Setting] {
        const SETTINGS: &[Setting] = &[
            Setting::number("reference_spp", 1.0, 1e6),
            Setting::number("refine_exponent", 0.0, 1.0),
            Setting::number("shadow_width_scale", 0.0, 16.0),
            Setting::number("indirect_width_scale", 0.0, 16.0),
            Setting::integer("analysis_spp", 0, 1024),
            Setting::integer("reflector_radius", 0, 16),
            Setting::number("max_sigma_px", 0.0, 64.0),
            Setting::integer("max_radius", 1, 64),
            Setting::number("beta", 0.0, 1000.0),
            Setting::number("sigma_z2_relative", 0.0, 100.0),
            Setting::integer("r_block", 1, 1024),
            Setting::integer("penumbra_rays", 1, 64),
            Setting::number("penumbra_max_width", 0.0, 1e9),
            Setting::integer("adaptive_from_spp", 0, 1 << 20),
            Setting::integer("adaptive_radius", 0, 16),
            Setting::number("adaptive_share", 0.0, 1.0),
            Setting::number("adaptive_max_ratio", 1.0, 1000.0),
            Setting::flag("adaptive_measured"),
            Setting::integer("adaptive_min_spp", 0, 1 << 20),
            Setting::integer("blend_from_spp", 0, 1 << 20),
            Setting::number("narrow_scale", 0.0, 1.0),
            Setting::integer("narrow_from_spp", 0, 1 << 20),
            Setting::integer("narrow_crease_from_spp", 0, 1 << 20),
            Setting::flag("narrow_linear"),
        ];
        SETTINGS
    }

    fn apply(&mut self, name: &str, v: Value) {
        match name {
            "reference_spp" => self.reference_spp = v.number(),
            "refine_exponent" => self.refine_exponent = v.number(),
            "shadow_width_scale" => self.shadow_width_scale = v.number(),
            "indirect_width_scale" => self.indirect_width_scale = v.number(),
            "analysis_spp" => self.analysis_spp = v.integer() as u32,
            "reflector_radius" => self.reflector_radius = v.integer() as usize,
            "max_sigma_px" => self.max_sigma_px = v.number(),
            "max_radius" => self.max_radius = v.integer() as usize,
            "beta" => self.beta = v.number(),
            "sigma_z2_relative" => self.sigma_z2_relative = v.number(),
            "r_block" => self.r_block = v.integer() as u32,
            "penumbra_rays" => self.penumbra_rays = v.integer() as u32,
            "penumbra_max_width" => self.penumbra_max_width = v.number(),
            "adaptive_from_spp" => self.adaptive_from_spp = v.integer() as u32,
            "adaptive_radius" => self.adaptive_radius = v.integer() as usize,
            "adaptive_share" => self.adaptive_share = v.number(),
            "adaptive_max_ratio" => self.adaptive_max_ratio = v.number(),
            "adaptive_measured" => self.adaptive_measured = v.flag(),
            "adaptive_min_spp" => self.adaptive_min_spp = v.integer() as u32,
            "blend_from_spp" => self.blend_from_spp = v.integer() as u32,
            "narrow_scale" => self.narrow_scale = v.number(),
            "narrow_from_spp" => self.narrow_from_spp = v.integer() as u32,
            "narrow_crease_from_spp" => self.narrow_crease_from_spp = v.integer() as u32,
            "narrow_linear" => self.narrow_linear = v.flag(),
            _ => unreachable!("{name} is in `settings`"),
        }
    }
}

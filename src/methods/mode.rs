//! What the AAF-family strategies do with their samples (the curves of the soft-shadow paper's
//! Fig. 6c and the indirect paper's Fig. 10a): the method and its two baselines share one code.

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterMode {
    /// Adaptive sampling and adaptive filtering: the method.
    Aaf,
    /// AAF's sample counts, no filter.
    Adaptive,
    /// The same samples everywhere (doubling per pass) and a fixed-width filter.
    UniformFiltered,
    /// The same samples everywhere (doubling per pass), indirect light filtered by Tokuyoshi's
    /// cross-bilateral gather with lobe-aware weights (Eq. 12) and a narrowing screen kernel.
    LobeAware,
    /// As `LobeAware` with the normal-aware weight (Tokuyoshi's Eq. 4, his baseline).
    NormalAware,
    /// AAF's sample counts and per-pixel filter widths (soft shadows and indirect light), with
    /// the indirect light gathered by Tokuyoshi's filter with lobe-aware weights in place of
    /// the AAF filter's normal threshold.
    Auto,
}

impl FilterMode {
    /// Whether indirect light is filtered by Tokuyoshi's gather (`lobe_aware::filter`) rather
    /// than the AAF papers' world-space Gaussian.
    pub fn tokuyoshi(self) -> bool {
        matches!(self, FilterMode::LobeAware | FilterMode::NormalAware | FilterMode::Auto)
    }

    /// Whether the indirect strategy also owns direct light (no soft-shadow part): Tokuyoshi's
    /// methods filter indirect light only.
    pub fn indirect_owns_direct(self) -> bool {
        matches!(self, FilterMode::LobeAware | FilterMode::NormalAware)
    }

    /// The mode the soft-shadow part runs in.
    pub fn for_shadows(self) -> FilterMode {
        match self {
            FilterMode::Auto => FilterMode::Aaf,
            m => m,
        }
    }

    /// Whether every pixel gets the same samples (doubling per pass).
    pub fn uniform_samples(self) -> bool {
        matches!(self, FilterMode::UniformFiltered | FilterMode::LobeAware | FilterMode::NormalAware)
    }
}

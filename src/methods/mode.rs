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
}

impl FilterMode {
    /// Whether indirect light is filtered by Tokuyoshi's gather (`lobe_aware::filter`) rather
    /// than the AAF papers' world-space Gaussian.
    pub fn tokuyoshi(self) -> bool {
        matches!(self, FilterMode::LobeAware | FilterMode::NormalAware)
    }

    /// Whether the indirect strategy also owns direct light (no soft-shadow part): Tokuyoshi's
    /// methods filter indirect light only.
    pub fn indirect_owns_direct(self) -> bool {
        matches!(self, FilterMode::LobeAware | FilterMode::NormalAware)
    }

    /// Whether every pixel gets the same samples (doubling per pass).
    pub fn uniform_samples(self) -> bool {
        matches!(self, FilterMode::UniformFiltered | FilterMode::LobeAware | FilterMode::NormalAware)
    }
}

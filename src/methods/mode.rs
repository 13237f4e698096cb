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
}

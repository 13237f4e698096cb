//! Options of the lobe-aware filter (Tokuyoshi 2015) and of its normal-aware baseline.

/// How a pixel's lobe is built (App. B) where the warp degenerates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeOptions {
    /// Lower clamp of `n.psi` in the warp `lambda' / (4 n.psi)` (BakingLab's 0.1).
    pub min_cos_view: f64,
    /// Cap of any lobe's sharpness.
    pub max_sharpness: f64,
}

impl Default for LobeOptions {
    fn default() -> Self {
        LobeOptions { min_cos_view: 0.1, max_sharpness: 1e6 }
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

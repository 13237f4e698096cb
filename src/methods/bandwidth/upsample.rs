//! The weights a pixel that is not shaded takes its value from its parents with (Bagher et al.
//! 2012, Sec. 3.2, Fig. 10): `w_i = g_z(z - z_i) g_a(p - p_i) alpha_i`, normalised over the
//! parents that were computed.
//!
//! The grids are nested on pixels (the parents of level l are the pixels of level l + 1, every
//! 2^(l+1)-th one), so a new pixel lies on an edge between two parents or at the centre of
//! four: its bilinear weights `alpha_i` are 1/2 or 1/4. (The paper's figure, whose values are
//! not in our copy, draws cells centred between pixels, where they would be 9/16, 3/16, 3/16,
//! 1/16.)
//!
//! `g_a(v) = exp(-v^T M v)`, `M = R_phi^T diag(1, cos theta) R_phi`, with `phi` the angle of the
//! screen-projected normal and `theta` the angle between the normal and the view: the kernel
//! is narrower across the foreshortened direction. Offsets `v` are in units of the parent
//! spacing times `anisotropy_scale`; `g_z` is a Gaussian of the relative depth difference with
//! deviation `depth_sigma`. Both scales are unspecified in the paper: parameters.

/// One candidate parent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Parent {
    /// Offset from the pixel, in parent spacings.
    pub offset: [f64; 2],
    pub depth: f64,
    /// Bilinear weight.
    pub alpha: f64,
    /// Whether the parent holds a value (shaded or upsampled itself).
    pub computed: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpsampleOptions {
    /// Deviation of `g_z`, relative to the pixel's depth.
    pub depth_sigma: f64,
    /// Offsets are multiplied by this before `g_a`.
    pub anisotropy_scale: f64,
}

impl Default for UpsampleOptions {
    fn default() -> Self {
        UpsampleOptions { depth_sigma: 0.05, anisotropy_scale: 1.0 }
    }
}

/// The normalised weights of `parents` for a pixel at `depth` whose screen-projected normal
/// points at angle `phi` and whose normal makes cosine `cos_theta` with the view; None when no
/// parent has weight (none computed, or all across a depth edge): the pixel is then shaded.
pub fn weights(parents: &[Parent], depth: f64, phi: f64, cos_theta: f64, opts: &UpsampleOptions) -> Option<Vec<f64>> {
    let (c, s) = (phi.cos(), phi.sin());
    let cos_theta = cos_theta.abs().clamp(0.0, 1.0);
    let raw: Vec<f64> = parents
        .iter()
        .map(|p| {
            if !p.computed || !(p.alpha > 0.0) {
                return 0.0;
            }
            // v in the normal's screen frame: along the projected normal, then across it.
            let (vx, vy) = (p.offset[0] * opts.anisotropy_scale, p.offset[1] * opts.anisotropy_scale);
            let (a, b) = (c * vx + s * vy, -s * vx + c * vy);
            let g_a = (-(a * a + cos_theta * b * b)).exp();
            let rel = (depth - p.depth) / (opts.depth_sigma * depth.abs().max(1e-12));
            let g_z = (-0.5 * rel * rel).exp();
            let w = g_z * g_a * p.alpha;
            if w.is_finite() {
                w
            } else {
                0.0
            }
        })
        .collect();
    let sum: f64 = raw.iter().sum();
    (sum > 1e-12).then(|| raw.iter().map(|w| w / sum).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn centre_parents(depths: [f64; 4]) -> Vec<Parent> {
        [[-0.5, -0.5], [0.5, -0.5], [-0.5, 0.5], [0.5, 0.5]]
            .iter()
            .zip(depths)
            .map(|(&offset, depth)| Parent { offset, depth, alpha: 0.25, computed: true })
            .collect()
    }

    #[test]
    fn weights_sum_to_one_and_a_constant_stays_constant() {
        let opts = UpsampleOptions::default();
        for (phi, cos) in [(0.0, 1.0), (0.7, 0.2), (2.5, 0.0)] {
            let w = weights(&centre_parents([1.0, 1.01, 0.99, 1.0]), 1.0, phi, cos, &opts).unwrap();
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let value: f64 = w.iter().map(|w| w * 3.5).sum();
            assert!((value - 3.5).abs() < 1e-12);
        }
        // Symmetric parents at equal depth and a view along the normal: bilinear.
        let w = weights(&centre_parents([2.0; 4]), 2.0, 0.3, 1.0, &opts).unwrap();
        assert!(w.iter().all(|&x| (x - 0.25).abs() < 1e-12), "{w:?}");
    }

    #[test]
    fn parents_across_a_depth_edge_or_not_computed_are_left_out() {
        let opts = UpsampleOptions::default();
        let mut parents = centre_parents([1.0, 1.0, 5.0, 5.0]);
        let w = weights(&parents, 1.0, 0.0, 1.0, &opts).unwrap();
        assert!(w[2] < 1e-9 && w[3] < 1e-9 && (w[0] - 0.5).abs() < 1e-6);
        parents[0].computed = false;
        let w = weights(&parents, 1.0, 0.0, 1.0, &opts).unwrap();
        assert!((w[1] - 1.0).abs() < 1e-6);
        // Nothing usable: the pixel must be shaded.
        parents[1].computed = false;
        assert!(weights(&parents, 1.0, 0.0, 1.0, &opts).is_none());
        assert!(weights(&[], 1.0, 0.0, 1.0, &opts).is_none());
    }

    #[test]
    fn a_foreshortened_surface_favours_parents_across_its_normal() {
        // Normal projected along +x (phi = 0), seen at a grazing angle: M = diag(1, cos), so
        // a parent along y (across the foreshortening) weighs more than one along x.
        let opts = UpsampleOptions::default();
        let parents = [
            Parent { offset: [1.0, 0.0], depth: 1.0, alpha: 0.5, computed: true },
            Parent { offset: [0.0, 1.0], depth: 1.0, alpha: 0.5, computed: true },
        ];
        let w = weights(&parents, 1.0, 0.0, 0.1, &opts).unwrap();
        assert!(w[1] > 2.0 * w[0], "{w:?}");
        let w = weights(&parents, 1.0, 0.0, 1.0, &opts).unwrap();
        assert!((w[0] - w[1]).abs() < 1e-12);
    }
}

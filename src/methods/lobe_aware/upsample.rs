//! Joint bilateral upsampling with Tokuyoshi's weights (Sec. 5, "Upsampling", after Kopf et
//! al. 2007) and the adaptive re-render of his Fig. 16.
//!
//! Light traced only at the sites of a coarse grid, every `factor`-th pixel in x and y (in
//! full-resolution coordinates, so the grids of factors 4, 2 and 1 are nested), reaches every
//! other pixel as the weighted mean of its four surrounding sites (Eq. 1 over those four): a
//! bilinear weight times the depth weight (Eq. 3) times the directional weight (Eq. 12, or
//! Eq. 4 for the normal-aware baseline), each pixel compared through its own full-resolution
//! guide. The paper smooths the lobes with kappa = 100 for upsampling (Sec. 5: four sparse
//! samples are interpolated smoothly); the caller builds the guides so.
//!
//! Since the bilinear weights sum to 1 and the others are at most 1, a pixel's weight sum lies
//! in [0, 1]: it says how much of the pixel its sites represent. Pixels below a threshold
//! (0.25 in Fig. 16) are "re-rendered": their light is traced at the pixel itself. The sum
//! depends on the guides alone, so the pixels to re-render are known before any light is traced.
use super::filter::{Guide, Similarity};
use super::weights::ln_depth_weight;

/// The coarse grid: pixel (x, y) of a `width` x `height` image is a site when both coordinates
/// are multiples of `factor`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grid {
    pub factor: usize,
    pub width: usize,
    pub height: usize,
}

/// The weights of one upsampling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpsampleWeights {
    pub similarity: Similarity,
    /// Eq. 3's variance relative to the pixel's depth squared.
    pub sigma_z2_relative: f64,
}

impl Grid {
    pub fn new(factor: usize, width: usize, height: usize) -> Self {
        Grid { factor: factor.max(1), width, height }
    }

    pub fn is_site(&self, p: usize) -> bool {
        let (x, y) = (p % self.width.max(1), p / self.width.max(1));
        x.is_multiple_of(self.factor) && y.is_multiple_of(self.factor)
    }

    /// The sites around pixel `p` and their bilinear weights (summing to 1). Beyond the last
    /// site of a row or column (the image's width not a multiple of the factor) the nearest
    /// site takes the whole weight along that axis; a site is its own only site.
    pub fn corners(&self, p: usize) -> impl Iterator<Item = (usize, f64)> {
        let f = self.factor;
        let (x, y) = (p % self.width, p / self.width);
        let axis = |at: usize, len: usize| -> [(usize, f64); 2] {
            let lo = at / f * f;
            let hi = lo + f;
            if at == lo || hi >= len {
                [(lo, 1.0), (lo, 0.0)]
            } else {
                let t = (at - lo) as f64 / f as f64;
                [(lo, 1.0 - t), (hi, t)]
            }
        };
        let (xs, ys) = (axis(x, self.width), axis(y, self.height));
        let w = self.width;
        ys.into_iter()
            .flat_map(move |(yy, wy)| xs.into_iter().map(move |(xx, wx)| (yy * w + xx, wx * wy)))
            .filter(|&(_, w)| w > 0.0)
    }
}

/// The upsampling weight of source `j` for pixel `i`, bilinear weight `b` included.
fn weight(guides: &[Guide], i: usize, j: usize, b: f64, o: &UpsampleWeights) -> f64 {
    if i == j {
        return b;
    }
    let (c, g) = (&guides[i], &guides[j]);
    let sigma_z2 = o.sigma_z2_relative * c.depth * c.depth;
    b * (ln_depth_weight(c.depth, g.depth, sigma_z2) + o.similarity.ln_weight(c, g)).exp()
}

/// Each pixel's upsampling weight sum over the sites that are `sources` (valid sites with light
/// to give): 1 at a source, 0 at an invalid pixel. Fig. 16 re-renders the pixels below its
/// threshold.
pub fn weight_sums(guides: &[Guide], sources: &[bool], grid: &Grid, o: &UpsampleWeights) -> Vec<f64> {
    use rayon::prelude::*;
    (0..guides.len())
        .into_par_iter()
        .map(|i| {
            if !guides[i].valid {
                return 0.0;
            }
            grid.corners(i).filter(|&(j, _)| sources[j]).map(|(j, b)| weight(guides, i, j, b, o)).sum()
        })
        .collect()
}

/// Upsampled `values`: at pixel i the weighted mean of `values` over its sources (Eq. 1 over the
/// four sites), or None where no source has weight (an invalid pixel, or one whose sites all
/// differ from it entirely: the ones to re-render). Only the sources' values are read.
pub fn upsample(
    guides: &[Guide],
    sources: &[bool],
    values: &[[f64; 3]],
    grid: &Grid,
    o: &UpsampleWeights,
) -> Vec<Option<[f64; 3]>> {
    use rayon::prelude::*;
    assert_eq!(guides.len(), values.len(), "one guide per value");
    (0..guides.len())
        .into_par_iter()
        .map(|i| {
            if !guides[i].valid {
                return None;
            }
            let (mut sum, mut wsum) = ([0.0f64; 3], 0.0f64);
            for (j, b) in grid.corners(i).filter(|&(j, _)| sources[j]) {
                let w = weight(guides, i, j, b, o);
                if w > 0.0 {
                    for k in 0..3 {
                        sum[k] += w * values[j][k];
                    }
                    wsum += w;
                }
            }
            (wsum > 0.0).then(|| sum.map(|s| s / wsum))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::lobe_aware::lobe::{diffuse, specular};
    use crate::methods::lobe_aware::options::LobeOptions;
    use crate::render::material::GlossyModel;
    use glam::DVec3;

    const LOBE: UpsampleWeights =
        UpsampleWeights { similarity: Similarity::Lobe { beta: 20.0 }, sigma_z2_relative: 0.01 };
    const NORMAL: UpsampleWeights =
        UpsampleWeights { similarity: Similarity::Normal { sigma_n2: 0.01 }, sigma_z2_relative: 0.01 };

    fn flat(n: usize) -> Vec<Guide> {
        vec![Guide { valid: true, depth: 4.0, normal: DVec3::Z, lobe: diffuse(DVec3::Z), asg: None, sigma_px: 0.0 }; n]
    }

    fn sites(grid: &Grid, n: usize) -> Vec<bool> {
        (0..n).map(|p| grid.is_site(p)).collect()
    }

    #[test]
    fn corners_are_bilinear_weights_that_sum_to_one_and_sites_are_nested() {
        for (f, w, h) in [(2, 9, 7), (4, 13, 10), (1, 5, 5)] {
            let grid = Grid::new(f, w, h);
            for p in 0..w * h {
                let c: Vec<_> = grid.corners(p).collect();
                assert!((c.iter().map(|&(_, b)| b).sum::<f64>() - 1.0).abs() < 1e-15);
                assert!(c.iter().all(|&(j, _)| grid.is_site(j)), "factor {f}, pixel {p}: {c:?}");
                if grid.is_site(p) {
                    assert_eq!(c, vec![(p, 1.0)]);
                }
                // A site of the factor-4 grid is one of the factor-2 grid's.
                if Grid::new(4, w, h).is_site(p) {
                    assert!(Grid::new(2, w, h).is_site(p));
                }
            }
        }
        // Pixel (1, 3) between sites (0, 2), (2, 2), (0, 4), (2, 4) of the factor-2 grid.
        let grid = Grid::new(2, 9, 7);
        let mut c: Vec<_> = grid.corners(3 * 9 + 1).collect();
        c.sort_by_key(|&(j, _)| j);
        assert_eq!(c, vec![(2 * 9, 0.25), (2 * 9 + 2, 0.25), (4 * 9, 0.25), (4 * 9 + 2, 0.25)]);
        // Pixel (9, 0) past the last site of its row (width 10: sites at 0, 4, 8): site 8 alone.
        let grid = Grid::new(4, 10, 4);
        let c: Vec<_> = grid.corners(9).collect();
        assert_eq!(c, vec![(8, 1.0)]);
    }

    /// With identical guides the upsampling is bilinear interpolation: a linear ramp is
    /// reproduced exactly between sites, a constant everywhere, and every weight sum is 1.
    #[test]
    fn identical_guides_interpolate_bilinearly() {
        let (w, h) = (17, 9);
        let grid = Grid::new(4, w, h);
        let guides = flat(w * h);
        let src = sites(&grid, w * h);
        let ramp: Vec<[f64; 3]> = (0..w * h).map(|p| [(p % w) as f64, (p / w) as f64 * 2.0, 1.0]).collect();
        let out = upsample(&guides, &src, &ramp, &grid, &LOBE);
        for (p, v) in out.iter().enumerate() {
            let v = v.expect("every pixel has sources");
            let y = (p / w) as f64;
            assert!((v[0] - (p % w) as f64).abs() < 1e-12 && (v[1] - 2.0 * y).abs() < 1e-12 && v[2] == 1.0);
        }
        assert!(weight_sums(&guides, &src, &grid, &LOBE).iter().all(|&s| (s - 1.0).abs() < 1e-12));
    }

    /// Tokuyoshi's Fig. 16 point: where glossiness changes (exponent 10 against 10,000 on one
    /// plane, so the normals agree), the lobe-aware weights flag the pixels between unlike
    /// sites (weight sum under 0.25), so they are re-rendered, and never mix the two sides;
    /// the normal-aware weights see nothing and blend the two sides' light.
    #[test]
    fn lobe_aware_weights_flag_an_edge_of_glossiness_that_normal_aware_blend() {
        let (w, h) = (16, 8);
        let grid = Grid::new(4, w, h);
        let psi = DVec3::new(0.3, 0.0, 1.0).normalize();
        let lo = LobeOptions::default();
        let mut guides = flat(w * h);
        let mut values = vec![[0.0; 3]; w * h];
        // Columns 0..=9 rough, 10.. sharp: pixel column 9 sits between sites 8 (rough) and 12.
        for p in 0..w * h {
            let m = if p % w < 10 { 10.0 } else { 10_000.0 };
            guides[p].lobe = specular(GlossyModel::BlinnPhong, m, DVec3::Z, psi, &lo).smoothed(100.0);
            values[p] = if p % w < 10 { [1.0; 3] } else { [5.0; 3] };
        }
        let src = sites(&grid, w * h);
        let (ls, ns) = (weight_sums(&guides, &src, &grid, &LOBE), weight_sums(&guides, &src, &grid, &NORMAL));
        let (lu, nu) =
            (upsample(&guides, &src, &values, &grid, &LOBE), upsample(&guides, &src, &values, &grid, &NORMAL));
        let at = |x: usize| 4 * w + x;
        // Column 11 (sharp) lies a quarter from site 12 and three quarters from site 8 (rough).
        assert!(ls[at(11)] < 0.8 && ls[at(11)] > 0.7, "lobe-aware keeps only the like site: {}", ls[at(11)]);
        assert!((lu[at(11)].unwrap()[0] - 5.0).abs() < 1e-6, "{:?}", lu[at(11)]);
        assert!((ns[at(11)] - 1.0).abs() < 1e-12);
        assert!((nu[at(11)].unwrap()[0] - 4.0).abs() < 1e-6, "normal-aware blends 1 and 5: {:?}", nu[at(11)]);
        // Column 10 (sharp) between site 8 (rough, weight 0.5) and 12 (sharp, 0.5) and column
        // 9 (rough, 0.75 and 0.25): lobe-aware keeps its own side.
        assert!((lu[at(9)].unwrap()[0] - 1.0).abs() < 1e-6 && (lu[at(10)].unwrap()[0] - 5.0).abs() < 1e-6);
        // A sharp pixel whose sites are all rough falls under Fig. 16's threshold.
        let mut lone = guides.clone();
        lone[at(5)].lobe = guides[at(12)].lobe;
        let s = weight_sums(&lone, &src, &grid, &LOBE);
        assert!(s[at(5)] < 0.25, "{}", s[at(5)]);
        assert!(upsample(&lone, &src, &values, &grid, &LOBE)[at(5)].is_none_or(|v| v[0] <= 1.0 + 1e-9));
    }

    #[test]
    fn invalid_pixels_and_sources_give_nothing_and_depth_separates() {
        let (w, h) = (9, 9);
        let grid = Grid::new(2, w, h);
        let mut guides = flat(w * h);
        let mut src = sites(&grid, w * h);
        let values: Vec<[f64; 3]> = (0..w * h).map(|p| [p as f64; 3]).collect();
        guides[0].valid = false;
        assert_eq!(upsample(&guides, &src, &values, &grid, &LOBE)[0], None);
        assert_eq!(weight_sums(&guides, &src, &grid, &LOBE)[0], 0.0);
        guides[0].valid = true;
        // Pixel (1, 0) between sites (0, 0) and (2, 0): with (2, 0) not a source, (0, 0)'s
        // value alone, at half the weight.
        src[2] = false;
        let out = upsample(&guides, &src, &values, &grid, &LOBE);
        assert_eq!(out[1], Some([0.0; 3]));
        assert!((weight_sums(&guides, &src, &grid, &LOBE)[1] - 0.5).abs() < 1e-12);
        // A site three times as far away as the pixel is (a background behind an edge) has no say.
        let mut far = flat(w * h);
        far[4 * w + 4].depth = 12.0;
        let s = weight_sums(&far, &sites(&grid, w * h), &grid, &LOBE);
        assert!((s[4 * w + 3] - 0.5).abs() < 1e-12, "{}", s[4 * w + 3]);
    }
}

//! Local bandwidth of an image from its wavelet coefficients (Bagher et al. 2012, Sec. 2.4 and
//! Appendix A): a 2-D discrete wavelet transform, and at each texel the finest level whose
//! coefficients covering the texel still matter.
//!
//! Levels are numbered by scale: the details of level j (j = 1 the finest) describe features
//! about 2^j texels wide. At a texel, `lambda_j` is the largest detail coefficient of level j
//! whose support covers it. Appendix A's estimator, read with this numbering: the result is
//! the coarsest level h such that levels 1..=h together hold less than `eps` of the reference
//! (the largest `lambda` at the texel, or in the whole image), so that everything finer than
//! h is negligible; the bandwidth is then one cycle per 2^h texels, an octave above the finest
//! level that matters (conservative, as the paper's `b_w = 2^{I_w}`). Which basis the
//! coefficients are measured in decides what "negligible" means (`Basis`). The paper's filter,
//! "Daubechies of order 4", is ambiguous: `Filter::Db4` (8 taps, the default: it leaks less
//! into finer levels) or `Filter::D4` (4 taps); methods.md §4.1.
use rayon::prelude::*;

/// The Daubechies low-pass filter (orthonormal: taps sum to sqrt 2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    /// 4 taps (db2, "D4").
    D4,
    /// 8 taps (db4).
    #[default]
    Db4,
}

impl Filter {
    fn taps(self) -> &'static [f64] {
        match self {
            Filter::D4 => {
                &[0.482_962_913_144_690_3, 0.836_516_303_737_469, 0.224_143_868_041_857_35, -0.129_409_522_550_921_45]
            }
            Filter::Db4 => &[
                0.230_377_813_308_855_23,
                0.714_846_570_552_541_5,
                0.630_880_767_929_590_4,
                -0.027_983_769_416_983_85,
                -0.187_034_811_718_881_14,
                0.030_841_381_835_986_965,
                0.032_883_011_666_982_945,
                -0.010_597_401_784_997_278,
            ],
        }
    }
}

/// What the negligible share is measured against.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Reference {
    /// The largest coefficient covering the texel (Appendix A, read per point). Far out on a
    /// smooth falloff (a lobe's tail, a dim sky) the coefficients are all tiny, and their
    /// relative structure reads as detail: the tail of a Gaussian has a local frequency that
    /// grows with the distance from its peak.
    Local,
    /// The largest coefficient anywhere in the image (the default): detail counts in
    /// proportion to what it adds to the image as a whole.
    #[default]
    Global,
}

/// Appendix A's threshold.
pub const EPSILON: f64 = 0.01;

/// The basis whose coefficients the estimator compares across levels.
///
/// Appendix A writes the signal over `2^-i psi((x - 2^i j) / 2^i)`, functions of unit area
/// (`UnitArea`, the default). Coarse levels' coefficients then weigh more than fine ones', by
/// 2^(1/2) per level and axis over the orthonormal ones: a sinusoid reads 2.6 octaves high
/// with db4 (leakage), a Gaussian bump of 4 texels' deviation 2 octaves high at its peak; but
/// a sharp edge in an image reads three octaves smoother than it is (the test below).
/// `Amplitude` compares how much each level adds to the signal's value: an edge is as sharp
/// as the texels, but a sinusoid reads 3.6 octaves high and the Gaussian bump 4 (its finest
/// levels hold a few percent of its amplitude). Neither is right everywhere; methods.md §4.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Basis {
    /// `2^(-i/2) psi`, unit peak per axis: coefficients are the amplitudes of each level.
    Amplitude,
    /// `2^-i psi`, unit area: Appendix A as printed.
    #[default]
    UnitArea,
}

/// One level of the periodic transform along one axis of `data` (`w` x `h`, row-major): each
/// line of length n becomes ceil(n / 2) approximation and as many detail coefficients.
fn split(data: &[f64], w: usize, h: usize, along_x: bool, taps: &[f64]) -> (Vec<f64>, Vec<f64>, usize, usize) {
    let (n, lines) = if along_x { (w, h) } else { (h, w) };
    let half = n.div_ceil(2);
    let (ow, oh) = if along_x { (half, h) } else { (w, half) };
    let (mut lo, mut hi) = (vec![0.0; ow * oh], vec![0.0; ow * oh]);
    let len = taps.len();
    for line in 0..lines {
        let at = |i: usize| if along_x { data[line * w + i % n] } else { data[(i % n) * w + line] };
        for k in 0..half {
            let (mut a, mut d) = (0.0, 0.0);
            for (t, &c) in taps.iter().enumerate() {
                let x = at(2 * k + t);
                a += c * x;
                // g_t = (-1)^t h_{L-1-t}
                let g = if t % 2 == 0 { taps[len - 1 - t] } else { -taps[len - 1 - t] };
                d += g * x;
            }
            let o = if along_x { line * ow + k } else { k * ow + line };
            lo[o] = a;
            hi[o] = d;
        }
    }
    (lo, hi, ow, oh)
}

/// The scale exponent h of the local bandwidth at every texel of `image` (`w` x `h`,
/// row-major, periodic at the edges): a bandwidth of one cycle per 2^h texels. None where the
/// image holds no detail at all (a constant: bandwidth 0).
pub fn scale_exponents(
    image: &[f64],
    w: usize,
    h: usize,
    filter: Filter,
    basis: Basis,
    eps: f64,
    reference: Reference,
) -> Vec<Option<u32>> {
    assert!(w > 0 && h > 0 && image.len() == w * h);
    let taps = filter.taps();
    let reach = taps.len() / 2;
    // levels[j - 1]: the level-j coefficient bounds, one per block, and which block covers
    // each texel's column and row.
    let mut levels: Vec<LevelBounds> = Vec::new();
    let (mut a, mut aw, mut ah) = (image.to_vec(), w, h);
    // The transform's coefficients are orthonormal; `basis` rescales them by 2^(-i/2) or
    // 2^(i/2) per axis halved.
    let mut normalisation = 1.0f64;
    while (aw >= 2 || ah >= 2) && levels.len() < 24 {
        // Rows, then columns; an axis already down to one sample is left as it is.
        let (lo, hi, bw, bh) =
            if aw >= 2 { split(&a, aw, ah, true, taps) } else { (a.clone(), vec![0.0; a.len()], aw, ah) };
        let (ll, lh, hl, hh, cw, ch) = if ah >= 2 {
            let (ll, lh, cw, ch) = split(&lo, bw, bh, false, taps);
            let (hl, hh, _, _) = split(&hi, bw, bh, false, taps);
            (ll, lh, hl, hh, cw, ch)
        } else {
            (lo, vec![0.0; hi.len()], hi, vec![0.0; bw * bh], bw, bh)
        };
        let per_axis = match basis {
            Basis::Amplitude => std::f64::consts::FRAC_1_SQRT_2,
            Basis::UnitArea => std::f64::consts::SQRT_2,
        };
        normalisation *= if aw >= 2 { per_axis } else { 1.0 };
        normalisation *= if ah >= 2 { per_axis } else { 1.0 };
        let detail: Vec<f64> =
            (0..cw * ch).map(|i| normalisation * lh[i].abs().max(hl[i].abs()).max(hh[i].abs())).collect();
        // A coefficient k covers the blocks k..k + reach - 1 of its level: block b is covered
        // by coefficients b - reach + 1..=b (periodic), along each axis it was taken along.
        let (rx, ry) = (if aw >= 2 { reach } else { 1 }, if ah >= 2 { reach } else { 1 });
        let mut covered = vec![0.0f64; cw * ch];
        for by in 0..ch {
            for bx in 0..cw {
                let mut m = 0.0f64;
                for dy in 0..ry {
                    for dx in 0..rx {
                        let (kx, ky) = ((bx + cw * rx - dx) % cw, (by + ch * ry - dy) % ch);
                        m = m.max(detail[ky * cw + kx]);
                    }
                }
                covered[by * cw + bx] = m;
            }
        }
        // Texel (x, y) lies in block (x >> j, y >> j) of a level that halved both axes; an
        // axis not halved keeps its index.
        let (sx, sy) = (w.div_ceil(cw), h.div_ceil(ch));
        let column = (0..w).map(|x| (x / sx).min(cw - 1)).collect();
        let row = (0..h).map(|y| (y / sy).min(ch - 1) * cw).collect();
        levels.push(LevelBounds { covered, column, row });
        (a, aw, ah) = (ll, cw, ch);
    }
    // The largest bound any texel sees (blocks no texel maps to do not count).
    let global = levels.iter().fold(0.0f64, |m, l| {
        l.row.iter().flat_map(|&r| l.column.iter().map(move |&c| r + c)).fold(m, |m, b| m.max(l.covered[b]))
    });
    // Coefficients at rounding level of the image's values are no detail (a constant
    // transforms to about 1e-16 of itself, not to 0).
    let floor = 1e-9 * image.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut out = vec![None; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, line)| {
        for (x, texel) in line.iter_mut().enumerate() {
            let bound = |l: &LevelBounds| l.covered[l.row[y] + l.column[x]];
            let reference = match reference {
                Reference::Local => levels.iter().fold(0.0f64, |m, l| m.max(bound(l))),
                Reference::Global => global,
            };
            if !(reference > floor) {
                continue;
            }
            // The coarsest h with levels 1..=h below eps of the reference.
            let mut tail = 0.0;
            let mut h = 0;
            for (j, l) in levels.iter().enumerate() {
                tail += bound(l);
                if tail < eps * reference {
                    h = j as u32 + 1;
                } else {
                    break;
                }
            }
            *texel = Some(h);
        }
    });
    out
}

/// One level's coefficient bounds per block, and the block of each texel: `covered[row[y] +
/// column[x]]` for texel (x, y).
struct LevelBounds {
    covered: Vec<f64>,
    column: Vec<usize>,
    row: Vec<usize>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sinusoid(n: usize, f: f64) -> Vec<f64> {
        (0..n).map(|x| (2.0 * std::f64::consts::PI * f * x as f64).sin()).collect()
    }

    /// The estimated frequency (cycles per texel) at the centre of a 1-D signal.
    fn estimate(signal: &[f64], filter: Filter, basis: Basis) -> f64 {
        let h = scale_exponents(signal, signal.len(), 1, filter, basis, EPSILON, Reference::Global)[signal.len() / 2];
        h.map_or(0.0, |h| 0.5f64.powi(h as i32))
    }

    #[test]
    fn the_filters_are_orthonormal_daubechies() {
        for f in [Filter::D4, Filter::Db4] {
            let t = f.taps();
            assert!((t.iter().sum::<f64>() - std::f64::consts::SQRT_2).abs() < 1e-12);
            assert!((t.iter().map(|c| c * c).sum::<f64>() - 1.0).abs() < 1e-12);
            // Orthogonal to its even shifts.
            for s in (2..t.len()).step_by(2) {
                let dot: f64 = (0..t.len() - s).map(|k| t[k] * t[k + s]).sum();
                assert!(dot.abs() < 1e-12, "{f:?} shift {s}: {dot}");
            }
        }
    }

    #[test]
    fn a_sinusoids_bandwidth_rises_with_its_frequency_and_bounds_it() {
        // Leakage into finer levels makes the estimate conservative. With db4: 2.6 octaves
        // above the true frequency in the unit-area basis (the oracle asks for at most three),
        // 3.6 in the amplitude basis; D4 leaks one to two octaves more.
        for (filter, basis, most) in [
            (Filter::Db4, Basis::UnitArea, 8.0),
            (Filter::Db4, Basis::Amplitude, 16.0),
            (Filter::D4, Basis::UnitArea, 16.0),
            (Filter::D4, Basis::Amplitude, 64.0),
        ] {
            let mut last = 0.0;
            for k in (1..=7).rev() {
                let f = 0.5f64.powi(k + 1) * 1.3; // between octaves, away from level boundaries
                let e = estimate(&sinusoid(1024, f), filter, basis);
                assert!(e >= last, "{filter:?} {basis:?}: not monotone at f = {f}: {e} after {last}");
                assert!(e >= f, "{filter:?} {basis:?}: {e} below the true frequency {f}");
                assert!(e <= most * f, "{filter:?} {basis:?}: over {most} f at f = {f}: {e}");
                last = e;
            }
        }
    }

    #[test]
    fn a_constant_has_no_bandwidth_and_a_step_is_sharp_only_near_the_edge() {
        let none = scale_exponents(&[3.0; 64], 8, 8, Filter::Db4, Basis::Amplitude, EPSILON, Reference::Local);
        assert!(none.iter().all(Option::is_none));
        // A 2-D step along x (periodic: it also steps at x = 0; an 8-tap coefficient of level
        // j spans about 7 2^j texels, so texels 128 from both edges see levels up to 4 free
        // of them).
        let (w, h) = (512, 16);
        let img: Vec<f64> = (0..w * h).map(|i| if (i % w) < 256 { 1.0 } else { 0.0 }).collect();
        let exponents = |basis| scale_exponents(&img, w, h, Filter::Db4, basis, EPSILON, Reference::Global);
        let s = exponents(Basis::Amplitude);
        let at = |x: usize| s[8 * w + x].unwrap();
        // The amplitude basis: the finest level at the edge, coarse ones far from it.
        assert!(at(256) == 0 && at(255) == 0, "{} {}", at(255), at(256));
        assert!(at(128) >= 4 && at(384) >= 4, "{} {}", at(128), at(384));
        // The unit-area basis reads the same edge as three octaves smoother.
        let s = exponents(Basis::UnitArea);
        assert!(s[8 * w + 256].unwrap() >= 3);
    }

    #[test]
    fn odd_sizes_and_single_rows_or_columns_work() {
        for (w, h) in [(1, 1), (1, 37), (37, 1), (13, 7), (100, 3)] {
            let img: Vec<f64> = (0..w * h).map(|i| ((i * 7919) % 13) as f64).collect();
            let s = scale_exponents(&img, w, h, Filter::D4, Basis::Amplitude, EPSILON, Reference::Local);
            assert_eq!(s.len(), w * h);
        }
    }
}

//! The separable form of Tokuyoshi's gather (Eq. 1; `filter::Gather::Separable`) in f32 over
//! packed guides, for the methods that filter every frame inside a preview budget (`auto`).
//! Its weights are the same as `filter`'s: the screen Gaussian of the centre's width, the depth
//! weight (Eq. 3) and the lobe-aware weight (Eq. 12 in the overflow-free ratio form), added as
//! logarithms with one exponential per neighbour; `filter::filter` with `Gather::Separable` is
//! its oracle (tests below). What makes it cheaper: f32, guides packed into 24 bytes with the
//! lobe's sharpness and its logarithm precomputed, the spatial factor tabled per centre, and the
//! ratio term skipped for lobes of equal sharpness (every pair of diffuse pixels), and an
//! exponential and logarithm that vectorise (`render::fast_math`).
use super::filter::Guide;
use crate::render::fast_math::{exp_neg, ln_pos};
use rayon::prelude::*;

/// One pixel's guide, packed (see `filter::Guide`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PackedGuide {
    /// Unit lobe axis.
    pub axis: [f32; 3],
    /// The smoothed lobe's sharpness (Eq. 10), at least `MIN_SHARPNESS`, and its logarithm.
    pub sharpness: f32,
    pub ln_sharpness: f32,
    /// Distance from the camera.
    pub depth: f32,
    /// 1 for a pixel that feeds and is filtered, 0 for one that does neither.
    pub valid: f32,
}

/// Sharpness below this counts as this: a lobe that flat is uniform to f32 (two of them weigh
/// 1, one against a lobe of sharpness 1 weighs about e^-70 at beta = 20, as Eq. 12's 1 and 0).
const MIN_SHARPNESS: f32 = 1e-6;

impl PackedGuide {
    pub const INVALID: PackedGuide =
        PackedGuide { axis: [0.0; 3], sharpness: 1.0, ln_sharpness: 0.0, depth: 0.0, valid: 0.0 };

    pub fn new(g: &Guide) -> Self {
        if !g.valid {
            return Self::INVALID;
        }
        let s = g.lobe.sharpness.clamp(MIN_SHARPNESS as f64, f32::MAX as f64) as f32;
        PackedGuide {
            axis: g.lobe.axis.as_vec3().to_array(),
            sharpness: s,
            ln_sharpness: s.ln(),
            depth: g.depth as f32,
            valid: 1.0,
        }
    }

    pub fn is_valid(&self) -> bool {
        self.valid > 0.0
    }
}

/// The gather's parameters (see `filter::BilateralOptions`; the directional weight is Eq. 12).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackedOptions {
    /// Eq. 12's power beta.
    pub beta: f32,
    /// Eq. 3's variance relative to the centre's depth squared.
    pub sigma_z2_relative: f32,
    /// The radius is ceil(3 sigma) pixels, capped here.
    pub max_radius: usize,
}

/// ln of Eq. 12's weight of lobes with sharpness (s_i, s_j), their inverses and the dot of their
/// axes, in a symmetric form without a min or max: with rho + 1/rho = s_i/s_j + s_j/s_i,
/// `ln(4 rho / (1 + rho)^2) = -ln((2 + rho + 1/rho) / 4)` (0 for equal sharpness: every pair of
/// diffuse lobes), and `u / v = s_i s_j / (s_i + s_j) = 1 / (1/s_i + 1/s_j)`. At most 0.
#[inline(always)]
fn ln_lobe(s: (f32, f32), inv: (f32, f32), dot: f32, beta: f32) -> f32 {
    let q = (2.0 + s.0 * inv.1 + s.1 * inv.0) * 0.25;
    (-0.5 * beta * ln_pos(q.max(1.0)) + beta * (dot.clamp(-1.0, 1.0) - 1.0) / (inv.0 + inv.1)).min(0.0)
}

/// Filters `values` (row-major, `width` wide; finite) in place: a horizontal, then a vertical
/// 1-D gather, each centre with its own screen width `sigma_px` (0: keep the value). Invalid
/// pixels keep their values and feed no one. The vertical pass runs on the transposed image, so
/// that both read memory in order. Rows run in parallel; the result does not depend on the
/// thread count.
pub fn gather(guides: &[PackedGuide], sigma_px: &[f32], width: usize, values: &mut [[f32; 3]], o: &PackedOptions) {
    assert!(guides.len() == values.len() && sigma_px.len() == values.len(), "one guide and width per value");
    if width == 0 || values.is_empty() {
        return;
    }
    let height = values.len() / width;
    let across = rows(guides, sigma_px, width, values, o);
    let (guides_t, sigma_t, across_t) =
        (transpose(guides, width, height), transpose(sigma_px, width, height), transpose(&across, width, height));
    let down_t = rows(&guides_t, &sigma_t, height, &across_t, o);
    values.copy_from_slice(&transpose(&down_t, height, width));
}

/// `v` (row-major, `width` wide, `height` rows) transposed.
fn transpose<T: Copy + Default + Send + Sync>(v: &[T], width: usize, height: usize) -> Vec<T> {
    let mut out = vec![T::default(); v.len()];
    out.par_chunks_mut(height.max(1)).enumerate().for_each(|(x, column)| {
        for (y, o) in column.iter_mut().enumerate() {
            *o = v[y * width + x];
        }
    });
    out
}

/// Centres are gathered this many at a time, one per lane (fixed-size arrays the compiler
/// vectorises).
const LANES: usize = 8;

/// One row in structure-of-arrays form, padded with invalid pixels (weight 0) so that the taps
/// of every block of `LANES` centres lie inside it.
#[derive(Default)]
struct Row {
    axis: [Vec<f32>; 3],
    sharpness: Vec<f32>,
    inverse: Vec<f32>,
    depth: Vec<f32>,
    valid: Vec<f32>,
    value: [Vec<f32>; 3],
    /// Whether every valid pixel of the row has the same sharpness (a row of diffuse pixels):
    /// Eq. 12's sharpness term is then 0 and needs no logarithm.
    uniform: bool,
}

impl Row {
    /// Loads `guides` and `values` after `pad` invalid pixels, with `pad + LANES` after.
    fn load(&mut self, guides: &[PackedGuide], values: &[[f32; 3]], pad: usize) {
        let n = guides.len() + 2 * pad + LANES;
        let fill = |v: &mut Vec<f32>, x: f32| {
            v.clear();
            v.resize(n, x);
        };
        for c in 0..3 {
            fill(&mut self.axis[c], 0.0);
            fill(&mut self.value[c], 0.0);
        }
        fill(&mut self.sharpness, 1.0);
        fill(&mut self.inverse, 1.0);
        fill(&mut self.depth, 0.0);
        fill(&mut self.valid, 0.0);
        let first = guides.iter().find(|g| g.is_valid()).map_or(1.0, |g| g.sharpness);
        self.uniform = guides.iter().all(|g| !g.is_valid() || g.sharpness == first);
        for (i, (g, v)) in guides.iter().zip(values).enumerate() {
            let k = pad + i;
            for ((axis, a), (value, x)) in self.axis.iter_mut().zip(g.axis).zip(self.value.iter_mut().zip(*v)) {
                axis[k] = a;
                value[k] = x;
            }
            self.sharpness[k] = g.sharpness;
            self.inverse[k] = 1.0 / g.sharpness;
            self.depth[k] = g.depth;
            self.valid[k] = g.valid;
        }
    }
}

/// One 1-D gather along every row.
fn rows(
    guides: &[PackedGuide],
    sigma_px: &[f32],
    width: usize,
    values: &[[f32; 3]],
    o: &PackedOptions,
) -> Vec<[f32; 3]> {
    #[cfg(target_arch = "x86_64")]
    let avx2 = std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma");
    let pad = o.max_radius.max(1);
    let mut out = values.to_vec();
    out.par_chunks_mut(width).enumerate().for_each_init(Row::default, |row, (y, out_row)| {
        let span = y * width..(y + 1) * width;
        let s_row = &sigma_px[span.clone()];
        if s_row.iter().all(|&s| !(s > 0.0)) {
            return;
        }
        row.load(&guides[span.clone()], &values[span], pad);
        #[cfg(target_arch = "x86_64")]
        if avx2 {
            // SAFETY: the CPU has AVX2 and FMA.
            return unsafe { row_avx2(row, s_row, out_row, pad, o) };
        }
        row_generic(row, s_row, out_row, pad, o)
    });
    out
}

/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn row_avx2(row: &mut Row, sigma: &[f32], out: &mut [[f32; 3]], pad: usize, o: &PackedOptions) {
    row_generic(row, sigma, out, pad, o)
}

/// Gathers every centre of one loaded row, `LANES` neighbouring centres at a time.
#[inline(always)]
fn row_generic(row: &mut Row, sigma: &[f32], out: &mut [[f32; 3]], pad: usize, o: &PackedOptions) {
    for (b, out) in out.chunks_mut(LANES).enumerate() {
        let x0 = b * LANES;
        let sigma = std::array::from_fn(|l| sigma.get(x0 + l).copied().unwrap_or(0.0));
        let block = if row.uniform {
            gather_block::<true>(row, pad + x0, sigma, o)
        } else {
            gather_block::<false>(row, pad + x0, sigma, o)
        };
        for (l, out) in out.iter_mut().enumerate() {
            if let Some(v) = block[l] {
                *out = v;
            }
        }
    }
}

/// The gathered values of the `LANES` centres from padded position `k0` with widths `sigma`,
/// one centre per lane, so that the taps are the loop and no sum crosses lanes; None for a
/// centre that keeps its value (invalid, or a width of 0). Each centre weighs the taps within
/// its own radius ceil(3 sigma); the loop runs to the largest.
#[inline(always)]
fn gather_block<const UNIFORM: bool>(
    row: &Row,
    k0: usize,
    sigma: [f32; LANES],
    o: &PackedOptions,
) -> [Option<[f32; 3]>; LANES] {
    let lane = |v: &Vec<f32>, at: usize| -> [f32; LANES] { v[at..at + LANES].try_into().expect("LANES taps") };
    let max_radius = o.max_radius.max(1);
    let filtered: [bool; LANES] = std::array::from_fn(|l| row.valid[k0 + l] != 0.0 && sigma[l] > 0.0);
    let radius: [usize; LANES] =
        std::array::from_fn(|l| if filtered[l] { ((3.0 * sigma[l]).ceil() as usize).clamp(1, max_radius) } else { 0 });
    let reach = radius.iter().copied().max().unwrap_or(0);
    if reach == 0 {
        return [None; LANES];
    }
    let r_f: [f32; LANES] = std::array::from_fn(|l| radius[l] as f32);
    let inv_2s2: [f32; LANES] =
        std::array::from_fn(|l| if filtered[l] { 1.0 / (2.0 * sigma[l] * sigma[l]) } else { 0.0 });
    let (cx, cy, cz) = (lane(&row.axis[0], k0), lane(&row.axis[1], k0), lane(&row.axis[2], k0));
    let (c_s, c_inv, c_depth) = (lane(&row.sharpness, k0), lane(&row.inverse, k0), lane(&row.depth, k0));
    let inv_2z2: [f32; LANES] =
        std::array::from_fn(|l| 1.0 / (2.0 * o.sigma_z2_relative * c_depth[l] * c_depth[l]).max(f32::MIN_POSITIVE));
    let beta = o.beta;
    let (mut sum, mut wsum) = ([[0.0f32; LANES]; 3], [0.0f32; LANES]);
    for i in 0..=2 * reach {
        // Every lane's tap at offset d = i - reach from its own centre.
        let at = k0 + i - reach;
        let d = i as f32 - reach as f32;
        let (ax, ay, az) = (lane(&row.axis[0], at), lane(&row.axis[1], at), lane(&row.axis[2], at));
        let (s, inv, depth, valid) =
            (lane(&row.sharpness, at), lane(&row.inverse, at), lane(&row.depth, at), lane(&row.valid, at));
        let (vx, vy, vz) = (lane(&row.value[0], at), lane(&row.value[1], at), lane(&row.value[2], at));
        for l in 0..LANES {
            // The screen term; past the lane's radius, minus infinity (weight 0).
            let screen = if d.abs() <= r_f[l] { -d * d * inv_2s2[l] } else { f32::NEG_INFINITY };
            let dot = cx[l] * ax[l] + cy[l] * ay[l] + cz[l] * az[l];
            let dz = c_depth[l] - depth[l];
            let lobe = if UNIFORM {
                // Equal sharpness s on valid lanes: u / v = s / 2, no sharpness term.
                (0.5 * beta * c_s[l] * (dot.clamp(-1.0, 1.0) - 1.0)).min(0.0)
            } else {
                ln_lobe((c_s[l], s[l]), (c_inv[l], inv[l]), dot, beta)
            };
            let ln_w = screen - dz * dz * inv_2z2[l] + lobe;
            let w = exp_neg(-ln_w) * valid[l];
            sum[0][l] += w * vx[l];
            sum[1][l] += w * vy[l];
            sum[2][l] += w * vz[l];
            wsum[l] += w;
        }
    }
    // A filtered centre's own weight is 1 (every factor is), so its sum of weights is at least 1.
    std::array::from_fn(|l| filtered[l].then(|| [0, 1, 2].map(|c| sum[c][l] / wsum[l])))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::lobe_aware::filter::{filter, BilateralOptions, Gather, Similarity};
    use crate::methods::lobe_aware::lobe::{diffuse, specular};
    use crate::methods::lobe_aware::options::LobeOptions;
    use crate::methods::lobe_aware::weights::ln_lobe_weight;
    use crate::render::material::GlossyModel;
    use crate::render::test_rng::Rng;
    use glam::DVec3;

    /// A 40 x 30 image of diffuse and glossy pixels (exponents 1 to 10^4) with a few invalid
    /// ones, normals tilting across it, two depth layers, per-pixel widths up to 5 px.
    fn scene(rng: &mut Rng) -> (Vec<Guide>, Vec<[f64; 3]>) {
        let (w, h) = (40, 30);
        let mut guides = Vec::new();
        let mut values = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let n = DVec3::new((x as f64 - 20.0) / 30.0, 1.0, (y as f64 - 15.0) / 40.0).normalize();
                let psi = DVec3::new(0.3, 0.9, 0.2).normalize();
                let lobe = if (x / 7 + y / 5) % 2 == 0 {
                    diffuse(n)
                } else {
                    let m = 10f64.powf(4.0 * rng.f() as f64);
                    specular(GlossyModel::BlinnPhong, m, n, psi, &LobeOptions::default())
                };
                guides.push(Guide {
                    valid: rng.f() as f64 > 0.05,
                    depth: if x < 25 { 3.0 + 0.01 * y as f64 } else { 5.0 },
                    normal: n,
                    lobe,
                    asg: None,
                    sigma_px: if (rng.f() as f64) < 0.1 { 0.0 } else { 5.0 * rng.f() as f64 },
                });
                values.push([rng.f() as f64, 2.0 * rng.f() as f64, 0.5]);
            }
        }
        (guides, values)
    }

    #[test]
    fn matches_the_f64_separable_gather() {
        let mut rng = Rng(7);
        let (guides, values) = scene(&mut rng);
        let opts = BilateralOptions {
            similarity: Similarity::Lobe { beta: 20.0 },
            sigma_z2_relative: 0.01,
            max_radius: 16,
            gather: Gather::Separable,
        };
        let oracle = filter(&guides, 40, &values, &opts).values;
        let packed: Vec<PackedGuide> = guides.iter().map(PackedGuide::new).collect();
        let sigma: Vec<f32> = guides.iter().map(|g| g.sigma_px as f32).collect();
        let mut mine: Vec<[f32; 3]> = values.iter().map(|v| v.map(|x| x as f32)).collect();
        let po = PackedOptions { beta: 20.0, sigma_z2_relative: 0.01, max_radius: 16 };
        gather(&packed, &sigma, 40, &mut mine, &po);
        let mut changed = 0;
        for (i, (a, b)) in oracle.iter().zip(&mine).enumerate() {
            for c in 0..3 {
                assert!((a[c] - b[c] as f64).abs() <= 1e-4 * (1.0 + a[c].abs()), "pixel {i}: {a:?} vs {b:?}");
            }
            changed += usize::from((a[0] - values[i][0]).abs() > 1e-3);
        }
        assert!(changed > 600, "the filter must act on most pixels ({changed})");
    }

    #[test]
    fn the_lobe_weight_equals_eq_12_in_f64() {
        let mut rng = Rng(3);
        for _ in 0..2000 {
            let axis = |rng: &mut Rng| {
                DVec3::new(rng.f() as f64 - 0.5, rng.f() as f64 - 0.5, rng.f() as f64 - 0.5).normalize()
            };
            let g = |rng: &mut Rng| Guide {
                valid: true,
                depth: 1.0,
                normal: DVec3::Y,
                lobe: crate::methods::lobe_aware::sg::Sg::new(axis(rng), 10f64.powf(6.0 * rng.f() as f64 - 1.0)),
                asg: None,
                sigma_px: 1.0,
            };
            let (a, b) = (g(&mut rng), g(&mut rng));
            let exact = ln_lobe_weight(&a.lobe, &b.lobe, 20.0).exp();
            let (pa, pb) = (PackedGuide::new(&a), PackedGuide::new(&b));
            let dot = pa.axis.iter().zip(&pb.axis).map(|(x, y)| x * y).sum();
            let ln = ln_lobe((pa.sharpness, pb.sharpness), (1.0 / pa.sharpness, 1.0 / pb.sharpness), dot, 20.0);
            let mine = (ln as f64).exp();
            assert!((exact - mine).abs() < 1e-4 + 1e-3 * exact, "{exact} vs {mine}");
        }
    }

    #[test]
    fn a_constant_image_stays_constant_and_invalid_pixels_pass_through() {
        let mut rng = Rng(11);
        let (guides, _) = scene(&mut rng);
        let packed: Vec<PackedGuide> = guides.iter().map(PackedGuide::new).collect();
        let sigma: Vec<f32> = guides.iter().map(|g| g.sigma_px as f32).collect();
        let mut values: Vec<[f32; 3]> =
            guides.iter().map(|g| if g.valid { [0.25, 1.5, 3.0] } else { [7.0; 3] }).collect();
        gather(
            &packed,
            &sigma,
            40,
            &mut values,
            &PackedOptions { beta: 20.0, sigma_z2_relative: 0.01, max_radius: 16 },
        );
        for (g, v) in guides.iter().zip(&values) {
            if g.valid {
                for (c, want) in [0.25f32, 1.5, 3.0].iter().enumerate() {
                    assert!((v[c] - want).abs() <= 1e-5 * want, "{v:?}");
                }
            } else {
                assert_eq!(*v, [7.0; 3], "an invalid pixel keeps its value");
            }
        }
    }

    #[test]
    fn the_result_does_not_depend_on_the_thread_count() {
        let mut rng = Rng(5);
        let (guides, values) = scene(&mut rng);
        let packed: Vec<PackedGuide> = guides.iter().map(PackedGuide::new).collect();
        let sigma: Vec<f32> = guides.iter().map(|g| g.sigma_px as f32).collect();
        let run = |threads: usize| {
            let mut v: Vec<[f32; 3]> = values.iter().map(|v| v.map(|x| x as f32)).collect();
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let o = PackedOptions { beta: 20.0, sigma_z2_relative: 0.01, max_radius: 16 };
            pool.install(|| gather(&packed, &sigma, 40, &mut v, &o));
            v
        };
        assert_eq!(run(1), run(2));
    }
}

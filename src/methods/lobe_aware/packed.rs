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
    /// Each 1-D gather fits a line through its weighted taps and takes its value at the centre
    /// (local linear regression) instead of their weighted mean: where the weights keep to one
    /// side of the centre (a crease, whose other face the lobe weight shuts out) the mean takes
    /// on the gradient times the taps' mean offset as a bias, which the fit does not. It pays in
    /// variance there (the line extrapolates); where the taps balance it is the mean.
    pub linear: bool,
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
/// pixels keep their values and feed no one. The vertical pass reads each column in place
/// (`Lines`) and writes it whole, so that the only image-sized buffers are the two passes'
/// outputs: at preview sizes fresh pages cost more than the gather's arithmetic. Lines run in
/// parallel; the result does not depend on the thread count.
pub fn gather(guides: &[PackedGuide], sigma_px: &[f32], width: usize, values: &mut [[f32; 3]], o: &PackedOptions) {
    gather_both(guides, None, sigma_px, width, values, o, false);
}

/// `gather` with each pixel valid only where its guide is and `feeds` holds too: the same
/// result as `gather` over guides made invalid where `feeds` is false, without that copy of
/// the guides (a frame filters several parts, each feeding from its own pixels).
pub fn gather_where(
    guides: &[PackedGuide],
    feeds: &[bool],
    sigma_px: &[f32],
    width: usize,
    values: &mut [[f32; 3]],
    o: &PackedOptions,
) {
    gather_both(guides, Some(feeds), sigma_px, width, values, o, false);
}

/// `gather`, also returning each pixel's noise power: the variance of its filtered value for
/// inputs of unit variance, independent between pixels (the sum of the squares of the
/// effective weights with which the two passes combine the inputs; 1 for a pixel that keeps its
/// value, about 1 / (4 pi sigma^2) for a wide Gaussian over one surface, more where the guides
/// cut the kernel or the linear fit extrapolates). `feeds` limits the pixels that feed as in
/// `gather_where` (None: every valid one).
pub fn gather_with_power(
    guides: &[PackedGuide],
    feeds: Option<&[bool]>,
    sigma_px: &[f32],
    width: usize,
    values: &mut [[f32; 3]],
    o: &PackedOptions,
) -> Vec<f32> {
    gather_both(guides, feeds, sigma_px, width, values, o, true).unwrap_or_else(|| vec![1.0; values.len()])
}

fn gather_both(
    guides: &[PackedGuide],
    feeds: Option<&[bool]>,
    sigma_px: &[f32],
    width: usize,
    values: &mut [[f32; 3]],
    o: &PackedOptions,
    power: bool,
) -> Option<Vec<f32>> {
    assert!(guides.len() == values.len() && sigma_px.len() == values.len(), "one guide and width per value");
    assert!(feeds.is_none_or(|f| f.len() == values.len()), "one feed flag per value");
    if width == 0 || values.is_empty() {
        return None;
    }
    let height = values.len() / width;
    let ones = power.then(|| vec![1.0f32; values.len()]);
    let (across, power_across) = lines(Lines::rows(width), guides, feeds, sigma_px, values, ones.as_deref(), o);
    // Column-major: column x's entries from x * height on.
    let (down, power_down) =
        lines(Lines::columns(width, height), guides, feeds, sigma_px, &across, power_across.as_deref(), o);
    values.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        row.iter_mut().enumerate().for_each(|(x, v)| *v = down[x * height + y]);
    });
    power_down.map(|p| (0..values.len()).into_par_iter().map(|k| p[(k % width) * height + k / width]).collect())
}

/// The lines a 1-D pass gathers along, `len` pixels each: element i of line j at
/// `j * across + i * along` in the row-major image.
#[derive(Clone, Copy, Debug)]
struct Lines {
    len: usize,
    along: usize,
    across: usize,
}

impl Lines {
    fn rows(width: usize) -> Self {
        Lines { len: width, along: 1, across: width }
    }

    fn columns(width: usize, height: usize) -> Self {
        Lines { len: height, along: width, across: 1 }
    }

    fn at(&self, line: usize, i: usize) -> usize {
        line * self.across + i * self.along
    }
}

/// Centres are gathered this many at a time, one per lane (fixed-size arrays the compiler
/// vectorises): 8 fill AVX2's registers, 16 AVX-512's. Each centre's sums run over its own taps
/// in the same order at either width (a lane's taps past its radius add exact zeros), so the
/// result does not depend on the CPU (`the_lane_width_does_not_change_a_bit`).
const LANES: usize = 8;
const WIDE_LANES: usize = 16;

/// One row in structure-of-arrays form, padded with invalid pixels (weight 0) so that the taps
/// of every block of `WIDE_LANES` centres lie inside it.
#[derive(Default)]
struct Row {
    axis: [Vec<f32>; 3],
    sharpness: Vec<f32>,
    inverse: Vec<f32>,
    depth: Vec<f32>,
    valid: Vec<f32>,
    value: [Vec<f32>; 3],
    /// Each pixel's noise power (`gather_with_power`); not loaded when not asked for.
    power: Vec<f32>,
    /// Whether every valid pixel of the row has the same sharpness (a row of diffuse pixels):
    /// Eq. 12's sharpness term is then 0 and needs no logarithm.
    uniform: bool,
}

impl Row {
    /// Loads line `line` of `guides` and `values` after `pad` invalid pixels, with
    /// `pad + WIDE_LANES` after, a pixel valid where its guide is and `feeds` (if given) holds. Only the padding is
    /// filled: the row's own entries are each written once.
    #[allow(clippy::too_many_arguments)]
    fn load(
        &mut self,
        lines: Lines,
        line: usize,
        guides: &[PackedGuide],
        feeds: Option<&[bool]>,
        values: &[[f32; 3]],
        power: Option<&[f32]>,
        pad: usize,
    ) {
        let (len, n) = (lines.len, lines.len + 2 * pad + WIDE_LANES);
        let pad_with = |v: &mut Vec<f32>, x: f32| {
            v.resize(n, x);
            v.truncate(n);
            v[..pad].fill(x);
            v[pad + len..].fill(x);
        };
        for c in 0..3 {
            pad_with(&mut self.axis[c], 0.0);
            pad_with(&mut self.value[c], 0.0);
        }
        pad_with(&mut self.sharpness, 1.0);
        pad_with(&mut self.inverse, 1.0);
        pad_with(&mut self.depth, 0.0);
        pad_with(&mut self.valid, 0.0);
        // Only a gather asked for its noise power reads it.
        if let Some(p) = power {
            pad_with(&mut self.power, 1.0);
            for (i, q) in self.power[pad..pad + len].iter_mut().enumerate() {
                *q = p[lines.at(line, i)];
            }
        }
        let mut first = None;
        self.uniform = true;
        let [ax, ay, az] = &mut self.axis;
        let [vx, vy, vz] = &mut self.value;
        fn body(v: &mut [f32], pad: usize, len: usize) -> &mut [f32] {
            &mut v[pad..pad + len]
        }
        let (ax, ay, az) = (body(ax, pad, len), body(ay, pad, len), body(az, pad, len));
        let (vx, vy, vz) = (body(vx, pad, len), body(vy, pad, len), body(vz, pad, len));
        let (sharpness, inverse) = (body(&mut self.sharpness, pad, len), body(&mut self.inverse, pad, len));
        let (depth, valid) = (body(&mut self.depth, pad, len), body(&mut self.valid, pad, len));
        for i in 0..len {
            let k = lines.at(line, i);
            let (g, v) = (&guides[k], &values[k]);
            [ax[i], ay[i], az[i]] = g.axis;
            [vx[i], vy[i], vz[i]] = *v;
            sharpness[i] = g.sharpness;
            inverse[i] = 1.0 / g.sharpness;
            depth[i] = g.depth;
            let feeds = feeds.is_none_or(|f| f[k]);
            valid[i] = if feeds { g.valid } else { 0.0 };
            if feeds && g.is_valid() {
                let s = *first.get_or_insert(g.sharpness);
                self.uniform &= g.sharpness == s;
            }
        }
    }
}

/// One 1-D gather along every line; with `power` (the inputs' noise powers), also the
/// outputs'. The outputs are line-major: line j's entries from `j * lines.len` on.
fn lines(
    lines: Lines,
    guides: &[PackedGuide],
    feeds: Option<&[bool]>,
    sigma_px: &[f32],
    values: &[[f32; 3]],
    power: Option<&[f32]>,
    o: &PackedOptions,
) -> (Vec<[f32; 3]>, Option<Vec<f32>>) {
    #[cfg(target_arch = "x86_64")]
    let avx2 = std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma");
    #[cfg(target_arch = "x86_64")]
    let avx512 = avx2 && std::arch::is_x86_feature_detected!("avx512f");
    let pad = o.max_radius.max(1);
    let len = lines.len.max(1);
    let mut out = vec![[0.0f32; 3]; values.len()];
    // Unwritten (its zero pages never touched) when no power is asked for.
    let mut out_power = vec![0.0f32; values.len()];
    let chunks = out.par_chunks_mut(len).zip(out_power.par_chunks_mut(len));
    chunks.enumerate().for_each_init(
        || (Row::default(), Vec::new()),
        |(row, s_line), (j, (out_line, power_line))| {
            let mut power_line = power.is_some().then_some(power_line);
            // Centres that are not gathered keep their values.
            for (i, v) in out_line.iter_mut().enumerate() {
                *v = values[lines.at(j, i)];
            }
            if let (Some(p), Some(q)) = (power, power_line.as_deref_mut()) {
                q.iter_mut().enumerate().for_each(|(i, q)| *q = p[lines.at(j, i)]);
            }
            s_line.clear();
            s_line.extend((0..lines.len).map(|i| sigma_px[lines.at(j, i)]));
            if s_line.iter().all(|&s| !(s > 0.0)) {
                return;
            }
            row.load(lines, j, guides, feeds, values, power, pad);
            #[cfg(target_arch = "x86_64")]
            if avx512 {
                // SAFETY: the CPU has AVX-512F, AVX2 and FMA.
                return unsafe { row_avx512(row, s_line, out_line, power_line, pad, o) };
            }
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                // SAFETY: the CPU has AVX2 and FMA.
                return unsafe { row_avx2(row, s_line, out_line, power_line, pad, o) };
            }
            row_generic::<LANES>(row, s_line, out_line, power_line, pad, o)
        },
    );
    (out, power.map(|_| out_power))
}

/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn row_avx2(
    row: &mut Row,
    sigma: &[f32],
    out: &mut [[f32; 3]],
    power: Option<&mut [f32]>,
    pad: usize,
    o: &PackedOptions,
) {
    row_generic::<LANES>(row, sigma, out, power, pad, o)
}

/// # Safety
/// The CPU must support AVX-512F, AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn row_avx512(
    row: &mut Row,
    sigma: &[f32],
    out: &mut [[f32; 3]],
    power: Option<&mut [f32]>,
    pad: usize,
    o: &PackedOptions,
) {
    row_generic::<WIDE_LANES>(row, sigma, out, power, pad, o)
}

/// Gathers every centre of one loaded row, `L` neighbouring centres at a time; with
/// `power`, writes each gathered centre's noise power there.
#[inline(always)]
fn row_generic<const L: usize>(
    row: &mut Row,
    sigma: &[f32],
    out: &mut [[f32; 3]],
    mut power: Option<&mut [f32]>,
    pad: usize,
    o: &PackedOptions,
) {
    for (b, out) in out.chunks_mut(L).enumerate() {
        let x0 = b * L;
        let sigma = std::array::from_fn(|l| sigma.get(x0 + l).copied().unwrap_or(0.0));
        let k0 = pad + x0;
        let block = match (row.uniform, o.linear, power.is_some()) {
            (true, false, false) => gather_block::<L, true, false, false>(row, k0, sigma, o),
            (false, false, false) => gather_block::<L, false, false, false>(row, k0, sigma, o),
            (true, true, false) => gather_block::<L, true, true, false>(row, k0, sigma, o),
            (false, true, false) => gather_block::<L, false, true, false>(row, k0, sigma, o),
            (true, false, true) => gather_block::<L, true, false, true>(row, k0, sigma, o),
            (false, false, true) => gather_block::<L, false, false, true>(row, k0, sigma, o),
            (true, true, true) => gather_block::<L, true, true, true>(row, k0, sigma, o),
            (false, true, true) => gather_block::<L, false, true, true>(row, k0, sigma, o),
        };
        for (l, out) in out.iter_mut().enumerate() {
            if let Some((v, p)) = block[l] {
                *out = v;
                if let Some(power) = power.as_deref_mut() {
                    power[x0 + l] = p;
                }
            }
        }
    }
}

/// The gathered values of the `L` centres from padded position `k0` with widths `sigma`,
/// one centre per lane, so that the taps are the loop and no sum crosses lanes; None for a
/// centre that keeps its value (invalid, or a width of 0). Each centre weighs the taps within
/// its own radius ceil(3 sigma); the loop runs to the largest.
#[inline(always)]
fn gather_block<const L: usize, const UNIFORM: bool, const LINEAR: bool, const POWER: bool>(
    row: &Row,
    k0: usize,
    sigma: [f32; L],
    o: &PackedOptions,
) -> [Option<([f32; 3], f32)>; L] {
    let lane = |v: &Vec<f32>, at: usize| -> [f32; L] { v[at..at + L].try_into().expect("L taps") };
    let max_radius = o.max_radius.max(1);
    let filtered: [bool; L] = std::array::from_fn(|l| row.valid[k0 + l] != 0.0 && sigma[l] > 0.0);
    let radius: [usize; L] =
        std::array::from_fn(|l| if filtered[l] { ((3.0 * sigma[l]).ceil() as usize).clamp(1, max_radius) } else { 0 });
    let reach = radius.iter().copied().max().unwrap_or(0);
    if reach == 0 {
        return [None; L];
    }
    let r_f: [f32; L] = std::array::from_fn(|l| radius[l] as f32);
    let inv_2s2: [f32; L] = std::array::from_fn(|l| if filtered[l] { 1.0 / (2.0 * sigma[l] * sigma[l]) } else { 0.0 });
    let (cx, cy, cz) = (lane(&row.axis[0], k0), lane(&row.axis[1], k0), lane(&row.axis[2], k0));
    let (c_s, c_inv, c_depth) = (lane(&row.sharpness, k0), lane(&row.inverse, k0), lane(&row.depth, k0));
    let inv_2z2: [f32; L] =
        std::array::from_fn(|l| 1.0 / (2.0 * o.sigma_z2_relative * c_depth[l] * c_depth[l]).max(f32::MIN_POSITIVE));
    let beta = o.beta;
    let (mut sum, mut wsum) = ([[0.0f32; L]; 3], [0.0f32; L]);
    // The linear fit's moments: sums of w d, w d^2 and w d v.
    let (mut s1, mut s2, mut sdv) = ([0.0f32; L], [0.0f32; L], [[0.0f32; L]; 3]);
    // The noise power's: sums of w^2 P, w^2 d P and w^2 d^2 P.
    let mut pw = [[0.0f32; L]; 3];
    for i in 0..=2 * reach {
        // Every lane's tap at offset d = i - reach from its own centre.
        let at = k0 + i - reach;
        let d = i as f32 - reach as f32;
        let (ax, ay, az) = (lane(&row.axis[0], at), lane(&row.axis[1], at), lane(&row.axis[2], at));
        let (s, inv, depth, valid) =
            (lane(&row.sharpness, at), lane(&row.inverse, at), lane(&row.depth, at), lane(&row.valid, at));
        let (vx, vy, vz) = (lane(&row.value[0], at), lane(&row.value[1], at), lane(&row.value[2], at));
        let tap_power = if POWER { lane(&row.power, at) } else { [0.0; L] };
        for l in 0..L {
            // The screen term; past the lane's radius the weight is 0 exactly (`exp_neg` never
            // returns 0), so that a block's reach, the widest of its lanes, changes no lane's sums.
            let screen = -d * d * inv_2s2[l];
            let inside = if d.abs() <= r_f[l] { valid[l] } else { 0.0 };
            let dot = cx[l] * ax[l] + cy[l] * ay[l] + cz[l] * az[l];
            let dz = c_depth[l] - depth[l];
            let lobe = if UNIFORM {
                // Equal sharpness s on valid lanes: u / v = s / 2, no sharpness term.
                (0.5 * beta * c_s[l] * (dot.clamp(-1.0, 1.0) - 1.0)).min(0.0)
            } else {
                ln_lobe((c_s[l], s[l]), (c_inv[l], inv[l]), dot, beta)
            };
            let ln_w = screen - dz * dz * inv_2z2[l] + lobe;
            let w = exp_neg(-ln_w) * inside;
            sum[0][l] += w * vx[l];
            sum[1][l] += w * vy[l];
            sum[2][l] += w * vz[l];
            wsum[l] += w;
            if LINEAR {
                let wd = w * d;
                s1[l] += wd;
                s2[l] += wd * d;
                sdv[0][l] += wd * vx[l];
                sdv[1][l] += wd * vy[l];
                sdv[2][l] += wd * vz[l];
            }
            if POWER {
                let wwp = w * w * tap_power[l];
                pw[0][l] += wwp;
                if LINEAR {
                    pw[1][l] += wwp * d;
                    pw[2][l] += wwp * d * d;
                }
            }
        }
    }
    // A filtered centre's own weight is 1 (every factor is), so its sum of weights is at least 1.
    // The output is sum_j e_j v_j with effective weights e_j = w_j / S0 (the mean) or
    // w_j (S2 - S1 d_j) / det (the weighted least-squares line a + b d at d = 0); its noise
    // power is sum_j e_j^2 P_j.
    std::array::from_fn(|l| {
        filtered[l].then(|| {
            let det = wsum[l] * s2[l] - s1[l] * s1[l];
            // With taps at one offset only (the centre alone) the line is undetermined: the mean.
            if LINEAR && det > 1e-4 * wsum[l] * s2[l] {
                let value = [0, 1, 2].map(|c| (s2[l] * sum[c][l] - s1[l] * sdv[c][l]) / det);
                let power = if POWER {
                    // The weights' scale divided out before squaring: det^2 underflows f32 where
                    // every tap but the centre weighs almost nothing (0 / 0 was NaN).
                    let (a, b) = (s2[l] / det, s1[l] / det);
                    a * a * pw[0][l] - 2.0 * a * b * pw[1][l] + b * b * pw[2][l]
                } else {
                    0.0
                };
                (value, power)
            } else {
                let power = if POWER { pw[0][l] / (wsum[l] * wsum[l]) } else { 0.0 };
                ([0, 1, 2].map(|c| sum[c][l] / wsum[l]), power)
            }
        })
    })
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

    /// The guides packed, and each one's width in pixels.
    fn packed_with_widths(guides: &[Guide]) -> (Vec<PackedGuide>, Vec<f32>) {
        (guides.iter().map(PackedGuide::new).collect(), guides.iter().map(|g| g.sigma_px as f32).collect())
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
        let (packed, sigma) = packed_with_widths(&guides);
        let mut mine: Vec<[f32; 3]> = values.iter().map(|v| v.map(|x| x as f32)).collect();
        let po = PackedOptions { beta: 20.0, sigma_z2_relative: 0.01, max_radius: 16, linear: false };
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
        let (packed, sigma) = packed_with_widths(&guides);
        let mut values: Vec<[f32; 3]> =
            guides.iter().map(|g| if g.valid { [0.25, 1.5, 3.0] } else { [7.0; 3] }).collect();
        gather(
            &packed,
            &sigma,
            40,
            &mut values,
            &PackedOptions { beta: 20.0, sigma_z2_relative: 0.01, max_radius: 16, linear: false },
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

    /// Diffuse guides of two faces meeting at a vertical crease in the middle of a `w` x `h`
    /// image, their normals 90 degrees apart, at one depth.
    fn crease(w: usize, h: usize) -> Vec<PackedGuide> {
        let guide = |x: usize| {
            let n = if x < w / 2 { DVec3::Z } else { DVec3::X };
            PackedGuide::new(&Guide { valid: true, depth: 2.0, normal: n, lobe: diffuse(n), asg: None, sigma_px: 1.0 })
        };
        (0..w * h).map(|p| guide(p % w)).collect()
    }

    /// A ramp over two faces that meet at a crease (normals 90 degrees apart, so the lobe weight
    /// shuts each face out of the other's gather): the weighted mean is one-sided beside the
    /// crease and at the image's borders and takes on the ramp's slope as a bias there; the
    /// linear fit reproduces the ramp at every pixel, and on a constant image both keep it.
    #[test]
    fn the_linear_gather_reproduces_a_ramp_beside_a_crease_where_the_mean_is_biased() {
        let (w, h) = (28, 13);
        let guides = crease(w, h);
        let sigma = vec![2.0f32; w * h];
        let ramp: Vec<[f32; 3]> = (0..w * h)
            .map(|p| {
                let v = 1.0 + 0.1 * (p % w) as f32 + 0.05 * (p / w) as f32;
                [v, 2.0 * v, 0.5]
            })
            .collect();
        let opts = |linear| PackedOptions { beta: 20.0, sigma_z2_relative: 0.01, max_radius: 16, linear };
        let (mut mean, mut fit) = (ramp.clone(), ramp.clone());
        gather(&guides, &sigma, w, &mut mean, &opts(false));
        gather(&guides, &sigma, w, &mut fit, &opts(true));
        for (p, (want, got)) in ramp.iter().zip(&fit).enumerate() {
            for c in 0..3 {
                assert!((want[c] - got[c]).abs() < 1e-4 * want[c], "pixel {p}, channel {c}: {got:?} vs {want:?}");
            }
        }
        // Beside the crease (x = 13, mid-height) the mean takes on about -0.1 times the taps'
        // mean offset, which lie to its left only.
        let beside = 6 * w + w / 2 - 1;
        assert!(ramp[beside][0] - mean[beside][0] > 0.1, "{:?} vs {:?}", mean[beside], ramp[beside]);
        // Away from the crease and the borders (radius 6) the taps balance and the two agree.
        let inside = 6 * w + 6;
        assert!(
            (mean[inside][0] - fit[inside][0]).abs() < 1e-4,
            "{:?} vs {:?} (ramp {:?})",
            mean[inside],
            fit[inside],
            ramp[inside]
        );
        let mut constant = vec![[0.25f32, 1.5, 3.0]; w * h];
        gather(&guides, &sigma, w, &mut constant, &opts(true));
        assert!(constant.iter().all(|v| v.iter().zip([0.25f32, 1.5, 3.0]).all(|(a, b)| (a - b).abs() < 1e-5 * b)));
    }

    /// The noise power is the variance of the filtered value of independent unit-variance
    /// inputs: checked against filtered noise images, beside a crease (one-sided taps) and away
    /// from it, for the mean and the linear fit, and against the discrete Gaussian's sum of
    /// squared weights on one surface; a pixel that keeps its value has power 1.
    #[test]
    fn the_noise_power_is_the_variance_of_filtered_noise() {
        let (w, h) = (24, 11);
        let guides = crease(w, h);
        let mut sigma = vec![1.5f32; w * h];
        sigma[0] = 0.0;
        let (beside, inside) = (5 * w + w / 2 - 1, 5 * w + 5);
        let mut rng = Rng(19);
        for linear in [false, true] {
            let o = PackedOptions { beta: 20.0, sigma_z2_relative: 0.01, max_radius: 16, linear };
            let mut unit = vec![[0.0f32; 3]; w * h];
            let power = gather_with_power(&guides, None, &sigma, w, &mut unit, &o);
            assert_eq!(power[0], 1.0);
            let trials = 1500;
            let mut second_moment = vec![0.0f64; w * h];
            for _ in 0..trials {
                // Uniform noise of unit variance.
                let mut v: Vec<[f32; 3]> = (0..w * h).map(|_| [(rng.f() - 0.5) * 12f32.sqrt(), 0.0, 0.0]).collect();
                gather(&guides, &sigma, w, &mut v, &o);
                second_moment.iter_mut().zip(&v).for_each(|(m, x)| *m += (x[0] as f64).powi(2) / trials as f64);
            }
            for p in [beside, inside, beside + w + 1] {
                let ratio = second_moment[p] / power[p] as f64;
                assert!((ratio - 1.0).abs() < 0.15, "linear {linear}, pixel {p}: {} vs {}", second_moment[p], power[p]);
            }
            assert!(power[beside] > 1.5 * power[inside], "linear {linear}: {} vs {}", power[beside], power[inside]);
            // Away from the crease and the borders: the separable Gaussian's power.
            let g: Vec<f64> = (-5..=5).map(|d: i32| (-(d * d) as f64 / (2.0 * 1.5 * 1.5)).exp()).collect();
            let one_d = g.iter().map(|x| x * x).sum::<f64>() / g.iter().sum::<f64>().powi(2);
            assert!(
                (power[inside] as f64 / (one_d * one_d) - 1.0).abs() < 1e-3,
                "{} vs {}",
                power[inside],
                one_d * one_d
            );
        }
    }

    #[test]
    fn the_result_does_not_depend_on_the_thread_count() {
        let mut rng = Rng(5);
        let (guides, values) = scene(&mut rng);
        let (packed, sigma) = packed_with_widths(&guides);
        let run = |threads: usize| {
            let mut v: Vec<[f32; 3]> = values.iter().map(|v| v.map(|x| x as f32)).collect();
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let o = PackedOptions { beta: 20.0, sigma_z2_relative: 0.01, max_radius: 16, linear: false };
            pool.install(|| gather(&packed, &sigma, 40, &mut v, &o));
            v
        };
        assert_eq!(run(1), run(2));
    }

    /// The 16-lane blocks (AVX-512) give every row, bit for bit, what the 8-lane ones (AVX2 and
    /// the portable path) give, with mixed and with all-diffuse lobes (both weight paths), with
    /// and without the linear fit and the noise power: frames do not depend on the CPU.
    #[test]
    fn the_lane_width_does_not_change_a_bit() {
        let mut rng = Rng(17);
        let (guides, values) = scene(&mut rng);
        let diffuse_only: Vec<Guide> = guides.iter().map(|g| Guide { lobe: diffuse(g.normal), ..*g }).collect();
        let values: Vec<[f32; 3]> = values.iter().map(|v| v.map(|x| x as f32)).collect();
        let powers: Vec<f32> = (0..values.len()).map(|_| 0.5 + rng.f()).collect();
        let (mut uniform_rows, mut rows) = (0, 0);
        for guides in [&guides, &diffuse_only] {
            let (packed, sigma) = packed_with_widths(guides);
            for (linear, with_power) in [(false, false), (true, false), (false, true), (true, true)] {
                let o = PackedOptions { beta: 20.0, sigma_z2_relative: 0.01, max_radius: 16, linear };
                let power = with_power.then_some(&powers[..]);
                for j in 0..30 {
                    let (lines, pad) = (Lines::rows(40), 16);
                    let mut row = Row::default();
                    row.load(lines, j, &packed, None, &values, power, pad);
                    let (uniform, span) = (row.uniform, j * 40..(j + 1) * 40);
                    let run = |wide: bool| {
                        let (mut out, mut p) = (values[span.clone()].to_vec(), powers[span.clone()].to_vec());
                        let p_out = with_power.then_some(&mut p[..]);
                        let mut row = Row::default();
                        row.load(lines, j, &packed, None, &values, power, pad);
                        if wide {
                            row_generic::<WIDE_LANES>(&mut row, &sigma[span.clone()], &mut out, p_out, pad, &o);
                        } else {
                            row_generic::<LANES>(&mut row, &sigma[span.clone()], &mut out, p_out, pad, &o);
                        }
                        (out, p)
                    };
                    let (narrow, wide) = (run(false), run(true));
                    assert_eq!(narrow, wide, "row {j}, uniform {uniform}, linear {linear}, power {with_power}");
                    assert_ne!(narrow.0, values[span].to_vec(), "row {j}: nothing gathered");
                    (uniform_rows, rows) = (uniform_rows + usize::from(uniform), rows + 1);
                }
            }
        }
        assert!(uniform_rows > 0 && uniform_rows < rows, "{uniform_rows} of {rows} rows of equal sharpness");
    }

    /// Limiting the pixels that feed by a mask gives, bit for bit, what the gather gives over
    /// guides made invalid there (mixed diffuse and glossy lobes, so both weight paths run),
    /// with and without the linear fit and the noise power.
    #[test]
    fn a_feed_mask_equals_invalid_guides() {
        let mut rng = Rng(11);
        let (guides, values) = scene(&mut rng);
        let (packed, sigma) = packed_with_widths(&guides);
        let feeds: Vec<bool> = (0..packed.len()).map(|_| rng.f() > 0.2).collect();
        let masked: Vec<PackedGuide> =
            packed.iter().zip(&feeds).map(|(g, &f)| if f { *g } else { PackedGuide::INVALID }).collect();
        let start: Vec<[f32; 3]> = values.iter().map(|v| v.map(|x| x as f32)).collect();
        for linear in [false, true] {
            let o = PackedOptions { beta: 20.0, sigma_z2_relative: 0.01, max_radius: 16, linear };
            let (mut want, mut got) = (start.clone(), start.clone());
            gather(&masked, &sigma, 40, &mut want, &o);
            gather_where(&packed, &feeds, &sigma, 40, &mut got, &o);
            assert_eq!(got, want, "linear {linear}");
            let (mut want, mut got) = (start.clone(), start.clone());
            let want_power = gather_with_power(&masked, None, &sigma, 40, &mut want, &o);
            let got_power = gather_with_power(&packed, Some(&feeds), &sigma, 40, &mut got, &o);
            assert!(got_power.iter().all(|p| p.is_finite() && *p >= 0.0), "linear {linear}: power not finite");
            assert_eq!((got, got_power), (want, want_power), "linear {linear}, with power");
        }
    }
}

//! The 1-D gather of the separable filter, laid out so that it vectorises: the neighbours'
//! positions, normals and objects as structure-of-arrays f32 planes, weights computed eight
//! taps at a time without branches (the validity, normal, object and cut-off tests become
//! lane masks), and the weighted sums accumulated in f64.
//!
//! Why: the filter is the method's own cost (its "method share"), and a wide kernel reads 100
//! taps per pixel per pass. A scalar f64 tap spent most of its time in libm's exp (a call) and
//! in a long dependent chain. Weights in f32 differ from the f64
//! reference (`super::weight`) by about 1e-7 relative, far below any image's noise; the values
//! and the sums stay f64, so a constant image stays constant to f64 rounding.
use super::{radius, FilterKernel, FilterOptions};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Taps per chunk: two SSE (or one AVX) f32 vectors.
const LANES: usize = 8;
/// Weights are cut at x = 18 (6 standard deviations: below 1.6e-8, they change nothing).
pub(super) const EXP_CUTOFF: f64 = 18.0;

/// e^-x for x >= 0 in f32, branch-free so that it vectorises: e^-x = 2^-n e^-r with
/// n = round(x / ln 2) and |r| <= ln 2 / 2, e^-r by its Taylor series to r^6 (truncation
/// error 0.35^7 / 7! = 1.2e-7, an ulp). x is clamped to the cut-off first (the caller masks
/// those lanes), which keeps 2^-n a normal number.
#[inline(always)]
fn exp_neg(x: f32) -> f32 {
    // Adding 1.5 * 2^23 rounds to an integer held in the low mantissa bits (no SSE4.1 round).
    const SHIFT: f32 = 12_582_912.0;
    // ln 2 split so that n * LN2_HI is exact for the n that occur (n <= 26).
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;
    let x = x.min(EXP_CUTOFF as f32);
    let t = x * std::f32::consts::LOG2_E + SHIFT;
    let n = t - SHIFT;
    let r = (x - n * LN2_HI) - n * LN2_LO;
    let p = 1.0 - r * (1.0 - r * (0.5 - r * (1.0 / 6.0 - r * (1.0 / 24.0 - r * (1.0 / 120.0 - r * (1.0 / 720.0))))));
    let n_bits = t.to_bits().wrapping_sub(SHIFT.to_bits());
    p * f32::from_bits((127u32.wrapping_sub(n_bits)) << 23)
}

/// A centre's constants, hoisted out of its taps.
struct Centre {
    position: [f32; 3],
    normal: [f32; 3],
    object: u32,
    /// 1 / (2 beta^2), finite (so that a zero distance gives weight exactly 1).
    inv_two_beta2: f32,
    cos_min: f32,
}

/// Positions, normals and objects as f32 planes in the order of the gather's rows. Each
/// plane is padded by `LANES` so that the last chunk of a row can be read whole and masked.
pub(super) struct Surface {
    width: usize,
    len: usize,
    position: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
    /// The object id, or 0 for every pixel when the object check is off.
    object: Vec<u32>,
}

impl Surface {
    /// The planes of `point(p)` = (position, normal, object) for p in 0..len, `width` per row,
    /// built in parallel.
    pub(super) fn new(
        len: usize,
        width: usize,
        o: &FilterOptions,
        point: impl Fn(usize) -> (DVec3, Vec3, u32) + Sync,
    ) -> Self {
        let points: Vec<(DVec3, Vec3, u32)> = (0..len).into_par_iter().map(&point).collect();
        let plane = |f: &(dyn Fn(&(DVec3, Vec3, u32)) -> f32 + Sync)| pad(points.par_iter().map(f).collect());
        let check = o.object_id_check;
        Surface {
            width,
            len,
            position: [0, 1, 2].map(|a| plane(&|p| p.0[a] as f32)),
            normal: [0, 1, 2].map(|a| plane(&|p| p.1[a])),
            object: pad(points.par_iter().map(|p| if check { p.2 } else { 0 }).collect()),
        }
    }

    /// The planes of the transposed image (`height` rows become the new row width).
    pub(super) fn transposed(&self, height: usize) -> Self {
        let (w, n) = (self.width, self.len);
        Surface {
            width: height,
            len: n,
            position: [0, 1, 2].map(|a| pad(transpose(&self.position[a][..n], w, height))),
            normal: [0, 1, 2].map(|a| pad(transpose(&self.normal[a][..n], w, height))),
            object: pad(transpose(&self.object[..n], w, height)),
        }
    }

    fn centre(&self, kernels: &Kernels, i: usize, cos_min: f32) -> Centre {
        Centre {
            position: [0, 1, 2].map(|a| self.position[a][i]),
            normal: [0, 1, 2].map(|a| self.normal[a][i]),
            object: self.object[i],
            inv_two_beta2: kernels.inv_two_beta2[i],
            cos_min,
        }
    }

    /// The weights (Eq. 11, unnormalised) of taps j .. j + LANES for centre `c`; lanes at or
    /// past `end` get 0.
    #[inline(always)]
    fn weights<const TANGENT: bool>(&self, valid: &[f32], c: &Centre, j: usize, end: usize) -> [f32; LANES] {
        let lanes = |v: &[f32]| -> [f32; LANES] { v[j..j + LANES].try_into().expect("planes are padded") };
        let (px, py, pz) = (lanes(&self.position[0]), lanes(&self.position[1]), lanes(&self.position[2]));
        let (nx, ny, nz) = (lanes(&self.normal[0]), lanes(&self.normal[1]), lanes(&self.normal[2]));
        let valid = lanes(valid);
        let object: [u32; LANES] = self.object[j..j + LANES].try_into().expect("planes are padded");
        let mut w = [0.0f32; LANES];
        for l in 0..LANES {
            let d = [px[l] - c.position[0], py[l] - c.position[1], pz[l] - c.position[2]];
            let mut d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if TANGENT {
                // The authors' indirect code: distance in the centre's tangent plane.
                let dn = d[0] * c.normal[0] + d[1] * c.normal[1] + d[2] * c.normal[2];
                d2 = (d2 - dn * dn).max(0.0);
            }
            let x = d2 * c.inv_two_beta2;
            let cos = nx[l] * c.normal[0] + ny[l] * c.normal[1] + nz[l] * c.normal[2];
            let keep = (cos >= c.cos_min) & (object[l] == c.object) & (x <= EXP_CUTOFF as f32) & (j + l < end);
            let e = exp_neg(x) * valid[l];
            w[l] = if keep { e } else { 0.0 };
        }
        w
    }

    /// The filtered value of centre `i` (absolute index) over taps lo ..= hi (absolute).
    #[inline(always)]
    fn gather_one<const TANGENT: bool>(
        &self,
        k: &Kernels,
        c: &Centre,
        v: &Values,
        i: usize,
        lo: usize,
        hi: usize,
    ) -> [f64; 3] {
        let mut acc = [[0.0f64; LANES]; 4];
        let mut j = lo;
        while j <= hi {
            let w = self.weights::<TANGENT>(&k.valid, c, j, hi + 1);
            let lanes = |v: &[f64]| -> [f64; LANES] { v[j..j + LANES].try_into().expect("values are padded") };
            let (r, g, b) = (lanes(&v.0[0]), lanes(&v.0[1]), lanes(&v.0[2]));
            for l in 0..LANES {
                let wl = w[l] as f64;
                acc[0][l] += wl * r[l];
                acc[1][l] += wl * g[l];
                acc[2][l] += wl * b[l];
                acc[3][l] += wl;
            }
            j += LANES;
        }
        let [mut sum_r, mut sum_g, mut sum_b, mut wsum] = acc.map(|a| a.iter().sum::<f64>());
        // The centre always counts with weight exactly 1 (methods.md §0.2), whatever the f32
        // normal test made of its own lane: replace that lane's weight.
        let own = 1.0 - self.weights::<TANGENT>(&k.valid, c, i, i + 1)[0] as f64;
        sum_r += own * v.0[0][i];
        sum_g += own * v.0[1][i];
        sum_b += own * v.0[2][i];
        wsum += own;
        [sum_r / wsum, sum_g / wsum, sum_b / wsum]
    }

    /// Filters `values` (in the surface's order) along rows with `kernels` (in the same
    /// order): the 1-D pass. Centres with radius 0 keep their values. Rows run in parallel;
    /// the result does not depend on the threads.
    pub(super) fn gather(&self, kernels: &Kernels, values: &[[f64; 3]], o: &FilterOptions) -> Vec<[f64; 3]> {
        let planar = Values::new(values, self.len);
        let cos_min = o.max_normal_angle_deg.to_radians().cos();
        let mut out = values.to_vec();
        out.par_chunks_mut(self.width.max(1)).enumerate().for_each(|(y, row)| {
            let base = y * self.width;
            for (x, out_px) in row.iter_mut().enumerate() {
                let r = kernels.radius[base + x] as usize;
                if r == 0 {
                    continue;
                }
                let (i, lo, hi) = (base + x, base + x.saturating_sub(r), base + (x + r).min(self.width - 1));
                let c = self.centre(kernels, i, cos_min);
                *out_px = if o.tangent_plane {
                    self.gather_one::<true>(kernels, &c, &planar, i, lo, hi)
                } else {
                    self.gather_one::<false>(kernels, &c, &planar, i, lo, hi)
                };
            }
        });
        out
    }
}

/// The per-pass part of the filter, in the order of a `Surface`: which pixels contribute,
/// each centre's radius in pixels (0: not filtered) and 1 / (2 beta^2).
pub(super) struct Kernels {
    /// 1 for a pixel with a value to contribute, 0 otherwise (a multiplier, not a branch).
    valid: Vec<f32>,
    radius: Vec<u32>,
    inv_two_beta2: Vec<f32>,
}

impl Kernels {
    pub(super) fn new(kernels: &[FilterKernel], o: &FilterOptions) -> Self {
        Kernels {
            valid: pad(kernels.par_iter().map(|k| if k.valid { 1.0 } else { 0.0 }).collect()),
            radius: kernels.par_iter().map(|k| radius(k, o)).collect(),
            // f32::MAX rather than infinity for a beta so small that 1/(2 beta^2) overflows:
            // a zero distance must still give x = 0, not NaN.
            inv_two_beta2: kernels.par_iter().map(|k| ((1.0 / (2.0 * k.beta * k.beta)) as f32).min(f32::MAX)).collect(),
        }
    }

    /// The kernels of the transposed `width` x `height` image.
    pub(super) fn transposed(&self, width: usize, height: usize) -> Self {
        let n = self.radius.len();
        Kernels {
            valid: pad(transpose(&self.valid[..n], width, height)),
            radius: transpose(&self.radius, width, height),
            inv_two_beta2: transpose(&self.inv_two_beta2, width, height),
        }
    }
}

/// The values as three padded f64 planes.
struct Values([Vec<f64>; 3]);

impl Values {
    fn new(values: &[[f64; 3]], len: usize) -> Self {
        Values([0, 1, 2].map(|c| pad(values[..len].par_iter().map(|v| v[c]).collect())))
    }
}

/// `v` followed by `LANES` zeros, so that a row's last chunk can be read whole.
fn pad<T: Copy + Default>(mut v: Vec<T>) -> Vec<T> {
    v.resize(v.len() + LANES, T::default());
    v
}

/// The `height` x `width` row-major image `v` as `width` x `height`, in cache-sized blocks,
/// in parallel over blocks of output rows.
pub(super) fn transpose<T: Copy + Default + Send + Sync>(v: &[T], width: usize, height: usize) -> Vec<T> {
    const B: usize = 32;
    let mut out = vec![T::default(); v.len()];
    out.par_chunks_mut((B * height).max(1)).enumerate().for_each(|(bx, block)| {
        // `block` holds output rows (input columns) bx * B .. bx * B + B.
        for y0 in (0..height).step_by(B) {
            for x in bx * B..((bx + 1) * B).min(width) {
                for y in y0..(y0 + B).min(height) {
                    block[(x - bx * B) * height + y] = v[y * width + x];
                }
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_neg_matches_libm_over_the_filter_range() {
        let mut worst = 0.0f64;
        for i in 0..=180_000 {
            let x = (i as f32 * 1e-4).min(EXP_CUTOFF as f32);
            let (got, want) = (exp_neg(x) as f64, (-(x as f64)).exp());
            worst = worst.max(((got - want) / want).abs());
        }
        assert!(worst < 3e-7, "worst relative error {worst:e}");
        assert_eq!(exp_neg(0.0), 1.0);
        // Past the cut-off the value is clamped (and masked by the caller), never 0 or NaN.
        assert!(exp_neg(1e30) > 0.0 && exp_neg(f32::INFINITY).is_finite());
    }
}

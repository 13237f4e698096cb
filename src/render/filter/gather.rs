//! The two 1-D gathers of the separable filter, laid out so that they vectorise and touch
//! little memory: every per-pixel plane (positions, normals, objects, kernels, values) is
//! stored in blocks of eight horizontally adjacent pixels, structure-of-arrays inside a block
//! (`LANES` lanes), each row padded to whole blocks.
//! - The horizontal pass gathers one centre at a time; its taps are the aligned blocks the
//!   centre's row window overlaps, lanes outside the window masked.
//! - The vertical pass gathers eight centres at once, one per lane: tap `dy` of a block is
//!   the block `dy` rows away, so every load is an aligned block and nothing is transposed.
//!
//! Why: the filter is the method's own cost (its "method share"). A scalar f64 tap spent most
//! of its time in libm's exp, and the earlier row-major layout transposed the whole image,
//! surface and kernels twice per pass to make the vertical taps contiguous. Weights are
//! computed in f32 without branches (validity, normal, object, window and cut-off tests become
//! lane masks); they differ from the f64 reference (`super::weight`) by about 1e-7 relative,
//! far below any image's noise. Values and sums stay f64, so a constant image stays constant
//! to f64 rounding. On x86-64 both passes are also compiled for AVX2 and FMA, chosen at run
//! time.
use super::{radius, FilterKernel, FilterOptions};
use crate::render::fast_math::exp_neg;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Pixels per block: one AVX (two SSE) f32 vector.
pub(super) const LANES: usize = 8;
/// Weights are cut at x = 18 (6 standard deviations: below 1.6e-8, they change nothing).
pub(super) const EXP_CUTOFF: f64 = 18.0;

/// Eight pixels' positions, normals and objects (the object 0 for all when the check is off).
#[derive(Clone, Copy, Default)]
struct SurfaceBlock {
    position: [[f32; LANES]; 3],
    normal: [[f32; LANES]; 3],
    object: [u32; LANES],
}

/// Eight pixels' kernels: 1 for a pixel with a value to contribute (a multiplier, not a
/// branch), the radius in pixels (0: not a filtered centre) and 1 / (2 beta^2). Padding
/// lanes are invalid centres of radius 0.
#[derive(Clone, Copy, Default)]
struct KernelBlock {
    valid: [f32; LANES],
    radius: [u32; LANES],
    inv_two_beta2: [f32; LANES],
}

/// Eight pixels' values, one array per channel.
#[derive(Clone, Copy, Default)]
struct ValueBlock([[f64; LANES]; 3]);

impl ValueBlock {
    /// Up to eight consecutive pixels of a row; the lanes past them are 0.
    #[inline(always)]
    fn from_pixels(pixels: &[[f64; 3]]) -> Self {
        let mut b = ValueBlock::default();
        for (lane, v) in pixels.iter().enumerate().take(LANES) {
            for (channel, &x) in b.0.iter_mut().zip(v) {
                channel[lane] = x;
            }
        }
        b
    }
}

/// Rows of blocks: `per_row` blocks per image row.
#[derive(Clone, Copy)]
struct Layout {
    width: usize,
    height: usize,
    per_row: usize,
}

impl Layout {
    fn new(width: usize, height: usize) -> Self {
        Layout { width, height, per_row: width.div_ceil(LANES) }
    }

    fn blocks(&self) -> usize {
        self.per_row * self.height
    }

    /// Builds one block per index in parallel from `pixel(p, lane)` for the image pixels
    /// it covers; padding lanes stay `T::default()`.
    fn build<B: Default + Send>(&self, fill: impl Fn(&mut B, usize, usize) + Sync) -> Vec<B> {
        let l = *self;
        (0..l.blocks())
            .into_par_iter()
            .with_min_len(l.per_row.max(1))
            .map(|b| {
                let (y, x0) = (b / l.per_row, (b % l.per_row) * LANES);
                let mut block = B::default();
                for lane in 0..LANES.min(l.width - x0) {
                    fill(&mut block, y * l.width + x0 + lane, lane);
                }
                block
            })
            .collect()
    }
}

/// The surface a filter gathers over, in blocks (see the module comment).
pub(super) struct Surface {
    layout: Layout,
    blocks: Vec<SurfaceBlock>,
}

impl Surface {
    /// The blocks of `point(p)` = (position, normal, object) for the `width` x `height`
    /// row-major image, built in one parallel pass.
    pub(super) fn new(
        width: usize,
        height: usize,
        o: &FilterOptions,
        point: impl Fn(usize) -> (DVec3, Vec3, u32) + Sync,
    ) -> Self {
        let layout = Layout::new(width, height);
        let check = o.object_id_check;
        let blocks = layout.build(|b: &mut SurfaceBlock, p, lane| {
            let (position, normal, object) = point(p);
            for a in 0..3 {
                b.position[a][lane] = position[a] as f32;
                b.normal[a][lane] = normal[a];
            }
            b.object[lane] = if check { object } else { 0 };
        });
        Surface { layout, blocks }
    }

    /// Filters `values` (row-major) in place with the separable filter and the pixels'
    /// `kernel(p)`. Pixels that are not filtered centres keep their values (they still feed
    /// their neighbours if valid). Rows run in parallel; the result does not depend on the
    /// threads.
    pub(super) fn filter(
        &self,
        kernel: impl Fn(usize) -> FilterKernel + Sync,
        values: &mut [[f64; 3]],
        o: &FilterOptions,
    ) {
        self.filter_on(kernel, values, o, Isa::detect());
    }

    /// `filter` with the instruction set chosen by the caller (tests run both).
    fn filter_on(
        &self,
        kernel: impl Fn(usize) -> FilterKernel + Sync,
        values: &mut [[f64; 3]],
        o: &FilterOptions,
        isa: Isa,
    ) {
        let l = self.layout;
        let kernels = l.build(|b: &mut KernelBlock, p, lane| {
            let k = kernel(p);
            b.valid[lane] = if k.valid { 1.0 } else { 0.0 };
            b.radius[lane] = radius(&k, o);
            // f32::MAX rather than infinity for a beta so small that 1/(2 beta^2) overflows:
            // a zero distance must still give x = 0, not NaN.
            b.inv_two_beta2[lane] = ((1.0 / (2.0 * k.beta * k.beta)) as f32).min(f32::MAX);
        });
        let cos_min = o.max_normal_angle_deg.to_radians().cos();
        let g = Gather { surface: &self.blocks, kernels: &kernels, layout: l, options: *o, cos_min, isa };
        // The horizontal pass reads `values` as they are and writes blocks; the vertical pass
        // reads those and writes its centres back into `values`: one image-sized buffer.
        let horizontal: Vec<ValueBlock> =
            (0..l.blocks()).into_par_iter().with_min_len(l.per_row.max(1)).map(|b| g.horizontal(values, b)).collect();
        values.par_chunks_mut(l.width.max(1)).enumerate().for_each(|(y, row)| {
            for (bx, pixels) in row.chunks_mut(LANES).enumerate() {
                g.vertical(&horizontal, y * l.per_row + bx, pixels);
            }
        });
    }
}

/// The constants of up to eight centres, one per lane.
struct Centres {
    position: [[f32; LANES]; 3],
    normal: [[f32; LANES]; 3],
    object: [u32; LANES],
    inv_two_beta2: [f32; LANES],
    cos_min: f32,
}

impl Centres {
    /// Every lane the same centre: lane `lane` of block `s`, `k`.
    fn splat(s: &SurfaceBlock, k: &KernelBlock, lane: usize, cos_min: f32) -> Self {
        Centres {
            position: [0, 1, 2].map(|a| [s.position[a][lane]; LANES]),
            normal: [0, 1, 2].map(|a| [s.normal[a][lane]; LANES]),
            object: [s.object[lane]; LANES],
            inv_two_beta2: [k.inv_two_beta2[lane]; LANES],
            cos_min,
        }
    }

    /// Lane i the centre in lane i of block `s`, `k`.
    fn lanes(s: &SurfaceBlock, k: &KernelBlock, cos_min: f32) -> Self {
        Centres { position: s.position, normal: s.normal, object: s.object, inv_two_beta2: k.inv_two_beta2, cos_min }
    }

    /// The weights (Eq. 11, unnormalised) of tap block `s`, `k` for these centres; lanes
    /// where `inside` is false get 0.
    #[inline(always)]
    fn weights<const TANGENT: bool>(&self, s: &SurfaceBlock, k: &KernelBlock, inside: [bool; LANES]) -> [f32; LANES] {
        let mut w = [0.0f32; LANES];
        for l in 0..LANES {
            let d = [0, 1, 2].map(|a| s.position[a][l] - self.position[a][l]);
            let mut d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if TANGENT {
                // The authors' indirect code: distance in the centre's tangent plane.
                let dn = d[0] * self.normal[0][l] + d[1] * self.normal[1][l] + d[2] * self.normal[2][l];
                d2 = (d2 - dn * dn).max(0.0);
            }
            let x = d2 * self.inv_two_beta2[l];
            let cos = s.normal[0][l] * self.normal[0][l]
                + s.normal[1][l] * self.normal[1][l]
                + s.normal[2][l] * self.normal[2][l];
            let keep = (cos >= self.cos_min) & (s.object[l] == self.object[l]) & (x <= EXP_CUTOFF as f32) & inside[l];
            let e = exp_neg(x) * k.valid[l];
            w[l] = if keep { e } else { 0.0 };
        }
        w
    }
}

/// Weighted sums of eight lanes: three channels and the weight.
#[derive(Default)]
struct Sums([[f64; LANES]; 4]);

impl Sums {
    #[inline(always)]
    fn add(&mut self, w: &[f32; LANES], v: &ValueBlock) {
        for (l, &wl) in w.iter().enumerate() {
            let wl = wl as f64;
            for c in 0..3 {
                self.0[c][l] += wl * v.0[c][l];
            }
            self.0[3][l] += wl;
        }
    }
}

/// The code the passes run: compiled for the build target, or also for AVX2 and FMA.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Isa {
    Generic,
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl Isa {
    fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            return Isa::Avx2;
        }
        Isa::Generic
    }
}

/// One filter call's inputs, shared by the passes.
struct Gather<'a> {
    surface: &'a [SurfaceBlock],
    kernels: &'a [KernelBlock],
    layout: Layout,
    options: FilterOptions,
    /// Cosine of the largest normal angle a neighbour may have (`options`), computed once.
    cos_min: f32,
    isa: Isa,
}

impl Gather<'_> {
    /// The row-major index of lane 0 of block `b`.
    fn first_pixel(&self, b: usize) -> usize {
        let l = self.layout;
        (b / l.per_row) * l.width + (b % l.per_row) * LANES
    }

    /// Block `b` after the horizontal pass over the row-major `values`: each centre lane
    /// gathered along its row, the other lanes as they were.
    fn horizontal(&self, input: &[[f64; 3]], b: usize) -> ValueBlock {
        match self.isa {
            Isa::Generic => self.horizontal_generic(input, b),
            // SAFETY: `Isa::detect` found AVX2 and FMA.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => unsafe { self.horizontal_avx2(input, b) },
        }
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn horizontal_avx2(&self, input: &[[f64; 3]], b: usize) -> ValueBlock {
        self.horizontal_generic(input, b)
    }

    #[inline(always)]
    fn horizontal_generic(&self, input: &[[f64; 3]], b: usize) -> ValueBlock {
        let start = self.first_pixel(b);
        let row_end = start - start % self.layout.width.max(1) + self.layout.width;
        let mut out = ValueBlock::from_pixels(&input[start..(start + LANES).min(row_end)]);
        let k = &self.kernels[b];
        for lane in 0..LANES {
            if k.radius[lane] > 0 {
                let v = if self.options.tangent_plane {
                    self.gather_row::<true>(input, b, lane)
                } else {
                    self.gather_row::<false>(input, b, lane)
                };
                for (channel, x) in out.0.iter_mut().zip(v) {
                    channel[lane] = x;
                }
            }
        }
        out
    }

    /// The horizontal gather of the centre in lane `lane` of block `b`.
    #[inline(always)]
    fn gather_row<const TANGENT: bool>(&self, input: &[[f64; 3]], b: usize, lane: usize) -> [f64; 3] {
        let l = self.layout;
        let row = b - b % l.per_row;
        let x = (b - row) * LANES + lane;
        let r = self.kernels[b].radius[lane] as usize;
        let c = Centres::splat(&self.surface[b], &self.kernels[b], lane, self.cos_min);
        let (first, last) = (x.saturating_sub(r) / LANES, (x + r).min(l.width - 1) / LANES);
        let mut sums = Sums::default();
        for tb in first..=last {
            let inside = std::array::from_fn(|t| (tb * LANES + t).abs_diff(x) <= r);
            let mut w = c.weights::<TANGENT>(&self.surface[row + tb], &self.kernels[row + tb], inside);
            if row + tb == b {
                // The centre always counts with weight exactly 1 (methods.md §0.2), whatever
                // the f32 normal test made of its own lane.
                w[lane] = 1.0;
            }
            let start = self.first_pixel(row + tb);
            let end = (start + LANES).min(self.first_pixel(row) + l.width);
            sums.add(&w, &ValueBlock::from_pixels(&input[start..end]));
        }
        let [r_, g, b_, wsum] = sums.0.map(|a| a.iter().sum::<f64>());
        [r_ / wsum, g / wsum, b_ / wsum]
    }

    /// The vertical pass of block `b`: its centre lanes gathered together down their
    /// columns from the horizontal pass's `input`, written to `pixels` (the block's pixels
    /// of the output image; the other lanes are left alone).
    fn vertical(&self, input: &[ValueBlock], b: usize, pixels: &mut [[f64; 3]]) {
        match self.isa {
            Isa::Generic => self.vertical_generic(input, b, pixels),
            // SAFETY: `Isa::detect` found AVX2 and FMA.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => unsafe { self.vertical_avx2(input, b, pixels) },
        }
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn vertical_avx2(&self, input: &[ValueBlock], b: usize, pixels: &mut [[f64; 3]]) {
        self.vertical_generic(input, b, pixels)
    }

    #[inline(always)]
    fn vertical_generic(&self, input: &[ValueBlock], b: usize, pixels: &mut [[f64; 3]]) {
        if self.kernels[b].radius.iter().all(|&r| r == 0) {
            return;
        }
        let sums = if self.options.tangent_plane {
            self.gather_column::<true>(input, b)
        } else {
            self.gather_column::<false>(input, b)
        };
        for (lane, v) in pixels.iter_mut().enumerate() {
            if self.kernels[b].radius[lane] > 0 {
                *v = [0, 1, 2].map(|c| sums.0[c][lane] / sums.0[3][lane]);
            }
        }
    }

    /// The weighted sums of the centre lanes of block `b` down their columns.
    #[inline(always)]
    fn gather_column<const TANGENT: bool>(&self, input: &[ValueBlock], b: usize) -> Sums {
        let l = self.layout;
        let k = &self.kernels[b];
        let c = Centres::lanes(&self.surface[b], k, self.cos_min);
        let y = b / l.per_row;
        let r_max = k.radius.iter().copied().max().unwrap_or(0) as usize;
        let mut sums = Sums::default();
        for ty in y.saturating_sub(r_max)..=(y + r_max).min(l.height - 1) {
            let tb = b - y * l.per_row + ty * l.per_row;
            let w = if ty == y {
                // Each lane's own pixel: weight exactly 1 (methods.md §0.2).
                [1.0; LANES]
            } else {
                let inside = std::array::from_fn(|t| ty.abs_diff(y) <= k.radius[t] as usize);
                c.weights::<TANGENT>(&self.surface[tb], &self.kernels[tb], inside)
            };
            sums.add(&w, &input[tb]);
        }
        sums
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generic_code_gives_the_same_image_as_the_detected_instruction_set() {
        // Rows ending mid-block, radii that differ per lane, rejections of every kind and both
        // distance measures: the AVX2 build may differ from the generic one only by the f32
        // rounding of FMA contractions.
        let (w, h) = (21, 13);
        for tangent_plane in [false, true] {
            let o = FilterOptions { tangent_plane, ..FilterOptions::default() };
            let point = |p: usize| {
                let (x, y) = ((p % w) as f64, (p / w) as f64);
                let normal = if p.is_multiple_of(11) { Vec3::X } else { Vec3::Z };
                (DVec3::new(x * 0.1, y * 0.1, (x * 0.3).sin() * 0.05), normal, p.is_multiple_of(17) as u32)
            };
            let surface = Surface::new(w, h, &o, point);
            let kernel =
                |p: usize| FilterKernel { valid: !p.is_multiple_of(13), beta: 0.05 + 0.03 * (p % 5) as f64, d: 0.1 };
            let values: Vec<[f64; 3]> =
                (0..w * h).map(|p| [(p % 7) as f64, (p % 3) as f64 * 0.5, ((p * 31) % 19) as f64]).collect();
            let (mut generic, mut detected) = (values.clone(), values.clone());
            surface.filter_on(kernel, &mut generic, &o, Isa::Generic);
            surface.filter_on(kernel, &mut detected, &o, Isa::detect());
            assert_ne!(generic, values, "the test filters nothing");
            for (a, b) in generic.iter().zip(&detected) {
                for c in 0..3 {
                    assert!((a[c] - b[c]).abs() <= 1e-5 * (1.0 + b[c].abs()), "{a:?} vs {b:?}");
                }
            }
        }
    }

    #[test]
    fn blocks_cover_every_pixel_once_and_pad_the_rest() {
        // Widths below, at and past a block, and a row that ends mid-block.
        for (w, h) in [(5, 3), (8, 2), (19, 4)] {
            let l = Layout::new(w, h);
            let blocks = l.build(|b: &mut [u32; LANES], p, lane| b[lane] = p as u32 + 1);
            assert_eq!(blocks.len(), w.div_ceil(LANES) * h);
            let mut seen = vec![0; w * h];
            for (i, b) in blocks.iter().enumerate() {
                for (lane, &v) in b.iter().enumerate() {
                    let x = (i % l.per_row) * LANES + lane;
                    if x >= w {
                        assert_eq!(v, 0, "{w}x{h}: padding lane filled");
                    } else {
                        assert_eq!(v as usize, (i / l.per_row) * w + x + 1);
                        seen[v as usize - 1] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&n| n == 1));
        }
    }
}

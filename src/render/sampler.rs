//! Deterministic, stratified sample values.
//!
//! Every random number of a sample derives from (seed, pixel, sample index, dimension) alone, so
//! an image is bit-identical whatever the thread count or tile order. The sample index is the
//! pixel's running sample count, so pass `p` continues where pass `p-1` stopped and the samples
//! of all passes together stay stratified.
//!
//! Values come from the first two dimensions of the Sobol sequence (a (0,2)-sequence: every
//! power-of-two prefix is stratified in both dimensions at once) with hash-based Owen scrambling
//! and index shuffling (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4)), with an
//! independent scramble per pixel and per dimension pair.

/// 64-bit finaliser (SplitMix64 / Stafford mix 13): a well-distributed hash of one word.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Hashes several words into one.
#[inline]
pub fn hash_words(words: &[u64]) -> u64 {
    words.iter().fold(0x9e37_79b9_7f4a_7c15, |h, &w| mix64(h ^ w.wrapping_add(0x9e37_79b9_7f4a_7c15)))
}

/// Laine-Karras style permutation: an Owen scramble of the bits of `x` from the top down when
/// applied to bit-reversed values (Burley 2020, Listing 2).
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// An Owen scramble of `x` (Burley 2020, Listing 2), as the tests' reference.
#[cfg(test)]
#[inline]
fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// Sobol dimension 0 (van der Corput) as a 32-bit fraction.
#[cfg(test)]
#[inline]
fn sobol0(i: u32) -> u32 {
    i.reverse_bits()
}

/// Sobol dimension 1: direction numbers of the primitive polynomial x + 1.
#[cfg(test)]
#[inline]
fn sobol1(mut i: u32) -> u32 {
    let mut v = 1u32 << 31;
    let mut r = 0;
    while i != 0 {
        if i & 1 != 0 {
            r ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    r
}

/// Sobol dimension 1, bit-reversed: `sobol1(i).reverse_bits()`. The sampler works on
/// bit-reversed values (an Owen scramble is a Laine-Karras permutation of them) and has the
/// shuffled index `i` at hand, since dimension 0 needs it too.
///
/// Dimension 1's direction numbers are the rows of Pascal's triangle mod 2 (v_k = v_{k-1} ^
/// (v_{k-1} >> 1)), so bit m of the reversed output is the XOR of the index's bits k with
/// C(k, m) odd, that is (Lucas) with m a submask of k: the superset sum of the index's bits
/// over the 5-bit positions, five shift-mask-XOR steps. Linear over GF(2) like the table it
/// replaced, it needs no memory, and runs on several samples per instruction
/// (`draw_ahead`).
#[inline(always)]
fn sobol1_of_index(mut i: u32) -> u32 {
    i ^= (i >> 1) & 0x5555_5555;
    i ^= (i >> 2) & 0x3333_3333;
    i ^= (i >> 4) & 0x0f0f_0f0f;
    i ^= (i >> 8) & 0x00ff_00ff;
    i ^= (i >> 16) & 0x0000_ffff;
    i
}

/// 2^-32 with the result kept strictly below 1 in f32.
#[inline]
fn to_unit(x: u32) -> f32 {
    // Use the top 24 bits so that the f32 value is exact and < 1.
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// Dimension pairs a sampler can hold drawn ahead (`PixelSampler::draw_ahead`): a path of a few
/// bounces under a few lights; the pairs past them are drawn one at a time.
pub const MAX_AHEAD: usize = 12;

/// The sample stream of one pixel: yields stratified 2-D points for successive dimension pairs.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    key: u64,
    /// The sample index, bit-reversed once here rather than at every point.
    reversed_index: u32,
    pair: u32,
    /// Pairs `ahead_from .. ahead_from + ahead_len` drawn ahead (`draw_ahead`): drawing one of
    /// them reads it here.
    ahead_from: u32,
    ahead_len: u32,
    ahead: [[f32; 2]; MAX_AHEAD],
}

impl PixelSampler {
    /// Sampler for sample `index` (0-based, counted over all passes) of pixel `pixel`.
    #[cfg_attr(not(feature = "stage-symbols"), inline)]
    #[cfg_attr(feature = "stage-symbols", inline(never))]
    pub fn new(seed: u64, pixel: u32, index: u32) -> Self {
        Self::of_pixel(Self::pixel_key(seed, pixel), index)
    }

    /// The scramble key of pixel `pixel` under `seed`, shared by all its samples: computed
    /// once, it spares a caller that draws many samples of a pixel a hash per sample.
    #[cfg_attr(not(feature = "stage-symbols"), inline)]
    #[cfg_attr(feature = "stage-symbols", inline(never))]
    pub fn pixel_key(seed: u64, pixel: u32) -> u64 {
        hash_words(&[seed, pixel as u64])
    }

    /// `new(seed, pixel, index)` from the pixel's `pixel_key(seed, pixel)`.
    #[cfg_attr(not(feature = "stage-symbols"), inline)]
    #[cfg_attr(feature = "stage-symbols", inline(never))]
    pub fn of_pixel(key: u64, index: u32) -> Self {
        Self::at_pair(key, index.reverse_bits(), 0)
    }

    #[inline(always)]
    fn at_pair(key: u64, reversed_index: u32, pair: u32) -> Self {
        PixelSampler { key, reversed_index, pair, ahead_from: 0, ahead_len: 0, ahead: [[0.0; 2]; MAX_AHEAD] }
    }

    /// The key of the stream a pixel's split paths draw from (`integrator::radiance_split`), from
    /// the pixel's `pixel_key`: a stream of its own, so that the split paths' numbers are
    /// independent of the camera samples' and the paths of all the pixel's samples, numbered
    /// consecutively, form one stratified set.
    #[inline]
    pub fn split_key(key: u64) -> u64 {
        mix64(key ^ SPLIT_DOMAIN)
    }

    /// Samplers for samples `first ..` of the stream `key`, one per entry of `samplers`, none of
    /// their pairs drawn yet: consecutive samples of one stream, for `draw_ahead`.
    #[inline]
    pub fn consecutive(key: u64, first: u32, samplers: &mut [PixelSampler]) {
        for (i, s) in samplers.iter_mut().enumerate() {
            *s = Self::of_pixel(key, first.wrapping_add(i as u32));
        }
    }

    /// The dimension pairs drawn so far (a 1-D value takes a pair).
    pub fn pairs_drawn(&self) -> u32 {
        self.pair
    }

    /// Pair `pair`'s point if it was drawn ahead.
    #[inline(always)]
    fn drawn_ahead(&self, pair: u32) -> Option<[f32; 2]> {
        self.ahead[..self.ahead_len as usize].get(pair.wrapping_sub(self.ahead_from) as usize).copied()
    }

    /// The next 2-D point in [0,1)^2. Successive calls use independent scrambles, each stratified
    /// across the pixel's samples.
    ///
    /// Point i of the shuffled, scrambled sequence is (owen(sobol0(i')), owen(sobol1(i'))) with
    /// i' = owen(i) (Burley 2020, Listing 3). The steps run on bit-reversed values where they
    /// can, since an Owen scramble is a Laine-Karras permutation of the reversed bits: sobol0
    /// reversed is the identity.
    #[cfg_attr(not(feature = "stage-symbols"), inline(always))]
    #[cfg_attr(feature = "stage-symbols", inline(never))]
    pub fn next_2d(&mut self) -> [f32; 2] {
        let pair = self.pair;
        self.pair += 1;
        if let Some(p) = self.drawn_ahead(pair) {
            return p;
        }
        point_2d(self.reversed_index, pair_hash(self.key, pair))
    }

    /// The next 1-D value in [0,1): the first coordinate of a fresh pair, without the work of
    /// the second.
    #[cfg_attr(not(feature = "stage-symbols"), inline(always))]
    #[cfg_attr(feature = "stage-symbols", inline(never))]
    pub fn next_1d(&mut self) -> f32 {
        let pair = self.pair;
        self.pair += 1;
        if let Some(p) = self.drawn_ahead(pair) {
            return p[0];
        }
        let h = pair_hash(self.key, pair);
        let j = laine_karras(self.reversed_index, h as u32);
        to_unit(laine_karras(j.reverse_bits(), (h >> 32) as u32).reverse_bits())
    }

    /// Samplers for samples `first ..` of the pixel with key `key` (`pixel_key`), one per entry
    /// of `samplers`, each after its first pair, which goes to `points`: what `of_pixel` and
    /// `next_2d` give each, with the pair's scramble hashed once for all of them (a pixel's
    /// camera samples draw their jitter this way).
    #[cfg_attr(not(feature = "stage-symbols"), inline)]
    #[cfg_attr(feature = "stage-symbols", inline(never))]
    pub fn first_points(key: u64, first: u32, samplers: &mut [PixelSampler], points: &mut [[f32; 2]]) {
        let h = pair_hash(key, 0);
        let chunks = samplers.chunks_mut(AHEAD_LANES).zip(points.chunks_mut(AHEAD_LANES));
        for (c, (samplers, points)) in chunks.enumerate() {
            let first = first.wrapping_add((c * AHEAD_LANES) as u32);
            let reversed: [u32; AHEAD_LANES] = std::array::from_fn(|i| first.wrapping_add(i as u32).reverse_bits());
            let (xs, ys) = points_in_lanes(&reversed, samplers.len(), h);
            for (i, (s, p)) in samplers.iter_mut().zip(points).enumerate() {
                *s = Self::at_pair(key, reversed[i], 1);
                *p = [xs[i], ys[i]];
            }
        }
    }

    /// Draws the next `pairs` pairs (at most `MAX_AHEAD`) of every sampler in `samplers`, ahead
    /// of their use: the samples of one pixel at one pair (`first_points`' samplers), which
    /// draw the same pairs in step and differ only in their index. Each pair's scramble is then
    /// hashed once for all of them and their points are computed several per instruction; each
    /// point is the one `next_2d` would draw, bit for bit.
    #[cfg_attr(not(feature = "stage-symbols"), inline)]
    #[cfg_attr(feature = "stage-symbols", inline(never))]
    pub fn draw_ahead(samplers: &mut [PixelSampler], pairs: usize) {
        if pairs == 0 {
            return;
        }
        let Some(&PixelSampler { key, pair: from, .. }) = samplers.first() else { return };
        assert!(samplers.iter().all(|s| s.key == key && s.pair == from), "samples of one pixel, at one pair");
        let pairs = pairs.min(MAX_AHEAD);
        for chunk in samplers.chunks_mut(AHEAD_LANES) {
            let mut reversed = [0u32; AHEAD_LANES];
            for (r, s) in reversed.iter_mut().zip(chunk.iter()) {
                *r = s.reversed_index;
            }
            for k in 0..pairs {
                let (xs, ys) = points_in_lanes(&reversed, chunk.len(), pair_hash(key, from + k as u32));
                for (i, s) in chunk.iter_mut().enumerate() {
                    s.ahead[k] = [xs[i], ys[i]];
                }
            }
            for s in chunk {
                (s.ahead_from, s.ahead_len) = (from, pairs as u32);
            }
        }
    }
}

/// Mixed into a pixel's key to give its split paths' stream (`PixelSampler::split_key`).
const SPLIT_DOMAIN: u64 = 0x5bd1_e995_9e37_79b9;

/// Samples whose points `draw_ahead` computes together: an AVX-512 register of 32-bit lanes.
const AHEAD_LANES: usize = 16;

/// Fewer samples than this compute their points one at a time: a vector of 16 lanes costs
/// about as much as this many scalar points.
const VECTOR_FROM: usize = 4;

/// `point_2d` of the first `n` indices in `reversed` with one pair's scramble seeds `h`: the two
/// coordinates' lanes (past `n`, zeros or the points of the lanes' indices). On x86-64 the lanes
/// go to the widest vector unit the CPU has; the arithmetic is integer and exact, so every
/// width gives the same bits.
#[inline(always)]
fn points_in_lanes(reversed: &[u32; AHEAD_LANES], n: usize, h: u64) -> ([f32; AHEAD_LANES], [f32; AHEAD_LANES]) {
    if n < VECTOR_FROM {
        let (mut xs, mut ys) = ([0.0; AHEAD_LANES], [0.0; AHEAD_LANES]);
        for i in 0..n {
            [xs[i], ys[i]] = point_2d(reversed[i], h);
        }
        return (xs, ys);
    }
    points_in_vector_lanes(reversed, h)
}

/// `points_in_lanes` of all the lanes, in the widest vector unit the CPU has.
#[inline(never)]
fn points_in_vector_lanes(reversed: &[u32; AHEAD_LANES], h: u64) -> ([f32; AHEAD_LANES], [f32; AHEAD_LANES]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512bw") {
            // SAFETY: the CPU has AVX-512F and AVX-512BW.
            return unsafe { points_avx512(reversed, h) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            return unsafe { points_avx2(reversed, h) };
        }
    }
    points_generic(reversed, h)
}

/// # Safety
/// The CPU must support AVX-512F and AVX-512BW.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx2")]
unsafe fn points_avx512(reversed: &[u32; AHEAD_LANES], h: u64) -> ([f32; AHEAD_LANES], [f32; AHEAD_LANES]) {
    points_generic(reversed, h)
}

/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn points_avx2(reversed: &[u32; AHEAD_LANES], h: u64) -> ([f32; AHEAD_LANES], [f32; AHEAD_LANES]) {
    points_generic(reversed, h)
}

#[inline(always)]
fn points_generic(reversed: &[u32; AHEAD_LANES], h: u64) -> ([f32; AHEAD_LANES], [f32; AHEAD_LANES]) {
    let (mut xs, mut ys) = ([0.0; AHEAD_LANES], [0.0; AHEAD_LANES]);
    for ((x, y), &r) in xs.iter_mut().zip(ys.iter_mut()).zip(reversed) {
        [*x, *y] = point_2d(r, h);
    }
    (xs, ys)
}

/// The scramble seeds of dimension pair `pair` of the pixel with key `key`, shared by all its
/// samples: the index shuffle's in the low word, the first coordinate's in the high word (the
/// second coordinate's is hashed from it).
#[inline(always)]
fn pair_hash(key: u64, pair: u32) -> u64 {
    mix64(key ^ (pair as u64).wrapping_mul(0xd1b5_4a32_d192_ed03))
}

/// Point `i` (bit-reversed: `reversed_index`) of the pair with scramble seeds `h`
/// (`pair_hash`).
#[inline(always)]
fn point_2d(reversed_index: u32, h: u64) -> [f32; 2] {
    let (s_index, s_x, s_y) = (h as u32, (h >> 32) as u32, mix64(h) as u32);
    let i = laine_karras(reversed_index, s_index).reverse_bits();
    let x = laine_karras(i, s_x).reverse_bits();
    let y = laine_karras(sobol1_of_index(i), s_y).reverse_bits();
    [to_unit(x), to_unit(y)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_in_unit_interval_and_reproducible() {
        for idx in 0..1000 {
            let mut a = PixelSampler::new(7, 123, idx);
            let mut b = PixelSampler::new(7, 123, idx);
            for _ in 0..8 {
                let p = a.next_2d();
                assert_eq!(p, b.next_2d());
                assert!((0.0..1.0).contains(&p[0]) && (0.0..1.0).contains(&p[1]));
            }
        }
    }

    /// `next_1d` is the first coordinate of `next_2d`'s pair, and `first_points` gives each
    /// sample the pair and the sampler that drawing it alone gives, bit for bit.
    #[test]
    fn shortcuts_equal_the_full_draws() {
        for idx in [0u32, 1, 7, 1000, u32::MAX - 3] {
            let mut a = PixelSampler::new(9, 55, idx);
            let mut b = a;
            for _ in 0..6 {
                assert_eq!(a.next_1d(), b.next_2d()[0]);
            }
        }
        let key = PixelSampler::pixel_key(3, 77);
        let mut samplers = [PixelSampler::new(0, 0, 0); 5];
        let mut points = [[0.0; 2]; 5];
        PixelSampler::first_points(key, 40, &mut samplers, &mut points);
        for i in 0..5 {
            let mut alone = PixelSampler::of_pixel(key, 40 + i as u32);
            assert_eq!(points[i], alone.next_2d(), "sample {i}");
            assert_eq!(samplers[i].next_2d(), alone.next_2d(), "sample {i}, the next pair");
        }
    }

    /// Samplers with pairs drawn ahead draw what they would alone, whatever mix of 1-D and 2-D
    /// draws follows, within the pairs drawn ahead and past them; and the vector lanes compute
    /// each point as `point_2d` does.
    #[test]
    fn pairs_drawn_ahead_equal_those_drawn_alone() {
        let key = PixelSampler::pixel_key(21, 4321);
        for (first, len, pairs) in [(0u32, 16usize, 4usize), (37, 5, 1), (1000, 20, MAX_AHEAD), (7, 3, 40), (2, 1, 0)] {
            let mut samplers = vec![PixelSampler::new(0, 0, 0); len];
            let mut points = vec![[0.0; 2]; len];
            PixelSampler::first_points(key, first, &mut samplers, &mut points);
            PixelSampler::draw_ahead(&mut samplers, pairs);
            for (i, s) in samplers.iter_mut().enumerate() {
                let mut alone = PixelSampler::of_pixel(key, first + i as u32);
                assert_eq!(points[i], alone.next_2d());
                for d in 0..MAX_AHEAD + 3 {
                    if d % 3 == 1 {
                        assert_eq!(s.next_1d(), alone.next_1d(), "sample {i}, draw {d} of {pairs} ahead");
                    } else {
                        assert_eq!(s.next_2d(), alone.next_2d(), "sample {i}, draw {d} of {pairs} ahead");
                    }
                }
            }
        }
        let reversed: [u32; AHEAD_LANES] = std::array::from_fn(|i| (i as u32).wrapping_mul(0x9e37_79b9).reverse_bits());
        for (h, n) in [(0u64, 16), (1, 1), (0xdead_beef_cafe_f00d, 5), (u64::MAX, 3)] {
            let (xs, ys) = points_in_lanes(&reversed, n, h);
            for i in 0..n {
                assert_eq!([xs[i], ys[i]], point_2d(reversed[i], h), "lane {i}");
            }
        }
    }

    #[test]
    #[should_panic(expected = "samples of one pixel")]
    fn drawing_ahead_refuses_samplers_of_other_pixels() {
        let mut samplers = [PixelSampler::new(1, 2, 0), PixelSampler::new(1, 3, 1)];
        PixelSampler::draw_ahead(&mut samplers, 2);
    }

    /// The sampler's reversed-domain arithmetic gives the same points, bit for bit, as
    /// Burley's Listing 3 written out (shuffle the index, Sobol, scramble each coordinate).
    #[test]
    fn points_equal_the_straightforward_owen_scrambled_sobol() {
        let reference = |key: u64, index: u32, pair: u32| {
            let h = mix64(key ^ (pair as u64).wrapping_mul(0xd1b5_4a32_d192_ed03));
            let (s_index, s_x, s_y) = (h as u32, (h >> 32) as u32, mix64(h) as u32);
            let i = nested_uniform_scramble(index, s_index);
            [to_unit(nested_uniform_scramble(sobol0(i), s_x)), to_unit(nested_uniform_scramble(sobol1(i), s_y))]
        };
        let mut indices: Vec<u32> = (0..2000).collect();
        indices.extend([1 << 20, (1 << 24) + 12345, u32::MAX - 1, u32::MAX]);
        for &index in &indices {
            for pixel in [0u32, 17, 99_999] {
                let mut s = PixelSampler::new(5, pixel, index);
                let key = hash_words(&[5, pixel as u64]);
                for pair in 0..6 {
                    assert_eq!(s.next_2d(), reference(key, index, pair), "index {index} pixel {pixel} pair {pair}");
                }
            }
        }
        // Both sides are linear over GF(2): equal on every bit, equal everywhere.
        for k in 0..32 {
            assert_eq!(sobol1_of_index(1 << k), sobol1(1 << k).reverse_bits(), "bit {k}");
        }
        for i in [0u32, 3, 0x8000_0001, 0xdead_beef, u32::MAX] {
            assert_eq!(sobol1_of_index(i), sobol1(i).reverse_bits(), "{i:#x}");
        }
    }

    #[test]
    fn sobol_prefixes_are_stratified_0_2_sequence() {
        // Unscrambled: the first 2^k points hit every elementary interval of area 2^-k once.
        for k in 0..=8u32 {
            let n = 1u32 << k;
            for split in 0..=k {
                let (nx, ny) = (1u32 << split, 1u32 << (k - split));
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let x = ((sobol0(i) as u64 * nx as u64) >> 32) as u32;
                    let y = ((sobol1(i) as u64 * ny as u64) >> 32) as u32;
                    let cell = (y * nx + x) as usize;
                    assert!(!seen[cell], "k={k} split={split} cell {cell} hit twice");
                    seen[cell] = true;
                }
            }
        }
    }

    #[test]
    fn scrambled_prefixes_stay_stratified() {
        // Owen scrambling preserves the (0,2) property; index shuffling permutes within
        // power-of-two blocks, so the first 16 samples of a pixel fill a 4x4 grid.
        for pixel in 0..50 {
            for pair in 0..3 {
                let mut seen = [false; 16];
                for i in 0..16 {
                    let mut s = PixelSampler::new(99, pixel, i);
                    let mut p = s.next_2d();
                    for _ in 0..pair {
                        p = s.next_2d();
                    }
                    let cell = (p[1] * 4.0) as usize * 4 + (p[0] * 4.0) as usize;
                    assert!(!seen[cell], "pixel {pixel} pair {pair}: cell {cell} twice");
                    seen[cell] = true;
                }
            }
        }
    }

    #[test]
    fn mean_is_unbiased_across_pixels() {
        let (mut sum, n) = (0.0f64, 200 * 64);
        for pixel in 0..200 {
            for i in 0..64 {
                let p = PixelSampler::new(3, pixel, i).next_2d();
                sum += (p[0] * p[1]) as f64;
            }
        }
        // E[xy] = 1/4; stratification makes the error far below the iid 1/sqrt(n) level.
        assert!((sum / n as f64 - 0.25).abs() < 2e-3);
    }

    #[test]
    fn different_pixels_and_seeds_decorrelate() {
        // Pearson correlation of the same sample's coordinates between neighbouring pixels and
        // between seeds, over many pixels and the first sample indices: zero within 4
        // standard errors (1/sqrt(n)) for independent streams; shared scrambling would give 1.
        fn correlation(pairs: &[(f64, f64)]) -> f64 {
            let n = pairs.len() as f64;
            let (ma, mb) = (pairs.iter().map(|p| p.0).sum::<f64>() / n, pairs.iter().map(|p| p.1).sum::<f64>() / n);
            let cov: f64 = pairs.iter().map(|p| (p.0 - ma) * (p.1 - mb)).sum();
            let va: f64 = pairs.iter().map(|p| (p.0 - ma).powi(2)).sum();
            let vb: f64 = pairs.iter().map(|p| (p.1 - mb).powi(2)).sum();
            cov / (va * vb).sqrt()
        }
        for index in [0u32, 1, 7] {
            for dim in 0..2 {
                let (mut pixels, mut seeds) = (Vec::new(), Vec::new());
                for pixel in 0..4096u32 {
                    let at = |seed: u64, pixel: u32| PixelSampler::new(seed, pixel, index).next_2d()[dim] as f64;
                    pixels.push((at(1, pixel), at(1, pixel + 1)));
                    seeds.push((at(1, pixel), at(2, pixel)));
                }
                let limit = 4.0 / (4096f64).sqrt();
                let (rp, rs) = (correlation(&pixels), correlation(&seeds));
                assert!(rp.abs() < limit, "index {index} dim {dim}: neighbouring pixels correlate {rp}");
                assert!(rs.abs() < limit, "index {index} dim {dim}: seeds correlate {rs}");
            }
        }
    }
}

//! One f32 per ray of a packet: 16 lanes with AVX-512F, 8 with AVX2. What the packet tests of
//! `packet` need, with SSE's semantics wherever the single-ray tests rely on them (`min` and
//! `max` return the second operand where either is NaN), so that a lane computes bit for bit
//! what the single-ray code computes. Masks are integers, bit i for lane i.
//!
//! Every function is `unsafe`: the CPU must have the instruction set of the type's lanes, which
//! the packet code checks before it runs.
#![cfg(target_arch = "x86_64")]
#![allow(unsafe_op_in_unsafe_fn)]
use std::arch::x86_64::*;

pub(super) trait Lanes: Copy {
    const N: usize;
    unsafe fn splat(x: f32) -> Self;
    /// The first `N` values of `a`.
    unsafe fn load(a: &[f32]) -> Self;
    unsafe fn store(self, a: &mut [f32]);
    unsafe fn add(self, o: Self) -> Self;
    unsafe fn sub(self, o: Self) -> Self;
    unsafe fn mul(self, o: Self) -> Self;
    unsafe fn div(self, o: Self) -> Self;
    /// `self` where it is less than `o`, else `o`.
    unsafe fn min(self, o: Self) -> Self;
    /// `self` where it is greater than `o`, else `o`.
    unsafe fn max(self, o: Self) -> Self;
    /// Lanes where `self <= o` (false for NaN).
    unsafe fn le(self, o: Self) -> u32;
    /// Lanes where `self < o` (false for NaN).
    unsafe fn lt(self, o: Self) -> u32;
    /// Lanes where `self == o` (false for NaN).
    unsafe fn eq(self, o: Self) -> u32;
    unsafe fn abs(self) -> Self;
    /// The sign bits alone (`self & -0.0`).
    unsafe fn sign(self) -> Self;
    unsafe fn xor(self, o: Self) -> Self;
    /// `a` in the lanes of `mask`, `b` elsewhere.
    unsafe fn select(mask: u32, a: Self, b: Self) -> Self;
}

#[derive(Clone, Copy)]
pub(super) struct L16(__m512);

impl Lanes for L16 {
    const N: usize = 16;
    #[inline(always)]
    unsafe fn splat(x: f32) -> Self {
        L16(_mm512_set1_ps(x))
    }
    #[inline(always)]
    unsafe fn load(a: &[f32]) -> Self {
        assert!(a.len() >= 16);
        L16(_mm512_loadu_ps(a.as_ptr()))
    }
    #[inline(always)]
    unsafe fn store(self, a: &mut [f32]) {
        assert!(a.len() >= 16);
        _mm512_storeu_ps(a.as_mut_ptr(), self.0)
    }
    #[inline(always)]
    unsafe fn add(self, o: Self) -> Self {
        L16(_mm512_add_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn sub(self, o: Self) -> Self {
        L16(_mm512_sub_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn mul(self, o: Self) -> Self {
        L16(_mm512_mul_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn div(self, o: Self) -> Self {
        L16(_mm512_div_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn min(self, o: Self) -> Self {
        L16(_mm512_min_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn max(self, o: Self) -> Self {
        L16(_mm512_max_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn le(self, o: Self) -> u32 {
        _mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, o.0) as u32
    }
    #[inline(always)]
    unsafe fn lt(self, o: Self) -> u32 {
        _mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, o.0) as u32
    }
    #[inline(always)]
    unsafe fn eq(self, o: Self) -> u32 {
        _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, o.0) as u32
    }
    #[inline(always)]
    unsafe fn abs(self) -> Self {
        L16(_mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(self.0), _mm512_set1_epi32(0x7fff_ffff))))
    }
    #[inline(always)]
    unsafe fn sign(self) -> Self {
        L16(_mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(self.0), _mm512_set1_epi32(i32::MIN))))
    }
    #[inline(always)]
    unsafe fn xor(self, o: Self) -> Self {
        L16(_mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(self.0), _mm512_castps_si512(o.0))))
    }
    #[inline(always)]
    unsafe fn select(mask: u32, a: Self, b: Self) -> Self {
        L16(_mm512_mask_blend_ps(mask as __mmask16, b.0, a.0))
    }
}

#[derive(Clone, Copy)]
pub(super) struct L8(__m256);

impl Lanes for L8 {
    const N: usize = 8;
    #[inline(always)]
    unsafe fn splat(x: f32) -> Self {
        L8(_mm256_set1_ps(x))
    }
    #[inline(always)]
    unsafe fn load(a: &[f32]) -> Self {
        assert!(a.len() >= 8);
        L8(_mm256_loadu_ps(a.as_ptr()))
    }
    #[inline(always)]
    unsafe fn store(self, a: &mut [f32]) {
        assert!(a.len() >= 8);
        _mm256_storeu_ps(a.as_mut_ptr(), self.0)
    }
    #[inline(always)]
    unsafe fn add(self, o: Self) -> Self {
        L8(_mm256_add_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn sub(self, o: Self) -> Self {
        L8(_mm256_sub_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn mul(self, o: Self) -> Self {
        L8(_mm256_mul_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn div(self, o: Self) -> Self {
        L8(_mm256_div_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn min(self, o: Self) -> Self {
        L8(_mm256_min_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn max(self, o: Self) -> Self {
        L8(_mm256_max_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn le(self, o: Self) -> u32 {
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0)) as u32
    }
    #[inline(always)]
    unsafe fn lt(self, o: Self) -> u32 {
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0)) as u32
    }
    #[inline(always)]
    unsafe fn eq(self, o: Self) -> u32 {
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0)) as u32
    }
    #[inline(always)]
    unsafe fn abs(self) -> Self {
        L8(_mm256_and_ps(self.0, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff))))
    }
    #[inline(always)]
    unsafe fn sign(self) -> Self {
        L8(_mm256_and_ps(self.0, _mm256_castsi256_ps(_mm256_set1_epi32(i32::MIN))))
    }
    #[inline(always)]
    unsafe fn xor(self, o: Self) -> Self {
        L8(_mm256_xor_ps(self.0, o.0))
    }
    #[inline(always)]
    unsafe fn select(mask: u32, a: Self, b: Self) -> Self {
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let m = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(mask as i32), bits), bits);
        L8(_mm256_blendv_ps(b.0, a.0, _mm256_castsi256_ps(m)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: [f32; 16] =
        [1.5, -2.0, f32::NAN, 0.0, -0.0, 3.0, f32::INFINITY, -7.25, 1.0, f32::NAN, 2.0, -0.0, 5.0, 0.0, -1.0, 9.0];
    const B: [f32; 16] =
        [0.5, -2.0, 1.0, -0.0, f32::NAN, 4.0, 2.0, 1.0, f32::NAN, 3.0, 2.0, 0.0, -5.0, -0.0, f32::NEG_INFINITY, 9.5];

    /// Lane i of `v` against `f(i, A[i], B[i])`, bit for bit.
    unsafe fn same<V: Lanes>(op: &str, v: V, f: impl Fn(usize, f32, f32) -> f32) {
        let mut out = [0.0f32; 16];
        v.store(&mut out);
        for i in 0..V::N {
            let want = f(i, A[i], B[i]);
            // A NaN's payload is not compared: the compiler folds the scalar side's constants
            // into a NaN of its own choosing.
            let same = out[i].to_bits() == want.to_bits() || (out[i].is_nan() && want.is_nan());
            assert!(same, "{op}, lane {i} of {}: {} {}: {} against {want}", V::N, A[i], B[i], out[i]);
        }
    }

    unsafe fn check<V: Lanes>() {
        let (x, y) = (V::load(&A), V::load(&B));
        same("add", x.add(y), |_, p, q| p + q);
        same("sub", x.sub(y), |_, p, q| p - q);
        same("mul", x.mul(y), |_, p, q| p * q);
        same("div", x.div(y), |_, p, q| p / q);
        same("min", x.min(y), |_, p, q| if p < q { p } else { q });
        same("max", x.max(y), |_, p, q| if p > q { p } else { q });
        same("abs", x.abs(), |_, p, _| p.abs());
        same("sign", x.sign(), |_, p, _| f32::from_bits(p.to_bits() & 0x8000_0000));
        same("xor", x.xor(y), |_, p, q| f32::from_bits(p.to_bits() ^ q.to_bits()));
        same("splat", V::splat(-3.5), |_, _, _| -3.5);
        let mask = 0b1010_0110_1100_0011u32 & ((1u32 << V::N) - 1);
        same("select", V::select(mask, x, y), |i, p, q| if mask >> i & 1 == 1 { p } else { q });
        let bits = |f: fn(f32, f32) -> bool| (0..V::N).map(|i| (f(A[i], B[i]) as u32) << i).sum::<u32>();
        assert_eq!(x.le(y), bits(|p, q| p <= q));
        assert_eq!(x.lt(y), bits(|p, q| p < q));
        assert_eq!(x.eq(y), bits(|p, q| p == q));
    }

    /// Each operation of both lane types against the scalar operation it stands for (SSE's
    /// `minps`/`maxps` for min and max), NaN and signed zeros included, where the CPU has the
    /// instructions.
    #[test]
    fn lanes_compute_what_the_scalar_operations_give() {
        if is_x86_feature_detected!("avx2") {
            // SAFETY: AVX2 checked.
            unsafe { check_avx2() }
        }
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: AVX-512F checked.
            unsafe { check_avx512() }
        }
    }

    #[target_feature(enable = "avx2")]
    unsafe fn check_avx2() {
        check::<L8>()
    }

    #[target_feature(enable = "avx512f")]
    unsafe fn check_avx512() {
        check::<L16>()
    }
}

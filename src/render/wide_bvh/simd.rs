//! Four f32 lanes: SSE on x86-64 (part of the base instruction set, so the portable build uses
//! it), plain arrays elsewhere (which LLVM vectorises where the target allows).
//!
//! Only what the 4-wide node and triangle tests need. Comparisons return all-ones/all-zeros lane
//! masks as `F4`, and `mask` packs their sign bits into the low four bits of an integer.

#[cfg(target_arch = "x86_64")]
mod imp {
    // SAFETY (every `unsafe` below): SSE and SSE2 belong to the x86-64 base instruction set, so
    // these intrinsics exist on every CPU this code can run on; none of them touches memory.
    #![allow(unused_unsafe)]
    use std::arch::x86_64::*;

    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct F4(__m128);

    impl F4 {
        #[inline(always)]
        pub fn splat(x: f32) -> Self {
            F4(unsafe { _mm_set1_ps(x) })
        }
        #[inline(always)]
        pub fn new(a: [f32; 4]) -> Self {
            F4(unsafe { _mm_setr_ps(a[0], a[1], a[2], a[3]) })
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            // SAFETY: __m128 and [f32; 4] have the same size, and every bit pattern is valid.
            unsafe { std::mem::transmute::<__m128, [f32; 4]>(self.0) }
        }
        #[inline(always)]
        pub fn add(self, o: Self) -> Self {
            F4(unsafe { _mm_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        pub fn sub(self, o: Self) -> Self {
            F4(unsafe { _mm_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        pub fn mul(self, o: Self) -> Self {
            F4(unsafe { _mm_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        pub fn div(self, o: Self) -> Self {
            F4(unsafe { _mm_div_ps(self.0, o.0) })
        }
        /// Lane-wise minimum; returns `o`'s lane where either is NaN (SSE `minps`).
        #[inline(always)]
        pub fn min(self, o: Self) -> Self {
            F4(unsafe { _mm_min_ps(self.0, o.0) })
        }
        /// Lane-wise maximum; returns `o`'s lane where either is NaN (SSE `maxps`).
        #[inline(always)]
        pub fn max(self, o: Self) -> Self {
            F4(unsafe { _mm_max_ps(self.0, o.0) })
        }
        #[inline(always)]
        pub fn le(self, o: Self) -> Self {
            F4(unsafe { _mm_cmple_ps(self.0, o.0) })
        }
        #[inline(always)]
        pub fn lt(self, o: Self) -> Self {
            F4(unsafe { _mm_cmplt_ps(self.0, o.0) })
        }
        #[inline(always)]
        pub fn ne(self, o: Self) -> Self {
            F4(unsafe { _mm_cmpneq_ps(self.0, o.0) })
        }
        #[inline(always)]
        pub fn and(self, o: Self) -> Self {
            F4(unsafe { _mm_and_ps(self.0, o.0) })
        }
        #[inline(always)]
        pub fn xor(self, o: Self) -> Self {
            F4(unsafe { _mm_xor_ps(self.0, o.0) })
        }
        /// Sign bits of the four lanes, lane i in bit i.
        #[inline(always)]
        pub fn mask(self) -> u32 {
            unsafe { _mm_movemask_ps(self.0) as u32 }
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod imp {
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(16))]
    pub struct F4([f32; 4]);

    #[inline(always)]
    fn bits(b: bool) -> f32 {
        f32::from_bits(if b { u32::MAX } else { 0 })
    }

    impl F4 {
        #[inline(always)]
        pub fn splat(x: f32) -> Self {
            F4([x; 4])
        }
        #[inline(always)]
        pub fn new(a: [f32; 4]) -> Self {
            F4(a)
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            self.0
        }
        #[inline(always)]
        fn zip(self, o: Self, f: impl Fn(f32, f32) -> f32) -> Self {
            F4([f(self.0[0], o.0[0]), f(self.0[1], o.0[1]), f(self.0[2], o.0[2]), f(self.0[3], o.0[3])])
        }
        #[inline(always)]
        pub fn add(self, o: Self) -> Self {
            self.zip(o, |a, b| a + b)
        }
        #[inline(always)]
        pub fn sub(self, o: Self) -> Self {
            self.zip(o, |a, b| a - b)
        }
        #[inline(always)]
        pub fn mul(self, o: Self) -> Self {
            self.zip(o, |a, b| a * b)
        }
        #[inline(always)]
        pub fn div(self, o: Self) -> Self {
            self.zip(o, |a, b| a / b)
        }
        /// Same NaN rule as SSE: `o`'s lane unless `self < o`.
        #[inline(always)]
        pub fn min(self, o: Self) -> Self {
            self.zip(o, |a, b| if a < b { a } else { b })
        }
        #[inline(always)]
        pub fn max(self, o: Self) -> Self {
            self.zip(o, |a, b| if a > b { a } else { b })
        }
        #[inline(always)]
        pub fn le(self, o: Self) -> Self {
            self.zip(o, |a, b| bits(a <= b))
        }
        #[inline(always)]
        pub fn lt(self, o: Self) -> Self {
            self.zip(o, |a, b| bits(a < b))
        }
        #[inline(always)]
        pub fn ne(self, o: Self) -> Self {
            self.zip(o, |a, b| bits(a != b))
        }
        #[inline(always)]
        pub fn and(self, o: Self) -> Self {
            self.zip(o, |a, b| f32::from_bits(a.to_bits() & b.to_bits()))
        }
        #[inline(always)]
        pub fn xor(self, o: Self) -> Self {
            self.zip(o, |a, b| f32::from_bits(a.to_bits() ^ b.to_bits()))
        }
        #[inline(always)]
        pub fn mask(self) -> u32 {
            (0..4).map(|i| (self.0[i].to_bits() >> 31) << i).sum()
        }
    }
}

pub use imp::F4;

#[cfg(test)]
mod tests {
    use super::F4;

    #[test]
    fn lane_operations_match_scalar_arithmetic() {
        let a = F4::new([1.0, -2.0, 3.5, f32::INFINITY]);
        let b = F4::new([0.5, 4.0, 3.5, -1.0]);
        assert_eq!(a.add(b).to_array(), [1.5, 2.0, 7.0, f32::INFINITY]);
        assert_eq!(a.sub(b).to_array(), [0.5, -6.0, 0.0, f32::INFINITY]);
        assert_eq!(a.mul(b).to_array(), [0.5, -8.0, 12.25, f32::NEG_INFINITY]);
        assert_eq!(a.div(b).to_array(), [2.0, -0.5, 1.0, f32::NEG_INFINITY]);
        assert_eq!(a.min(b).to_array(), [0.5, -2.0, 3.5, -1.0]);
        assert_eq!(a.max(b).to_array(), [1.0, 4.0, 3.5, f32::INFINITY]);
        assert_eq!(a.le(b).mask(), 0b0110);
        assert_eq!(a.ne(b).mask(), 0b1011);
        assert_eq!(a.lt(b).mask(), 0b0010);
        assert_eq!(F4::splat(-0.0).lt(F4::splat(0.0)).mask(), 0);
        assert_eq!(a.le(b).and(a.ne(b)).mask(), 0b0010);
        assert_eq!(a.xor(F4::splat(-0.0)).to_array(), [-1.0, 2.0, -3.5, f32::NEG_INFINITY]);
        assert_eq!(F4::new([-0.0, 0.0, -1.0, 1.0]).mask(), 0b0101);
        assert_eq!(F4::splat(2.0).to_array(), [2.0; 4]);
    }

    #[test]
    fn min_and_max_return_the_second_operand_on_nan() {
        let nan = F4::splat(f32::NAN);
        let one = F4::splat(1.0);
        assert_eq!(nan.min(one).to_array(), [1.0; 4]);
        assert_eq!(nan.max(one).to_array(), [1.0; 4]);
        assert!(one.min(nan).to_array()[0].is_nan());
        assert_eq!(nan.le(one).mask(), 0);
        assert_eq!(nan.lt(one).mask() | one.lt(nan).mask(), 0);
        assert_eq!(nan.ne(nan).mask(), 0b1111);
    }
}

//! Inner nodes of 4 and 8 children, and their slab test against one ray.
//!
//! A node stores its children's boxes in structure-of-arrays form (`b[0]` minima, `b[1]` maxima,
//! per axis), so that one vector instruction per plane tests every child at once.
use super::simd::F4;
use glam::Vec3;

/// Child reference: an inner node's index, or LEAF | block start << 3 | (block count - 1).
pub const LEAF: u32 = 1 << 31;
/// An unused child slot (its box is empty, so the slab test never enters it).
pub const NO_CHILD: u32 = u32::MAX;

/// Exit distances are scaled up by 1 + 2 gamma(3) (Ize 2013, "Robust BVH Ray Traversal"), so that
/// rounding in (plane - origin) * inverse never culls a box the ray touches, e.g. at the shared
/// edge of two flat boxes.
pub(super) const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON / 2.0) / (1.0 - 3.0 * f32::EPSILON / 2.0);

/// Per-ray constants of the slab test: for each axis, which of `b[0]`/`b[1]` holds the near
/// plane, the origin and the inverse direction.
pub struct RayBox {
    near: [usize; 3],
    o: Vec3,
    inv: Vec3,
}

impl RayBox {
    pub fn new(o: Vec3, d: Vec3) -> Self {
        // Direction components at or near zero get a huge finite inverse of their own sign, so
        // that (plane - origin) * inverse is never 0 * inf = NaN (the origin on a box's plane).
        let inv = |x: f32| 1.0 / if x.abs() < 1e-30 { 1e-30f32.copysign(x) } else { x };
        let i = Vec3::new(inv(d.x), inv(d.y), inv(d.z));
        RayBox { near: [(i.x < 0.0) as usize, (i.y < 0.0) as usize, (i.z < 0.0) as usize], o, inv: i }
    }
}

/// What the traversal needs of a node.
pub trait WideNode {
    /// Writes the entry distance of each child into `t` and returns the mask of the children
    /// entered within [tmin, tmax] (bit i for child i).
    ///
    /// # Safety
    /// The CPU must support the node's instruction set (AVX for `Node8`).
    unsafe fn enter(&self, ray: &RayBox, tmin: f32, tmax: f32, t: &mut [f32; 8]) -> u32;
    fn child(&self, lane: usize) -> u32;
    /// Child `lane`'s box (minimum, maximum); empty lanes give an empty box.
    fn lane_box(&self, lane: usize) -> (Vec3, Vec3);
    fn set_lane_box(&mut self, lane: usize, lo: Vec3, hi: Vec3);
    /// The children's minima (`side` 0) or maxima (1) along `axis`, one per lane.
    fn plane(&self, side: usize, axis: usize) -> &[f32];
    /// Lanes per node.
    const LANES: usize;
}

/// Four children, tested with SSE (or portable 4-lane code).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Node4 {
    b: [[F4; 3]; 2],
    child: [u32; 4],
}

impl Node4 {
    pub fn new(lo: [[f32; 8]; 3], hi: [[f32; 8]; 3], child: [u32; 8]) -> Self {
        let four = |a: [f32; 8]| F4::new([a[0], a[1], a[2], a[3]]);
        Node4 { b: [lo.map(four), hi.map(four)], child: [child[0], child[1], child[2], child[3]] }
    }
}

impl WideNode for Node4 {
    #[inline(always)]
    unsafe fn enter(&self, ray: &RayBox, tmin: f32, tmax: f32, t: &mut [f32; 8]) -> u32 {
        let (o, inv) = (ray.o.to_array().map(F4::splat), ray.inv.to_array().map(F4::splat));
        let plane = |axis: usize, side: usize| self.b[side][axis].sub(o[axis]).mul(inv[axis]);
        let near = |a: usize| plane(a, ray.near[a]);
        let far = |a: usize| plane(a, 1 - ray.near[a]);
        let t0 = near(0).max(near(1)).max(near(2).max(F4::splat(tmin)));
        let t1 = far(0).min(far(1)).min(far(2)).mul(F4::splat(FAR_SCALE)).min(F4::splat(tmax));
        t[..4].copy_from_slice(&t0.to_array());
        t0.le(t1).mask()
    }

    #[inline(always)]
    fn child(&self, lane: usize) -> u32 {
        self.child[lane]
    }

    fn lane_box(&self, lane: usize) -> (Vec3, Vec3) {
        let side = |s: usize| Vec3::from_array(self.b[s].map(|axis| axis.to_array()[lane]));
        (side(0), side(1))
    }

    fn set_lane_box(&mut self, lane: usize, lo: Vec3, hi: Vec3) {
        for (s, v) in [lo, hi].into_iter().enumerate() {
            for axis in 0..3 {
                let mut a = self.b[s][axis].to_array();
                a[lane] = v[axis];
                self.b[s][axis] = F4::new(a);
            }
        }
    }

    #[inline(always)]
    fn plane(&self, side: usize, axis: usize) -> &[f32] {
        // SAFETY: an F4 is four f32 in memory (an __m128, or an array elsewhere).
        unsafe { std::slice::from_raw_parts(&self.b[side][axis] as *const F4 as *const f32, 4) }
    }

    const LANES: usize = 4;
}

#[cfg(target_arch = "x86_64")]
pub use eight::Node8;

#[cfg(target_arch = "x86_64")]
mod eight {
    use super::{RayBox, WideNode, FAR_SCALE};
    use glam::Vec3;
    use std::arch::x86_64::*;

    /// Eight children, tested with AVX. Only built when the CPU has AVX2 and FMA (checked at run
    /// time), as Embree picks its 8-wide BVH on such CPUs.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(64))]
    pub struct Node8 {
        b: [[__m256; 3]; 2],
        child: [u32; 8],
    }

    impl Node8 {
        pub fn new(lo: [[f32; 8]; 3], hi: [[f32; 8]; 3], child: [u32; 8]) -> Self {
            // SAFETY: [f32; 8] and __m256 have the same size and every bit pattern is valid;
            // no AVX instruction is involved in building the value.
            let v = |a: [f32; 8]| unsafe { std::mem::transmute::<[f32; 8], __m256>(a) };
            Node8 { b: [lo.map(v), hi.map(v)], child }
        }
    }

    impl WideNode for Node8 {
        #[inline(always)]
        unsafe fn enter(&self, ray: &RayBox, tmin: f32, tmax: f32, t: &mut [f32; 8]) -> u32 {
            // SAFETY: the caller guarantees AVX (see the trait); `t` holds eight f32.
            unsafe {
                let o = ray.o.to_array().map(|x| _mm256_set1_ps(x));
                let inv = ray.inv.to_array().map(|x| _mm256_set1_ps(x));
                let plane =
                    |axis: usize, side: usize| _mm256_mul_ps(_mm256_sub_ps(self.b[side][axis], o[axis]), inv[axis]);
                let near = |a: usize| plane(a, ray.near[a]);
                let far = |a: usize| plane(a, 1 - ray.near[a]);
                let t0 = _mm256_max_ps(_mm256_max_ps(near(0), near(1)), _mm256_max_ps(near(2), _mm256_set1_ps(tmin)));
                let t1 = _mm256_min_ps(
                    _mm256_mul_ps(_mm256_min_ps(_mm256_min_ps(far(0), far(1)), far(2)), _mm256_set1_ps(FAR_SCALE)),
                    _mm256_set1_ps(tmax),
                );
                _mm256_storeu_ps(t.as_mut_ptr(), t0);
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32
            }
        }

        #[inline(always)]
        fn child(&self, lane: usize) -> u32 {
            self.child[lane]
        }

        fn lane_box(&self, lane: usize) -> (Vec3, Vec3) {
            let side = |s: usize| Vec3::from_array(self.b[s].map(|axis| lanes(axis)[lane]));
            (side(0), side(1))
        }

        fn set_lane_box(&mut self, lane: usize, lo: Vec3, hi: Vec3) {
            for (s, v) in [lo, hi].into_iter().enumerate() {
                for axis in 0..3 {
                    let mut a = lanes(self.b[s][axis]);
                    a[lane] = v[axis];
                    // SAFETY: as in `new`.
                    self.b[s][axis] = unsafe { std::mem::transmute::<[f32; 8], __m256>(a) };
                }
            }
        }

        #[inline(always)]
        fn plane(&self, side: usize, axis: usize) -> &[f32] {
            // SAFETY: an __m256 is eight f32 in memory; reading them needs no AVX instruction.
            unsafe { std::slice::from_raw_parts(&self.b[side][axis] as *const __m256 as *const f32, 8) }
        }

        const LANES: usize = 8;
    }

    /// The eight values of a vector, read without AVX instructions.
    fn lanes(v: __m256) -> [f32; 8] {
        // SAFETY: same size, every bit pattern is a valid f32.
        unsafe { std::mem::transmute::<__m256, [f32; 8]>(v) }
    }
}

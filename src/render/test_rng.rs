//! Test helpers: a deterministic xorshift for test data (geometry and BVH tests) and the mean
//! and standard error of Monte Carlo estimates.
use glam::Vec3;

pub struct Rng(pub u64);

impl Rng {
    /// Uniform in [0, 1).
    pub fn f(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in the cube [-1, 1)^3.
    pub fn v(&mut self) -> Vec3 {
        Vec3::new(self.f(), self.f(), self.f()) * 2.0 - 1.0
    }
}

/// Mean and standard error of `f(i)` over `n` samples, each asserted finite and non-negative
/// (Monte Carlo estimates in tests).
pub fn mean_se(n: u32, mut f: impl FnMut(u32) -> f64) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0, 0.0);
    for i in 0..n {
        let v = f(i);
        assert!(v.is_finite() && v >= 0.0, "sample {i}: {v}");
        sum += v;
        sum2 += v * v;
    }
    let mean = sum / n as f64;
    (mean, ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
}

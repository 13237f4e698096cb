//! Deterministic xorshift for test data (geometry and BVH tests).
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

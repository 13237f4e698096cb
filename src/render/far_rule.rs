//! The far-field quadrature rule of a Gaussian rectangular light (`RectLight`'s exact unshadowed
//! irradiance for distant receivers), laid out for SIMD: its nodes in blocks of four lanes, so
//! that the sum over them runs as four independent f64 partial sums (one per lane) instead of
//! one serial chain, with AVX2 where the CPU has it. A sample of `auto` on a Gaussian light
//! evaluates it once per r(x), and r(x) is computed on every sample of a pixel an edge crosses.
use glam::DVec3;

/// Lanes per block.
const LANES: usize = 4;

/// Four nodes: their positions by coordinate and their weights.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Block {
    x: [f64; LANES],
    y: [f64; LANES],
    z: [f64; LANES],
    w: [f64; LANES],
}

/// A quadrature rule of nodes `y_i` with weights `w_i` for `sum_i w_i max(0, n . (y_i - x)) /
/// |y_i - x|^4`, the irradiance integrand of a light's points seen from `x` (times the height
/// of `x` above the light's plane, which the caller applies).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FarRule {
    blocks: Vec<Block>,
}

impl FarRule {
    /// The rule of `nodes` (position, weight). The last block is padded with copies of the
    /// last node at weight 0, so that no lane divides by zero where the others would not.
    pub fn new(nodes: &[(DVec3, f64)]) -> Self {
        let blocks = nodes
            .chunks(LANES)
            .map(|chunk| {
                let at = |l: usize| chunk.get(l).copied().unwrap_or((chunk[chunk.len() - 1].0, 0.0));
                Block {
                    x: std::array::from_fn(|l| at(l).0.x),
                    y: std::array::from_fn(|l| at(l).0.y),
                    z: std::array::from_fn(|l| at(l).0.z),
                    w: std::array::from_fn(|l| at(l).1),
                }
            })
            .collect();
        FarRule { blocks }
    }

    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }

    /// `sum_i w_i max(0, n . (y_i - x)) / |y_i - x|^4`. The same bits on every CPU: the AVX2
    /// path runs the same operations in the same order (Rust does not fuse a multiply and an
    /// add unless asked to).
    pub fn sum(&self, x: DVec3, n: DVec3) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            return unsafe { sum_avx2(&self.blocks, x, n) };
        }
        sum_lanes(&self.blocks, x, n)
    }
}

/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn sum_avx2(blocks: &[Block], x: DVec3, n: DVec3) -> f64 {
    sum_lanes(blocks, x, n)
}

#[inline(always)]
fn sum_lanes(blocks: &[Block], x: DVec3, n: DVec3) -> f64 {
    let mut acc = [0.0f64; LANES];
    for b in blocks {
        for (l, acc) in acc.iter_mut().enumerate() {
            let (dx, dy, dz) = (b.x[l] - x.x, b.y[l] - x.y, b.z[l] - x.z);
            let r2 = dx * dx + dy * dy + dz * dz;
            let cos = n.x * dx + n.y * dy + n.z * dz;
            // Not f64::max: its NaN handling keeps the compiler from a plain vector max.
            let cos = if cos > 0.0 { cos } else { 0.0 };
            *acc += b.w[l] * cos / (r2 * r2);
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::test_rng::Rng;

    /// The blocked sum equals the plain one (to rounding: the order differs) for rules of 1 to
    /// 70 nodes, those below the receiver's horizon counting 0, and the padding adds nothing.
    #[test]
    fn the_blocked_sum_is_the_plain_sum() {
        let mut rng = Rng(17);
        let mut r = || rng.f() as f64;
        for count in [1usize, 3, 4, 5, 8, 63, 64, 70] {
            let nodes: Vec<(DVec3, f64)> =
                (0..count).map(|_| (DVec3::new(r() - 0.5, 1.0 + 0.1 * r(), r() - 0.5), r())).collect();
            let rule = FarRule::new(&nodes);
            assert_eq!(rule.blocks.len(), count.div_ceil(LANES));
            for _ in 0..20 {
                let x = DVec3::new(2.0 * r() - 1.0, -r(), 2.0 * r() - 1.0);
                let n = DVec3::new(r() - 0.5, 1.0, r() - 0.5).normalize();
                let plain: f64 = nodes
                    .iter()
                    .map(|&(y, w)| {
                        let d = y - x;
                        w * n.dot(d).max(0.0) / (d.length_squared() * d.length_squared())
                    })
                    .sum();
                let blocked = rule.sum(x, n);
                assert!((blocked - plain).abs() <= 1e-14 * plain.abs().max(1e-300), "{count}: {blocked} vs {plain}");
                assert_eq!(blocked, sum_lanes(&rule.blocks, x, n), "every CPU path gives the same bits");
            }
            // A receiver facing away from every node: nothing.
            assert_eq!(rule.sum(DVec3::new(0.0, -1.0, 0.0), DVec3::NEG_Y), 0.0);
        }
        assert!(FarRule::new(&[]).is_empty() && FarRule::new(&[]).sum(DVec3::ZERO, DVec3::Y) == 0.0);
    }
}

//! Four triangles in structure-of-arrays form, tested against one ray at once.
//!
//! The test is Möller-Trumbore in the form obvhs's `RtTriangle` uses (v0, e1 = v0 - v1,
//! e2 = v2 - v0, ng = e1 x e2), lane by lane, so that hits and barycentrics agree with it.
use super::simd::F4;
use glam::Vec3;

/// Marks an unused lane (a leaf with fewer than four triangles).
pub const EMPTY_SLOT: u32 = u32::MAX;

#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct Tri4 {
    v0: [F4; 3],
    e1: [F4; 3],
    e2: [F4; 3],
    ng: [F4; 3],
    /// Triangle slot of each lane (index into `Geometry::tris`), or EMPTY_SLOT.
    pub slots: [u32; 4],
}

/// A ray with what the 4-wide tests reuse: origin and direction broadcast to four lanes.
pub struct Ray4 {
    pub o: [F4; 3],
    pub d: [F4; 3],
}

impl Ray4 {
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray4 {
            o: [F4::splat(o.x), F4::splat(o.y), F4::splat(o.z)],
            d: [F4::splat(d.x), F4::splat(d.y), F4::splat(d.z)],
        }
    }
}

/// Lanes of a block hit within a range: their distances and barycentrics.
pub struct BlockHits {
    /// Bit i set when lane i hits.
    pub mask: u32,
    pub t: [f32; 4],
    pub u: F4,
    pub v: F4,
}

#[inline(always)]
fn cross(a: [F4; 3], b: [F4; 3]) -> [F4; 3] {
    [a[1].mul(b[2]).sub(a[2].mul(b[1])), a[2].mul(b[0]).sub(a[0].mul(b[2])), a[0].mul(b[1]).sub(a[1].mul(b[0]))]
}

#[inline(always)]
fn dot(a: [F4; 3], b: [F4; 3]) -> F4 {
    a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]))
}

impl Tri4 {
    /// Packs up to four triangles (vertices, slot); missing lanes are EMPTY_SLOT.
    pub fn new(tris: &[([Vec3; 3], u32)]) -> Self {
        assert!(!tris.is_empty() && tris.len() <= 4, "a block holds 1 to 4 triangles");
        let lane = |i: usize| tris.get(i).map_or(([Vec3::ZERO; 3], EMPTY_SLOT), |&t| t);
        let mut v0 = [[0.0f32; 4]; 3];
        let mut e1 = v0;
        let mut e2 = v0;
        let mut ng = v0;
        let mut slots = [EMPTY_SLOT; 4];
        for i in 0..4 {
            let (p, slot) = lane(i);
            let (a, b) = (p[0] - p[1], p[2] - p[0]);
            let n = a.cross(b);
            for k in 0..3 {
                v0[k][i] = p[0][k];
                e1[k][i] = a[k];
                e2[k][i] = b[k];
                ng[k][i] = n[k];
            }
            slots[i] = slot;
        }
        Tri4 { v0: v0.map(F4::new), e1: e1.map(F4::new), e2: e2.map(F4::new), ng: ng.map(F4::new), slots }
    }

    /// The lanes hit at t in [tmin, tmax]. Empty lanes have a zero normal, so the det != 0 test
    /// rejects them; it also rejects rays parallel to a triangle's plane.
    ///
    /// The inside and range tests run on the numerators with the sign of the determinant folded
    /// in (u det, v det, t det against |det|), and the division happens only when a lane hits:
    /// most blocks a ray reaches it misses.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray4, tmin: F4, tmax: F4) -> BlockHits {
        let c = [self.v0[0].sub(ray.o[0]), self.v0[1].sub(ray.o[1]), self.v0[2].sub(ray.o[2])];
        let r = cross(ray.d, c);
        let det = dot(self.ng, ray.d);
        let sign = det.and(F4::splat(-0.0));
        let abs_det = det.xor(sign);
        let u = dot(r, self.e2).xor(sign);
        let v = dot(r, self.e1).xor(sign);
        let w = abs_det.sub(u).sub(v);
        let t = dot(self.ng, c).xor(sign);
        // Inside when u, v and w all have a clear sign bit (as RtTriangle: -0.0 is outside), and
        // the comparisons are false for NaN.
        let outside = u.or(v).or(w).mask();
        let ok = det.ne(F4::splat(0.0)).and(abs_det.mul(tmin).le(t)).and(t.le(abs_det.mul(tmax))).mask();
        let mask = ok & !outside & 0xf;
        if mask == 0 {
            return BlockHits { mask, t: [f32::INFINITY; 4], u, v };
        }
        let inv = F4::splat(1.0).div(abs_det);
        BlockHits { mask, t: t.mul(inv).to_array(), u: u.mul(inv), v: v.mul(inv) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obvhs::{ray::Ray, rt_triangle::RtTriangle};

    #[test]
    fn lanes_agree_with_obvhs_triangle_test() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut f = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let mut hits = 0;
        for _ in 0..2000 {
            let tris: Vec<([Vec3; 3], u32)> = (0..3)
                .map(|i| {
                    let c = Vec3::new(f(), f(), f());
                    ([c, c + Vec3::new(f(), f(), f()), c + Vec3::new(f(), f(), f())], i)
                })
                .collect();
            let block = Tri4::new(&tris);
            // Aimed near the first triangle, so that a fair share of the lanes hit.
            let o = Vec3::new(f(), f(), f()) * 3.0;
            let d = (tris[0].0[0] + Vec3::new(f(), f(), f()) * 0.5 - o).normalize();
            let got = block.intersect(&Ray4::new(o, d), F4::splat(0.0), F4::splat(10.0));
            assert_eq!(got.mask & 0b1000, 0, "the empty lane never hits");
            let (u, v) = (got.u.to_array(), got.v.to_array());
            for (i, (p, _)) in tris.iter().enumerate() {
                let tri = RtTriangle::new(p[0].into(), p[1].into(), p[2].into());
                let ray = Ray::new(o.into(), d.into(), 0.0, 10.0);
                let t = tri.intersect(&ray);
                assert_eq!(got.mask >> i & 1 == 1, t.is_finite(), "lane {i}");
                if t.is_finite() {
                    hits += 1;
                    assert!((got.t[i] - t).abs() <= 1e-6 * t.max(1.0));
                    let b = tri.compute_barycentric(&ray);
                    assert!((u[i] - b.x).abs() < 1e-5 && (v[i] - b.y).abs() < 1e-5);
                }
            }
        }
        assert!(hits > 200, "{hits}");
    }
}

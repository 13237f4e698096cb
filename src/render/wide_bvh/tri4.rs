//! Four triangles in structure-of-arrays form, tested against one ray at once.
//!
//! The test is Woop, Benthin and Wald's watertight ray/triangle test (JCGT 2(1), 2013): the
//! vertices are moved into a frame where the ray runs along +z (a permutation and a shear),
//! and the three 2-D edge functions decide inside/outside. Two triangles that share an edge
//! compute that edge's function from the same two transformed vertices, so they get exactly
//! negated values, and a value of exactly zero counts as inside for both: a ray through a
//! shared edge or vertex hits at least one of the triangles. Moller-Trumbore, which the
//! tracer used before, builds each triangle's edges from its own first vertex and can miss
//! both (a closed box then leaks light along its seams).
use super::simd::F4;
use glam::Vec3;

/// Marks an unused lane (a leaf with fewer than four triangles).
pub const EMPTY_SLOT: u32 = u32::MAX;

#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct Tri4 {
    /// The three vertices of each lane, each as x, y, z lanes.
    v: [[F4; 3]; 3],
    /// Triangle slot of each lane (index into `Geometry::tris`), or EMPTY_SLOT.
    pub slots: [u32; 4],
}

/// A ray with what the 4-wide tests reuse: the origin broadcast to four lanes, the axis
/// permutation (kz the dominant axis of the direction) and the shear of the watertight test.
pub struct Ray4 {
    o: [F4; 3],
    k: [usize; 3],
    shear: [F4; 3],
}

impl Ray4 {
    pub fn new(o: Vec3, d: Vec3) -> Self {
        let kz = d.abs().max_position();
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Swapping x and y when the ray runs along -z keeps the triangles' winding.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let shear = [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]];
        Ray4 { o: [F4::splat(o.x), F4::splat(o.y), F4::splat(o.z)], k: [kx, ky, kz], shear: shear.map(F4::splat) }
    }
}

/// Lanes of a block hit within a range: their distances and barycentrics.
pub struct BlockHits {
    /// Bit i set when lane i hits.
    pub mask: u32,
    pub t: [f32; 4],
    /// Weight of the second vertex.
    pub u: F4,
    /// Weight of the third vertex.
    pub v: F4,
}

impl Tri4 {
    /// Packs up to four triangles (vertices, slot); missing lanes are EMPTY_SLOT.
    pub fn new(tris: &[([Vec3; 3], u32)]) -> Self {
        assert!(!tris.is_empty() && tris.len() <= 4, "a block holds 1 to 4 triangles");
        let mut v = [[[0.0f32; 4]; 3]; 3];
        let mut slots = [EMPTY_SLOT; 4];
        for (i, (p, slot)) in tris.iter().enumerate() {
            for (j, vertex) in p.iter().enumerate() {
                for k in 0..3 {
                    v[j][k][i] = vertex[k];
                }
            }
            slots[i] = *slot;
        }
        Tri4 { v: v.map(|vertex| vertex.map(F4::new)), slots }
    }

    /// Moves lane `lane` to the triangle `p` (its slot stays).
    pub fn set_lane(&mut self, lane: usize, p: [Vec3; 3]) {
        for (j, vertex) in p.iter().enumerate() {
            for k in 0..3 {
                let mut a = self.v[j][k].to_array();
                a[lane] = vertex[k];
                self.v[j][k] = F4::new(a);
            }
        }
    }

    /// The vertices' coordinates as (vertex, axis, lane), read in place.
    #[inline(always)]
    pub fn coordinates(&self) -> &[[[f32; 4]; 3]; 3] {
        // SAFETY: an F4 is four f32 in memory (an __m128, or an array elsewhere), so `v` is
        // 3 x 3 x 4 f32 with the same layout.
        unsafe { &*(&self.v as *const [[F4; 3]; 3] as *const [[[f32; 4]; 3]; 3]) }
    }

    /// The bounds of the used lanes (exact: the vertices the test reads).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for lane in (0..4).filter(|&i| self.slots[i] != EMPTY_SLOT) {
            for vertex in &self.v {
                let p = Vec3::new(vertex[0].to_array()[lane], vertex[1].to_array()[lane], vertex[2].to_array()[lane]);
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (lo, hi)
    }

    /// The lanes hit at t in [tmin, tmax]. Empty lanes are degenerate (all vertices at the
    /// origin), so their determinant is zero and the det != 0 test rejects them, as it rejects
    /// rays that graze a triangle's plane.
    ///
    /// The range test runs on t det against |det| with the determinant's sign folded in, and
    /// the division happens only when a lane hits: most blocks a ray reaches it misses.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray4, tmin: F4, tmax: F4) -> BlockHits {
        let [kx, ky, kz] = ray.k;
        let [sx, sy, sz] = ray.shear;
        // Each vertex relative to the origin, sheared so that the ray runs along +z. The z
        // scale (1 / d[kz]) is applied once to the distance below rather than to each vertex.
        let moved = |p: &[F4; 3]| {
            let (x, y, z) = (p[kx].sub(ray.o[kx]), p[ky].sub(ray.o[ky]), p[kz].sub(ray.o[kz]));
            (x.sub(sx.mul(z)), y.sub(sy.mul(z)), z)
        };
        let (ax, ay, az) = moved(&self.v[0]);
        let (bx, by, bz) = moved(&self.v[1]);
        let (cx, cy, cz) = moved(&self.v[2]);
        // Edge functions (scaled barycentrics of the first, second and third vertex).
        let e0 = cx.mul(by).sub(cy.mul(bx));
        let e1 = ax.mul(cy).sub(ay.mul(cx));
        let e2 = bx.mul(ay).sub(by.mul(ax));
        let zero = F4::splat(0.0);
        // Outside when the edge functions have both signs; zeros (either sign) count as inside.
        let some_negative = e0.min(e1).min(e2).lt(zero);
        let some_positive = zero.lt(e0.max(e1).max(e2));
        let outside = some_negative.and(some_positive).mask();
        let det = e0.add(e1).add(e2);
        let t = sz.mul(e0.mul(az).add(e1.mul(bz)).add(e2.mul(cz)));
        let sign = det.and(F4::splat(-0.0));
        let abs_det = det.xor(sign);
        let t = t.xor(sign);
        // The comparisons are false for NaN, so a NaN lane never hits.
        let ok = det.ne(zero).and(abs_det.mul(tmin).le(t)).and(t.le(abs_det.mul(tmax))).mask();
        let mask = ok & !outside & 0xf;
        let (u, v) = (e1.xor(sign), e2.xor(sign));
        if mask == 0 {
            return BlockHits { mask, t: [f32::INFINITY; 4], u, v };
        }
        let inv = F4::splat(1.0).div(abs_det);
        // A hit nearer than the test's own rounding error could be the surface the ray left (or
        // a coplanar neighbour): pbrt-v4's conservative bound on the error of t (Pharr, Jakob
        // and Humphreys, "Physically Based Rendering", 4th ed., Sec. 6.8.4 and 6.8.7). Origins
        // leave surfaces offset by the error bound of the hit point (`Surface::spawn_origin`);
        // the two together keep rays off their own surface with no fixed epsilon. The bound
        // grows as the triangle's determinant shrinks: slivers need it most. Hits farther than
        // `NEAR_HIT` (a thousandth of the internal frame's diagonal, far above any bound but a
        // degenerate sliver's) skip it: most hits are, and the bound costs as much as the test.
        let t = t.mul(inv);
        if t.lt(F4::splat(NEAR_HIT)).mask() & mask == 0 {
            return BlockHits { mask, t: t.to_array(), u: u.mul(inv), v: v.mul(inv) };
        }
        let delta_t = t_error_bound([[ax, ay, az], [bx, by, bz], [cx, cy, cz]], [e0, e1, e2], sz, inv);
        let mask = mask & delta_t.lt(t).mask();
        BlockHits { mask, t: t.to_array(), u: u.mul(inv), v: v.mul(inv) }
    }
}

/// pbrt-v4's bound on the rounding error of the watertight test's t (Sec. 6.8.7), from the
/// vertices in the ray's sheared frame, the edge functions, the z scale and 1 / |det|. Out of
/// line: few hits are near enough to need it, and the traversal loop stays small.
#[inline(never)]
fn t_error_bound(v: [[F4; 3]; 3], e: [F4; 3], sz: F4, inv: F4) -> F4 {
    let abs = |x: F4| x.and(F4::splat(f32::from_bits(0x7fff_ffff)));
    let max3 = |a: F4, b: F4, c: F4| abs(a).max(abs(b)).max(abs(c));
    let [[ax, ay, az], [bx, by, bz], [cx, cy, cz]] = v;
    let max_zt = max3(az, bz, cz).mul(abs(sz));
    let (max_xt, max_yt) = (max3(ax, bx, cx), max3(ay, by, cy));
    let delta_z = F4::splat(gamma(3)).mul(max_zt);
    let delta_x = F4::splat(gamma(5)).mul(max_xt.add(max_zt));
    let delta_y = F4::splat(gamma(5)).mul(max_yt.add(max_zt));
    let delta_e = F4::splat(2.0)
        .mul(F4::splat(gamma(2)).mul(max_xt).mul(max_yt).add(delta_y.mul(max_xt)).add(delta_x.mul(max_yt)));
    let max_e = max3(e[0], e[1], e[2]);
    F4::splat(3.0)
        .mul(F4::splat(gamma(3)).mul(max_e).mul(max_zt).add(delta_e.mul(max_zt)).add(delta_z.mul(max_e)))
        .mul(inv)
}

/// Hits at least this far need no check against the intersection's error bound.
pub(super) const NEAR_HIT: f32 = 1e-2;

/// pbrt's gamma(n) = n u / (1 - n u), u = 2^-24: the relative error bound of n roundings.
pub const fn gamma(n: u32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}

#[cfg(test)]
mod tests {
    use super::*;
    use obvhs::{ray::Ray, rt_triangle::RtTriangle};
    use std::f32::consts::TAU;

    /// Xorshift values in [-1, 1).
    fn uniform_in(seed: u64) -> impl FnMut() -> f32 {
        let mut s = seed;
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        }
    }

    #[test]
    fn lanes_agree_with_obvhs_triangle_test() {
        let mut f = uniform_in(0x2545_f491_4f6c_dd1d);
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
                let b = tri.compute_barycentric(&ray);
                // The two tests may round differently within a hair of an edge.
                if b.x.min(b.y).min(1.0 - b.x - b.y).abs() < 1e-5 {
                    continue;
                }
                assert_eq!(got.mask >> i & 1 == 1, t.is_finite(), "lane {i}");
                if t.is_finite() {
                    hits += 1;
                    assert!((got.t[i] - t).abs() <= 1e-5 * t.max(1.0), "{} vs {t}", got.t[i]);
                    assert!((u[i] - b.x).abs() < 1e-4 && (v[i] - b.y).abs() < 1e-4);
                }
            }
        }
        assert!(hits > 200, "{hits}");
    }

    /// A fan of triangles around one vertex, each sharing an edge with the next: rays aimed
    /// exactly at the shared vertex and at points on the shared edges, from many directions
    /// (both windings, both sides), must hit at least one triangle of the fan.
    #[test]
    fn rays_through_shared_edges_and_vertices_never_fall_through() {
        let centre = Vec3::new(0.3, -0.2, 0.7);
        let (a, b) = (Vec3::new(0.37, 0.11, -0.92).normalize(), Vec3::new(-0.5, 0.8, 0.2));
        let (e1, e2) = (a.cross(b).normalize(), a);
        let e2 = e2.cross(e1).normalize();
        let n = 7;
        let rim = |k: usize| {
            let k = k % n;
            let phi = TAU * k as f32 / n as f32 + 0.1;
            centre + (e1 * phi.cos() + e2 * phi.sin()) * (1.0 + 0.3 * (k as f32).sin())
        };
        let tris: Vec<([Vec3; 3], u32)> = (0..n).map(|k| ([centre, rim(k), rim(k + 1)], k as u32)).collect();
        let blocks: Vec<Tri4> = tris.chunks(4).map(Tri4::new).collect();
        let mut targets = vec![centre];
        for k in 0..n {
            for s in [0.1f32, 0.37, 0.5, 0.83] {
                targets.push(centre.lerp(rim(k), s));
            }
        }
        let mut f = uniform_in(0x9e37_79b9_7f4a_7c15);
        let mut rays = 0;
        for target in &targets {
            for _ in 0..400 {
                let o = target + Vec3::new(f(), f(), f()) * 4.0;
                let d = (*target - o).normalize();
                let ray = Ray4::new(o, d);
                let hit = blocks.iter().any(|b| b.intersect(&ray, F4::splat(0.0), F4::splat(100.0)).mask != 0);
                assert!(hit, "ray from {o} towards {target} fell through the fan");
                rays += 1;
            }
        }
        assert_eq!(rays, targets.len() * 400);
    }

    /// The barycentrics name the second and third vertex, as the shading code expects.
    #[test]
    fn barycentrics_and_distance_of_a_known_hit() {
        let p = [Vec3::new(0.0, 0.0, 2.0), Vec3::new(1.0, 0.0, 2.0), Vec3::new(0.0, 1.0, 2.0)];
        let block = Tri4::new(&[(p, 5)]);
        for d in [Vec3::Z, -Vec3::Z] {
            let o = Vec3::new(0.25, 0.5, 2.0) - d * 3.0;
            let h = block.intersect(&Ray4::new(o, d), F4::splat(0.0), F4::splat(10.0));
            assert_eq!(h.mask, 1);
            assert!((h.t[0] - 3.0).abs() < 1e-6);
            assert!((h.u.to_array()[0] - 0.25).abs() < 1e-6 && (h.v.to_array()[0] - 0.5).abs() < 1e-6);
        }
        // Out of range on either side.
        let h = block.intersect(&Ray4::new(Vec3::new(0.25, 0.5, 0.0), Vec3::Z), F4::splat(2.5), F4::splat(10.0));
        assert_eq!(h.mask, 0);
        let h = block.intersect(&Ray4::new(Vec3::new(0.25, 0.5, 0.0), Vec3::Z), F4::splat(0.0), F4::splat(1.5));
        assert_eq!(h.mask, 0);
    }
}

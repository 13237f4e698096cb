//! Triangles and their acceleration structure: closest hit and occlusion.
//!
//! The tree is built by obvhs. It is traced either as wedge's own wide BVH (`super::wide_bvh`, the
//! default: 8 children per node on CPUs with AVX2, else 4) or as obvhs's compressed 8-wide BVH,
//! kept so that the ray benchmark can compare them on the same rays.
pub use super::wide_bvh::gamma;
use super::wide_bvh::{LeafCost, WideBvh, Width, MAX_PACKET};
use glam::{Vec2, Vec3, Vec3A};
use obvhs::{
    bvh2::builder::build_bvh2_from_tris,
    cwbvh::{builder::build_cwbvh_from_tris, CwBvh},
    ray::{Ray, RayHit},
    rt_triangle::RtTriangle,
    triangle::Triangle,
    BvhBuildParams,
};
use std::time::Duration;

/// Marks an absent per-triangle attribute.
pub const NONE: u32 = u32::MAX;

/// What a triangle belongs to. Shading normals and texture coordinates live in side tables so
/// that meshes without them cost nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TriAttr {
    pub material: u32,
    /// Shape (object) id, for G-buffer id checks.
    pub object: u32,
    /// Index into the normals table, or NONE (flat shading).
    pub normals: u32,
    /// Index into the uv table, or NONE (barycentric uvs).
    pub uvs: u32,
}

/// BVH build presets of obvhs: slower builds trace faster (pre-splitting, wider search).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BvhQuality {
    Fast,
    #[default]
    Medium,
    Slow,
}

impl BvhQuality {
    fn params(self) -> BvhBuildParams {
        match self {
            BvhQuality::Fast => BvhBuildParams::fast_build(),
            BvhQuality::Medium => BvhBuildParams::medium_build(),
            BvhQuality::Slow => BvhBuildParams::slow_build(),
        }
    }
}

/// How the built tree is laid out and traced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BvhLayout {
    /// wedge's wide BVH with vector box and triangle tests (`super::wide_bvh`), with leaves
    /// chosen by the block-aware SAH (`LeafCost`), or None: obvhs's own leaves of up to 8
    /// triangles (kept for the ray benchmark's comparison).
    Wide(Width, Option<LeafCost>),
    /// obvhs's compressed 8-wide BVH and its traversal.
    Cwbvh,
}

impl Default for BvhLayout {
    /// The widest BVH this CPU traces fast.
    fn default() -> Self {
        BvhLayout::Wide(Width::best(), Some(LeafCost::default()))
    }
}

#[derive(Clone)]
enum Accel {
    Wide(WideBvh),
    Cwbvh(CwBvh),
}

/// Collects triangles before the BVH is built.
#[derive(Default, Clone, Debug)]
pub struct GeometryBuilder {
    pub positions: Vec<[Vec3; 3]>,
    pub attrs: Vec<TriAttr>,
    pub normals: Vec<[Vec3; 3]>,
    pub uvs: Vec<[Vec2; 3]>,
    /// Zero-area triangles left out (they can never be hit and have no normal).
    pub degenerate: usize,
}

impl GeometryBuilder {
    pub fn push(
        &mut self,
        p: [Vec3; 3],
        normals: Option<[Vec3; 3]>,
        uvs: Option<[Vec2; 3]>,
        material: u32,
        object: u32,
    ) {
        let area2 = (p[1] - p[0]).cross(p[2] - p[0]).length();
        if !(area2 > 0.0 && area2.is_finite()) {
            self.degenerate += 1;
            return;
        }
        let normals = match normals {
            Some(n) if n.iter().all(|v| v.is_finite() && v.length_squared() > 0.0) => {
                self.normals.push(n.map(Vec3::normalize));
                (self.normals.len() - 1) as u32
            }
            _ => NONE,
        };
        let uvs = match uvs {
            Some(uv) => {
                self.uvs.push(uv);
                (self.uvs.len() - 1) as u32
            }
            None => NONE,
        };
        self.positions.push(p);
        self.attrs.push(TriAttr { material, object, normals, uvs });
    }

    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Applies `f` to every position and shading normal (`g` maps normals).
    pub fn transform(&mut self, f: impl Fn(Vec3) -> Vec3, g: impl Fn(Vec3) -> Vec3) {
        for t in &mut self.positions {
            *t = t.map(&f);
        }
        for n in &mut self.normals {
            *n = n.map(|v| g(v).normalize_or_zero());
        }
    }

    pub fn build(self, quality: BvhQuality, layout: BvhLayout) -> Geometry {
        if self.positions.is_empty() {
            return Geometry {
                bvh: None,
                tris: Vec::new(),
                attrs: Vec::new(),
                source: Vec::new(),
                normals: self.normals,
                uvs: self.uvs,
            };
        }
        let input: Vec<Triangle> =
            self.positions.iter().map(|p| Triangle { v0: p[0].into(), v1: p[1].into(), v2: p[2].into() }).collect();
        let mut build_time = Duration::ZERO;
        let (accel, slots) = match layout {
            BvhLayout::Wide(width, leaves) => {
                // With a LeafCost, obvhs builds a binary tree down to single triangles, and the
                // collapse to the wide tree picks the leaves.
                let max_prims_per_leaf = if leaves.is_some() { 1 } else { 8 };
                let params = BvhBuildParams { max_prims_per_leaf, ..quality.params() };
                let bvh2 = build_bvh2_from_tris(&input, params, &mut build_time);
                let slot_tris: Vec<[Vec3; 3]> =
                    bvh2.primitive_indices.iter().map(|&i| self.positions[i as usize]).collect();
                let w = WideBvh::from_bvh2(&bvh2, &slot_tris, width, leaves);
                (Accel::Wide(w), bvh2.primitive_indices)
            }
            BvhLayout::Cwbvh => {
                let bvh = build_cwbvh_from_tris(&input, quality.params(), &mut build_time);
                let slots = bvh.primitive_indices.clone();
                (Accel::Cwbvh(bvh), slots)
            }
        };
        // Store triangles in BVH slot order so a hit's slot indexes them directly (with
        // pre-splitting a triangle can occupy several slots).
        let tris = slots.iter().map(|&i| RtTriangle::from(&input[i as usize])).collect();
        let attrs = slots.iter().map(|&i| self.attrs[i as usize]).collect();
        Geometry { bvh: Some(accel), tris, attrs, source: slots, normals: self.normals, uvs: self.uvs }
    }
}

/// Turns -0.0 components into +0.0: obvhs's CWBVH traversal misses some hits of rays with a
/// -0.0 direction component (axis-aligned rays against flat boxes; see the test below), and
/// x + 0.0 is +0.0 for x = -0.0 and x otherwise.
#[inline]
fn canonical(d: Vec3) -> Vec3 {
    d + Vec3::ZERO
}

/// Up to `MAX_PACKET` rays with `canonical` directions, padded.
fn canonical_rays(rays: &[(Vec3, Vec3)]) -> [(Vec3, Vec3); MAX_PACKET] {
    std::array::from_fn(|i| rays.get(i).map_or((Vec3::ZERO, Vec3::Z), |&(o, d)| (o, canonical(d))))
}

/// A ray-surface intersection, before shading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Triangle slot (index into `Geometry::tris`/`attrs`).
    pub slot: u32,
    /// Barycentric weights of the second and third vertex.
    pub b1: f32,
    pub b2: f32,
}

#[derive(Clone)]
pub struct Geometry {
    bvh: Option<Accel>,
    pub tris: Vec<RtTriangle>,
    pub attrs: Vec<TriAttr>,
    /// Per slot: the index of its triangle in the builder (pre-splitting can put one triangle
    /// in several slots), so that a triangle can be moved later (`with_moved`).
    pub source: Vec<u32>,
    pub normals: Vec<[Vec3; 3]>,
    pub uvs: Vec<[Vec2; 3]>,
}

impl std::fmt::Debug for Geometry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Geometry").field("triangles", &self.tris.len()).finish()
    }
}

impl Geometry {
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Closest hit with t in [tmin, tmax].
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let dir = canonical(dir);
        match self.bvh.as_ref()? {
            Accel::Wide(bvh) => {
                bvh.intersect(origin, dir, tmin, tmax).map(|h| Hit { t: h.t, slot: h.slot, b1: h.u, b2: h.v })
            }
            Accel::Cwbvh(bvh) => {
                let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
                let mut hit = RayHit::none();
                if !bvh.ray_traverse(ray, &mut hit, |r, id| self.tris[id].intersect(r)) {
                    return None;
                }
                let tri = &self.tris[hit.primitive_id as usize];
                let b = tri.compute_barycentric(&ray);
                Some(Hit { t: hit.t, slot: hit.primitive_id, b1: b.x, b2: b.y })
            }
        }
    }

    /// True when something lies on the segment origin + t dir, t in [tmin, tmax].
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        let dir = canonical(dir);
        match self.bvh.as_ref() {
            None => false,
            Some(Accel::Wide(bvh)) => bvh.occluded(origin, dir, tmin, tmax),
            Some(Accel::Cwbvh(bvh)) => {
                let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
                // ray_traverse_miss returns true when NOT occluded.
                !bvh.ray_traverse_miss(ray, |r, id| self.tris[id].intersect(r))
            }
        }
    }

    /// The closest hit of each ray (origin, direction) with t in [tmin, tmax], into `out`: what
    /// `intersect` gives each, coherent rays traced together (`WideBvh::intersect_many`).
    pub fn intersect_many(&self, rays: &[(Vec3, Vec3)], tmin: f32, tmax: f32, out: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), out.len(), "one hit per ray");
        let Some(Accel::Wide(bvh)) = self.bvh.as_ref() else {
            for (o, &(origin, dir)) in out.iter_mut().zip(rays) {
                *o = self.intersect(origin, dir, tmin, tmax);
            }
            return;
        };
        for (rays, out) in rays.chunks(MAX_PACKET).zip(out.chunks_mut(MAX_PACKET)) {
            let n = rays.len();
            let rays: [(Vec3, Vec3); MAX_PACKET] = canonical_rays(rays);
            let mut hits = [None; MAX_PACKET];
            bvh.intersect_many(&rays[..n], tmin, tmax, &mut hits[..n]);
            for (o, h) in out.iter_mut().zip(hits) {
                *o = h.map(|h| Hit { t: h.t, slot: h.slot, b1: h.u, b2: h.v });
            }
        }
    }

    /// Whether something lies on each segment origin + t dir, t in [tmin, tmax[i]], into `out`:
    /// what `occluded` says for each, coherent rays traced together.
    pub fn occluded_many(&self, rays: &[(Vec3, Vec3)], tmin: f32, tmax: &[f32], out: &mut [bool]) {
        assert!(rays.len() == out.len() && rays.len() == tmax.len(), "one answer and one end per ray");
        let Some(Accel::Wide(bvh)) = self.bvh.as_ref() else {
            for ((o, &(origin, dir)), &end) in out.iter_mut().zip(rays).zip(tmax) {
                *o = self.occluded(origin, dir, tmin, end);
            }
            return;
        };
        let chunks = rays.chunks(MAX_PACKET).zip(tmax.chunks(MAX_PACKET)).zip(out.chunks_mut(MAX_PACKET));
        for ((rays, ends), out) in chunks {
            let rays: [(Vec3, Vec3); MAX_PACKET] = canonical_rays(rays);
            bvh.occluded_many(&rays[..out.len()], tmin, ends, out);
        }
    }

    /// The nearest and the farthest hit on the segment origin + t dir, t in [tmin, tmax], in one
    /// traversal that never shortens the ray (what the AAF authors' any-hit shader collected):
    /// cheaper than a closest-hit query from each end.
    pub fn hit_range(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<(f32, f32)> {
        let dir = canonical(dir);
        let (mut near, mut far) = (f32::INFINITY, f32::NEG_INFINITY);
        let mut add = |t: f32| {
            near = near.min(t);
            far = far.max(t);
        };
        match self.bvh.as_ref()? {
            Accel::Wide(bvh) => bvh.for_each_hit(origin, dir, tmin, tmax, add),
            Accel::Cwbvh(bvh) => {
                let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
                let mut hit = RayHit::none();
                bvh.ray_traverse(ray, &mut hit, |r, id| {
                    let t = self.tris[id].intersect(r);
                    if t.is_finite() {
                        add(t);
                    }
                    // Never a hit for the traversal: every node the segment crosses is visited.
                    f32::INFINITY
                });
            }
        }
        (near <= far).then_some((near, far))
    }

    /// Geometric (unnormalised-orientation) unit normal of a slot: (v1 - v0) x (v2 - v0).
    #[inline]
    pub fn geometric_normal(&self, slot: u32) -> Vec3 {
        // RtTriangle stores ng = (v0 - v1) x (v2 - v0) = -(v1 - v0) x (v2 - v0).
        Vec3::from(-self.tris[slot as usize].ng).normalize()
    }

    /// A copy with the builder's triangles `moved[i].0` at the vertices `moved[i].1`, the tree
    /// refitted rather than built again (`WideBvh::move_triangles`). None for the CWBVH layout,
    /// which only the ray benchmark builds and which has no refit.
    pub fn with_moved(&self, moved: &[(u32, [Vec3; 3])]) -> Option<Geometry> {
        let mut g = self.clone();
        let slots: Vec<(u32, [Vec3; 3])> = (0..g.source.len() as u32)
            .filter_map(|s| moved.iter().find(|(i, _)| *i == g.source[s as usize]).map(|(_, p)| (s, *p)))
            .collect();
        for &(s, p) in &slots {
            g.tris[s as usize] = RtTriangle::new(p[0].into(), p[1].into(), p[2].into());
        }
        match &mut g.bvh {
            None => {}
            Some(Accel::Wide(bvh)) => bvh.move_triangles(&slots),
            Some(Accel::Cwbvh(_)) => return None,
        }
        Some(g)
    }

    /// The three vertices of a slot.
    pub fn vertices(&self, slot: u32) -> [Vec3; 3] {
        let t = &self.tris[slot as usize];
        let v0: Vec3A = t.v0;
        [v0.into(), (v0 - t.e1).into(), (v0 + t.e2).into()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::test_rng::Rng;

    fn brute_force(tris: &[[Vec3; 3]], o: Vec3, d: Vec3, tmax: f32) -> Option<(f32, usize)> {
        let mut best: Option<(f32, usize)> = None;
        for (i, p) in tris.iter().enumerate() {
            let t = RtTriangle::new(p[0].into(), p[1].into(), p[2].into()).intersect(&Ray::new(
                o.into(),
                d.into(),
                0.0,
                tmax,
            ));
            if t < best.map_or(tmax, |b| b.0) {
                best = Some((t, i));
            }
        }
        best
    }

    /// `count` random triangles of size about `size` in a 4-unit box; object id = index.
    fn triangle_soup(rng: &mut Rng, count: u32, size: f32) -> (Vec<[Vec3; 3]>, GeometryBuilder) {
        let mut b = GeometryBuilder::default();
        let mut tris = Vec::new();
        for i in 0..count {
            let c = rng.v() * 4.0;
            let p = [c + rng.v() * size, c + rng.v() * size, c + rng.v() * size];
            tris.push(p);
            b.push(p, None, None, 0, i);
        }
        (tris, b)
    }

    /// The builder built in every layout and quality (slow pre-splits triangles, so that one
    /// triangle sits in several leaves).
    fn every_build(b: &GeometryBuilder) -> Vec<(String, Geometry)> {
        let mut out = Vec::new();
        let sah = Some(LeafCost::default());
        let layouts = [
            BvhLayout::Wide(Width::Eight, sah),
            BvhLayout::Wide(Width::Four, sah),
            BvhLayout::Wide(Width::Eight, None),
            BvhLayout::Cwbvh,
        ];
        for layout in layouts {
            for quality in [BvhQuality::Fast, BvhQuality::Medium, BvhQuality::Slow] {
                out.push((format!("{layout:?} {quality:?}"), b.clone().build(quality, layout)));
            }
        }
        out
    }

    #[test]
    fn hit_range_is_the_nearest_and_farthest_hit_on_the_segment() {
        let (tris, b) = triangle_soup(&mut Rng(0x9e37_79b9), 500, 0.4);
        for (name, g) in every_build(&b) {
            hit_range_matches_brute_force(&name, &g, &tris);
        }
    }

    fn hit_range_matches_brute_force(name: &str, g: &Geometry, tris: &[[Vec3; 3]]) {
        let mut rng = Rng(0x5bd1_e995);
        let mut seen = 0;
        for _ in 0..2000 {
            let (o, d, tmax) = (rng.v() * 6.0, rng.v().normalize(), 1.0 + rng.f() * 10.0);
            let ts: Vec<f32> = tris
                .iter()
                .map(|p| {
                    let ray = Ray::new(o.into(), d.into(), 0.0, tmax);
                    RtTriangle::new(p[0].into(), p[1].into(), p[2].into()).intersect(&ray)
                })
                .filter(|t| t.is_finite())
                .collect();
            let expect = (!ts.is_empty())
                .then(|| (ts.iter().copied().fold(f32::INFINITY, f32::min), ts.iter().copied().fold(0.0, f32::max)));
            let got = g.hit_range(o, d, 0.0, tmax);
            match (expect, got) {
                (None, None) => {}
                (Some((n, f)), Some((gn, gf))) => {
                    seen += 1;
                    assert!((n - gn).abs() <= 1e-5 * n.max(1.0) && (f - gf).abs() <= 1e-5 * f.max(1.0));
                    assert!(gn <= gf);
                }
                other => panic!("{name}: mismatch {other:?}"),
            }
        }
        assert!(seen > 100, "{name}: only {seen} segments hit anything");
    }

    #[test]
    fn bvh_hits_equal_brute_force_on_random_triangles() {
        let (tris, b) = triangle_soup(&mut Rng(0x1234_5678), 2000, 0.3);
        assert_eq!(b.degenerate, 0);
        for (name, g) in every_build(&b) {
            hits_match_brute_force(&name, &g, &tris);
        }
    }

    fn hits_match_brute_force(name: &str, g: &Geometry, tris: &[[Vec3; 3]]) {
        let mut rng = Rng(0x2545_f491);
        let (mut hits, mut occl) = (0, 0);
        for _ in 0..3000 {
            let o = rng.v() * 6.0;
            let d = rng.v().normalize();
            let tmax = 1.0 + rng.f() * 10.0;
            let expect = brute_force(tris, o, d, tmax);
            let got = g.intersect(o, d, 0.0, tmax);
            match (expect, got) {
                (None, None) => {}
                (Some((t, i)), Some(h)) => {
                    hits += 1;
                    assert!((t - h.t).abs() <= 1e-5 * t.max(1.0), "t {t} vs {}", h.t);
                    // Same triangle (the object id carries the original index).
                    if (t - h.t).abs() < 1e-7 {
                        assert_eq!(g.attrs[h.slot as usize].object as usize, i);
                    }
                }
                (e, h) => panic!("{name}: brute force {e:?} vs bvh {h:?}"),
            }
            if g.occluded(o, d, 0.0, tmax) {
                occl += 1;
            }
            assert_eq!(g.occluded(o, d, 0.0, tmax), expect.is_some(), "{name}");
        }
        assert!(hits > 300 && occl == hits, "{name}: hits {hits} occl {occl}");
    }

    #[test]
    fn barycentrics_reconstruct_the_hit_point() {
        let mut b = GeometryBuilder::default();
        let p = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 3.0, 0.0)];
        b.push(p, None, None, 0, 0);
        for (name, g) in every_build(&b) {
            let o = Vec3::new(0.5, 1.0, 5.0);
            let h = g.intersect(o, Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
            let v = g.vertices(h.slot);
            let x = v[0] * (1.0 - h.b1 - h.b2) + v[1] * h.b1 + v[2] * h.b2;
            assert!((x - Vec3::new(0.5, 1.0, 0.0)).length() < 1e-6, "{name}");
            assert!((h.t - 5.0).abs() < 1e-6, "{name}");
            assert!((g.geometric_normal(h.slot) - Vec3::Z).length() < 1e-6, "{name}");
        }
    }

    #[test]
    fn axis_aligned_rays_with_negative_zero_components_hit_flat_geometry() {
        let mut b = GeometryBuilder::default();
        let (c, u, v) = (Vec3::new(-2.0, 0.0, -2.0), Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 4.0));
        b.push([c, c + u, c + u + v], None, None, 0, 0);
        b.push([c, c + u + v, c + v], None, None, 0, 0);
        for (name, g) in every_build(&b) {
            let o = Vec3::new(0.3, 3.0, 0.2);
            for d in [Vec3::NEG_Y, Vec3::new(-0.0, -1.0, -0.0)] {
                assert_eq!(g.intersect(o, d, 0.0, f32::INFINITY).map(|h| h.t), Some(3.0), "{name} {d:?}");
                assert!(g.occluded(o, d, 0.0, 10.0), "{name} {d:?}");
            }
        }
    }

    #[test]
    fn degenerate_and_empty_geometry_are_harmless() {
        let mut b = GeometryBuilder::default();
        b.push([Vec3::ZERO, Vec3::X, Vec3::X * 2.0], None, None, 0, 0);
        b.push([Vec3::ZERO, Vec3::ZERO, Vec3::ZERO], None, None, 0, 0);
        b.push([Vec3::ZERO, Vec3::NAN, Vec3::X], None, None, 0, 0);
        assert_eq!(b.degenerate, 3);
        for (name, g) in every_build(&b) {
            assert_eq!(g.triangle_count(), 0, "{name}");
            assert!(g.intersect(Vec3::ZERO, Vec3::X, 0.0, 1.0).is_none(), "{name}");
            assert!(!g.occluded(Vec3::ZERO, Vec3::X, 0.0, 1.0), "{name}");
            assert!(g.hit_range(Vec3::ZERO, Vec3::X, 0.0, 1.0).is_none(), "{name}");
        }
    }
}

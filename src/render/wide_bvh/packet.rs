//! Rays traced through the tree together, as packets of 16 (AVX-512) or 8 (AVX2) rays in
//! structure-of-arrays form: one vector lane per ray.
//!
//! A single ray tests the 4 triangles of a block, or the 8 boxes of a node, in one vector
//! instruction; a packet tests one triangle, or one box, against all its rays at once. Where the
//! rays of a packet visit the same nodes (a pixel's camera rays, which leave one point in
//! nearly one direction) this reads each node and triangle once for all of them, and a leaf's
//! triangles cost a quarter of the single-ray tests with 16 lanes. Incoherent rays would drag
//! every lane through every ray's nodes, so callers pack only coherent ones.
//!
//! Every lane computes what `WideBvh::intersect` computes for its ray, with the same
//! operations in the same order (the slab test of `node`, the watertight test of `tri4`,
//! including its error bound): each ray enters the same boxes and finds the same closest
//! distance, bit for bit. Only the order in which a packet visits the leaves differs, so where
//! two triangles lie at exactly the same distance (a ray through a shared edge) the slot and
//! barycentrics reported may be the other triangle's.
// Elsewhere the packet code is not built and every query goes one ray at a time.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code, unused_imports))]
#[cfg(target_arch = "x86_64")]
use super::lanes::{Lanes, L16, L8};
use super::node::{WideNode, FAR_SCALE, LEAF, NO_CHILD};
use super::tri4::{gamma, Tri4, EMPTY_SLOT, NEAR_HIT};
use super::{Nodes, WideBvh, WideHit};
use glam::Vec3;

/// The widest packet any CPU traces.
pub const MAX_PACKET: usize = 16;

/// How this CPU traces packets: the lanes per packet, or none (rays go one at a time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacketWidth {
    /// No packet code for this CPU or tree: `intersect` per ray.
    Single,
    /// 8 lanes (AVX2, FMA; 8-wide trees).
    Eight,
    /// 16 lanes (AVX-512F; 8-wide trees).
    Sixteen,
}

impl PacketWidth {
    fn of(bvh: &WideBvh) -> PacketWidth {
        #[cfg(target_arch = "x86_64")]
        if let Nodes::Eight(_) = bvh.nodes {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return PacketWidth::Sixteen;
            }
            return PacketWidth::Eight;
        }
        let _ = bvh;
        PacketWidth::Single
    }
}

/// The per-lane constants of a packet's rays, and what they have found. Every ray of a packet
/// shares the triangle test's axis permutation `k` and the slab test's near sides `near` (the
/// signs of its direction), which `run` groups rays by.
#[cfg(target_arch = "x86_64")]
struct Packet<V: Lanes> {
    o: [V; 3],
    inv: [V; 3],
    shear: [V; 3],
    k: [usize; 3],
    near: [usize; 3],
    tmin: V,
    /// The segment's end, shortened to the closest hit so far.
    tmax: V,
    slot: [u32; MAX_PACKET],
    u: V,
    v: V,
}

/// The grouping key of a ray: the axis permutation of the watertight test (`Ray4::new`) and the
/// near sides of the slab test (`RayBox::new`).
#[cfg(target_arch = "x86_64")]
fn key(d: Vec3) -> ([usize; 3], [usize; 3]) {
    let kz = d.abs().max_position();
    let mut kx = (kz + 1) % 3;
    let mut ky = (kx + 1) % 3;
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let inv = inverse(d);
    ([kx, ky, kz], [(inv.x < 0.0) as usize, (inv.y < 0.0) as usize, (inv.z < 0.0) as usize])
}

/// `RayBox`'s inverse direction: near-zero components get a huge inverse of their own sign.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn inverse(d: Vec3) -> Vec3 {
    let inv = |x: f32| 1.0 / if x.abs() < 1e-30 { 1e-30f32.copysign(x) } else { x };
    Vec3::new(inv(d.x), inv(d.y), inv(d.z))
}

#[cfg(target_arch = "x86_64")]
impl<V: Lanes> Packet<V> {
    /// The packet of `rays[i]` for the lanes of `lanes` (the others idle), all with key `k`.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions.
    #[inline(always)]
    unsafe fn new(rays: &[(Vec3, Vec3)], lanes: &[usize], k: ([usize; 3], [usize; 3]), tmin: f32) -> Self {
        let mut o = [[0.0f32; MAX_PACKET]; 3];
        let mut inv = [[1.0f32; MAX_PACKET]; 3];
        let mut shear = [[0.0f32; MAX_PACKET]; 3];
        let [kx, ky, kz] = k.0;
        for (lane, &r) in lanes.iter().enumerate() {
            let (origin, d) = rays[r];
            let i = inverse(d);
            for a in 0..3 {
                o[a][lane] = origin[a];
                inv[a][lane] = i[a];
            }
            shear[0][lane] = d[kx] / d[kz];
            shear[1][lane] = d[ky] / d[kz];
            shear[2][lane] = 1.0 / d[kz];
        }
        Packet {
            o: [V::load(&o[0]), V::load(&o[1]), V::load(&o[2])],
            inv: [V::load(&inv[0]), V::load(&inv[1]), V::load(&inv[2])],
            shear: [V::load(&shear[0]), V::load(&shear[1]), V::load(&shear[2])],
            k: k.0,
            near: k.1,
            tmin: V::splat(tmin),
            tmax: V::splat(f32::NEG_INFINITY),
            slot: [EMPTY_SLOT; MAX_PACKET],
            u: V::splat(0.0),
            v: V::splat(0.0),
        }
    }

    /// The lanes of `active` that enter child `c` of `node`, and the nearest entry distance
    /// among them (`Node8::enter`'s arithmetic per lane).
    #[inline(always)]
    unsafe fn enter<N: WideNode>(&self, node: &N, c: usize, active: u32) -> (u32, f32) {
        // No closures here: a closure is compiled without the caller's target features, and
        // its intrinsics would not be inlined.
        let mut near = [V::splat(0.0); 3];
        let mut far = [V::splat(0.0); 3];
        for a in 0..3 {
            near[a] = V::splat(node.plane(self.near[a], a)[c]).sub(self.o[a]).mul(self.inv[a]);
            far[a] = V::splat(node.plane(1 - self.near[a], a)[c]).sub(self.o[a]).mul(self.inv[a]);
        }
        let t0 = near[0].max(near[1]).max(near[2].max(self.tmin));
        let t1 = far[0].min(far[1]).min(far[2]).mul(V::splat(FAR_SCALE)).min(self.tmax);
        let mask = t0.le(t1) & active;
        if mask == 0 {
            return (0, 0.0);
        }
        let mut t = [0.0f32; MAX_PACKET];
        V::select(mask, t0, V::splat(f32::INFINITY)).store(&mut t);
        (mask, t[..V::N].iter().fold(f32::INFINITY, |m, &x| if x < m { x } else { m }))
    }

    /// Vertex `p` relative to the lanes' origins, sheared so that each ray runs along +z
    /// (`Tri4::intersect`'s `moved`).
    #[inline(always)]
    unsafe fn moved(&self, p: &[[f32; 4]; 3], lane: usize) -> (V, V, V) {
        let [kx, ky, kz] = self.k;
        let [sx, sy, _] = self.shear;
        let x = V::splat(p[kx][lane]).sub(self.o[kx]);
        let y = V::splat(p[ky][lane]).sub(self.o[ky]);
        let z = V::splat(p[kz][lane]).sub(self.o[kz]);
        (x.sub(sx.mul(z)), y.sub(sy.mul(z)), z)
    }

    /// Tests triangle `lane` of a block (`tri`: its coordinates as (vertex, axis, lane); `slot`)
    /// against the packet's lanes of `active`, keeping each lane's closest hit (`Tri4::intersect` per lane). Returns the lanes
    /// it hit.
    #[inline(always)]
    unsafe fn triangle(&mut self, tri: &[[[f32; 4]; 3]; 3], lane: usize, slot: u32, active: u32) -> u32 {
        let sz = self.shear[2];
        let (ax, ay, az) = self.moved(&tri[0], lane);
        let (bx, by, bz) = self.moved(&tri[1], lane);
        let (cx, cy, cz) = self.moved(&tri[2], lane);
        let e0 = cx.mul(by).sub(cy.mul(bx));
        let e1 = ax.mul(cy).sub(ay.mul(cx));
        let e2 = bx.mul(ay).sub(by.mul(ax));
        let zero = V::splat(0.0);
        let some_negative = e0.min(e1).min(e2).lt(zero);
        let some_positive = zero.lt(e0.max(e1).max(e2));
        let det = e0.add(e1).add(e2);
        let t = sz.mul(e0.mul(az).add(e1.mul(bz)).add(e2.mul(cz)));
        let sign = det.sign();
        let abs_det = det.xor(sign);
        let t = t.xor(sign);
        // `det != 0` as SSE's cmpneq (true for NaN, whose range tests then fail).
        let nonzero = !det.eq(zero);
        let in_range = abs_det.mul(self.tmin).le(t) & t.le(abs_det.mul(self.tmax));
        let mut mask = nonzero & in_range & !(some_negative & some_positive) & active;
        if mask == 0 {
            return 0;
        }
        let inv = V::splat(1.0).div(abs_det);
        let t = t.mul(inv);
        if t.lt(V::splat(NEAR_HIT)) & mask != 0 {
            let delta_t = t_error_bound::<V>([[ax, ay, az], [bx, by, bz], [cx, cy, cz]], [e0, e1, e2], sz, inv);
            mask &= delta_t.lt(t);
        }
        // Nearer than (or as near as) the closest hit so far, as `WideBvh::intersect` keeps it.
        let closer = mask & t.le(self.tmax);
        if closer != 0 {
            self.tmax = V::select(closer, t, self.tmax);
            self.u = V::select(closer, e1.xor(sign).mul(inv), self.u);
            self.v = V::select(closer, e2.xor(sign).mul(inv), self.v);
            let mut m = closer;
            while m != 0 {
                self.slot[m.trailing_zeros() as usize] = slot;
                m &= m - 1;
            }
        }
        mask
    }
}

/// The largest magnitude of three lanes' values, as `tri4`'s `max3`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn max3<V: Lanes>(a: V, b: V, c: V) -> V {
    a.abs().max(b.abs()).max(c.abs())
}

/// `tri4::t_error_bound` over a packet's lanes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn t_error_bound<V: Lanes>(v: [[V; 3]; 3], e: [V; 3], sz: V, inv: V) -> V {
    let [[ax, ay, az], [bx, by, bz], [cx, cy, cz]] = v;
    let max_zt = max3(az, bz, cz).mul(sz.abs());
    let (max_xt, max_yt) = (max3(ax, bx, cx), max3(ay, by, cy));
    let delta_z = V::splat(gamma(3)).mul(max_zt);
    let delta_x = V::splat(gamma(5)).mul(max_xt.add(max_zt));
    let delta_y = V::splat(gamma(5)).mul(max_yt.add(max_zt));
    let delta_e =
        V::splat(2.0).mul(V::splat(gamma(2)).mul(max_xt).mul(max_yt).add(delta_y.mul(max_xt)).add(delta_x.mul(max_yt)));
    let max_e = max3(e[0], e[1], e[2]);
    V::splat(3.0)
        .mul(V::splat(gamma(3)).mul(max_e).mul(max_zt).add(delta_e.mul(max_zt)).add(delta_z.mul(max_e)))
        .mul(inv)
}

/// A node of the packet's walk: the lanes that entered it and the nearest of their entry
/// distances.
#[derive(Clone, Copy)]
struct Entry {
    node: u32,
    mask: u32,
    t: f32,
}

#[cfg(target_arch = "x86_64")]
impl<V: Lanes> Packet<V> {
    /// The children of inner node `node` that some lane of `mask` enters, as entries.
    #[inline(always)]
    unsafe fn children<N: WideNode>(&self, node: &N, mask: u32, kids: &mut [Entry; 8]) -> usize {
        let mut n = 0;
        for c in 0..N::LANES {
            let child = node.child(c);
            if child == NO_CHILD {
                continue;
            }
            let (m, t) = self.enter(node, c, mask);
            if m != 0 {
                kids[n] = Entry { node: child, mask: m, t };
                n += 1;
            }
        }
        n
    }

    /// Each lane of `active`'s closest hit, in `tmax`, `slot`, `u`, `v`. Children are visited
    /// nearest first (by their nearest lane's entry), so that hits found early cull the rest.
    #[inline(always)]
    unsafe fn closest<N: WideNode>(&mut self, bvh: &WideBvh, nodes: &[N], active: u32, stack: &mut Vec<Entry>) {
        stack.clear();
        stack.push(Entry { node: bvh.root, mask: active, t: f32::NEG_INFINITY });
        let mut kids = [Entry { node: NO_CHILD, mask: 0, t: 0.0 }; 8];
        while let Some(e) = stack.pop() {
            // A lane whose closest hit is nearer than the node's nearest entry cannot meet
            // anything nearer in it.
            let mask = e.mask & V::splat(e.t).le(self.tmax);
            if mask == 0 {
                continue;
            }
            if e.node & LEAF == 0 {
                let n = self.children(&nodes[e.node as usize], mask, &mut kids);
                // Farthest first onto the stack, so that the nearest is popped next.
                for j in 1..n {
                    let mut k = j;
                    while k > 0 && kids[k - 1].t < kids[k].t {
                        kids.swap(k - 1, k);
                        k -= 1;
                    }
                }
                stack.extend_from_slice(&kids[..n]);
            } else {
                for block in leaf_blocks(bvh, e.node) {
                    for lane in 0..4 {
                        if block.slots[lane] != EMPTY_SLOT {
                            self.triangle(block.coordinates(), lane, block.slots[lane], mask);
                        }
                    }
                }
            }
        }
    }

    /// The lanes of `active` whose segment meets some triangle.
    #[inline(always)]
    unsafe fn any<N: WideNode>(&mut self, bvh: &WideBvh, nodes: &[N], active: u32, stack: &mut Vec<Entry>) -> u32 {
        stack.clear();
        stack.push(Entry { node: bvh.root, mask: active, t: f32::NEG_INFINITY });
        let mut kids = [Entry { node: NO_CHILD, mask: 0, t: 0.0 }; 8];
        let mut blocked = 0;
        while let Some(e) = stack.pop() {
            let mut mask = e.mask & !blocked;
            if mask == 0 {
                continue;
            }
            if e.node & LEAF == 0 {
                let n = self.children(&nodes[e.node as usize], mask, &mut kids);
                stack.extend_from_slice(&kids[..n]);
                continue;
            }
            'leaf: for block in leaf_blocks(bvh, e.node) {
                for lane in 0..4 {
                    if block.slots[lane] != EMPTY_SLOT {
                        blocked |= self.triangle(block.coordinates(), lane, block.slots[lane], mask);
                        mask &= !blocked;
                        if mask == 0 {
                            break 'leaf;
                        }
                    }
                }
            }
            if blocked == active {
                break;
            }
        }
        blocked
    }
}

/// The blocks of leaf reference `leaf`.
#[inline(always)]
fn leaf_blocks(bvh: &WideBvh, leaf: u32) -> &[Tri4] {
    let start = ((leaf & !LEAF) >> 3) as usize;
    let count = (leaf & 7) as usize + 1;
    &bvh.blocks[start..start + count]
}

/// Groups fewer rays than this go one at a time: a packet costs the same for one lane as for
/// all of them.
pub const MIN_PACKET: usize = 3;

/// What a packet query does with its packets and with rays traced alone.
trait Query {
    #[cfg(target_arch = "x86_64")]
    unsafe fn packet<V: Lanes, N: WideNode>(
        &mut self,
        bvh: &WideBvh,
        nodes: &[N],
        p: &mut Packet<V>,
        lanes: &[usize],
        stack: &mut Vec<Entry>,
    );
    fn single(&mut self, bvh: &WideBvh, ray: usize);
}

struct Closest<'a> {
    rays: &'a [(Vec3, Vec3)],
    tmin: f32,
    tmax: f32,
    out: &'a mut [Option<WideHit>],
}

impl Query for Closest<'_> {
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn packet<V: Lanes, N: WideNode>(
        &mut self,
        bvh: &WideBvh,
        nodes: &[N],
        p: &mut Packet<V>,
        lanes: &[usize],
        stack: &mut Vec<Entry>,
    ) {
        p.tmax = V::splat(self.tmax);
        p.closest(bvh, nodes, (1u32 << lanes.len()) - 1, stack);
        let mut t = [0.0f32; MAX_PACKET];
        let (mut u, mut v) = ([0.0f32; MAX_PACKET], [0.0f32; MAX_PACKET]);
        p.tmax.store(&mut t);
        p.u.store(&mut u);
        p.v.store(&mut v);
        for (lane, &r) in lanes.iter().enumerate() {
            self.out[r] = (p.slot[lane] != EMPTY_SLOT).then(|| WideHit {
                t: t[lane],
                slot: p.slot[lane],
                u: u[lane],
                v: v[lane],
            });
        }
    }

    fn single(&mut self, bvh: &WideBvh, r: usize) {
        let (o, d) = self.rays[r];
        self.out[r] = bvh.intersect(o, d, self.tmin, self.tmax);
    }
}

struct Occluded<'a> {
    rays: &'a [(Vec3, Vec3)],
    tmin: f32,
    tmax: &'a [f32],
    out: &'a mut [bool],
}

impl Query for Occluded<'_> {
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn packet<V: Lanes, N: WideNode>(
        &mut self,
        bvh: &WideBvh,
        nodes: &[N],
        p: &mut Packet<V>,
        lanes: &[usize],
        stack: &mut Vec<Entry>,
    ) {
        let mut ends = [f32::NEG_INFINITY; MAX_PACKET];
        for (lane, &r) in lanes.iter().enumerate() {
            ends[lane] = self.tmax[r];
        }
        p.tmax = V::load(&ends);
        let blocked = p.any(bvh, nodes, (1u32 << lanes.len()) - 1, stack);
        for (lane, &r) in lanes.iter().enumerate() {
            self.out[r] = blocked >> lane & 1 == 1;
        }
    }

    fn single(&mut self, bvh: &WideBvh, r: usize) {
        let (o, d) = self.rays[r];
        self.out[r] = bvh.occluded(o, d, self.tmin, self.tmax[r]);
    }
}

/// Runs `q` over `rays` in packets of up to `V::N` rays sharing a key (`key`); small groups go
/// one ray at a time.
///
/// # Safety
/// The CPU must have `V`'s instructions.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn run<V: Lanes, N: WideNode, Q: Query>(
    bvh: &WideBvh,
    nodes: &[N],
    rays: &[(Vec3, Vec3)],
    tmin: f32,
    q: &mut Q,
) {
    let mut stack = Vec::with_capacity(bvh.stack_need);
    for (chunk, part) in rays.chunks(V::N).enumerate() {
        let base = chunk * V::N;
        let mut keys = [([0usize; 3], [0usize; 3]); MAX_PACKET];
        for (i, r) in part.iter().enumerate() {
            keys[i] = key(r.1);
        }
        let mut left = (1u32 << part.len()) - 1;
        while left != 0 {
            let first = left.trailing_zeros() as usize;
            let mut lanes = [0usize; MAX_PACKET];
            let mut n = 0;
            for i in first..part.len() {
                if left >> i & 1 == 1 && keys[i] == keys[first] {
                    lanes[n] = base + i;
                    n += 1;
                    left &= !(1 << i);
                }
            }
            if n < MIN_PACKET {
                lanes[..n].iter().for_each(|&r| q.single(bvh, r));
                continue;
            }
            // Each query sets its lanes' segment ends.
            let mut p = Packet::<V>::new(rays, &lanes[..n], keys[first], tmin);
            q.packet(bvh, nodes, &mut p, &lanes[..n], &mut stack);
        }
    }
}

impl WideBvh {
    /// How this tree traces packets on this CPU.
    pub fn packet_width(&self) -> PacketWidth {
        PacketWidth::of(self)
    }

    /// The closest hit of each of `rays` (origin, unit direction) with t in [tmin, tmax], into
    /// `out`: what `intersect` finds for each (but for which of two triangles at exactly the
    /// same distance is named; see the module doc). Rays that share their direction's signs
    /// and dominant axis go in packets, so coherent rays should come together.
    pub fn intersect_many(&self, rays: &[(Vec3, Vec3)], tmin: f32, tmax: f32, out: &mut [Option<WideHit>]) {
        self.intersect_many_as(self.packet_width(), rays, tmin, tmax, out)
    }

    /// `intersect_many` in packets of `width` (one ray at a time where this CPU lacks it).
    pub(super) fn intersect_many_as(
        &self,
        width: PacketWidth,
        rays: &[(Vec3, Vec3)],
        tmin: f32,
        tmax: f32,
        out: &mut [Option<WideHit>],
    ) {
        assert_eq!(rays.len(), out.len(), "one hit per ray");
        let mut q = Closest { rays, tmin, tmax, out };
        self.dispatch(width, rays, tmin, &mut q);
    }

    /// Whether something lies on each segment `rays[i]` at t in [tmin, tmax[i]]: what
    /// `occluded` says for each, rays that share direction signs and dominant axis in packets.
    pub fn occluded_many(&self, rays: &[(Vec3, Vec3)], tmin: f32, tmax: &[f32], out: &mut [bool]) {
        self.occluded_many_as(self.packet_width(), rays, tmin, tmax, out)
    }

    pub(super) fn occluded_many_as(
        &self,
        width: PacketWidth,
        rays: &[(Vec3, Vec3)],
        tmin: f32,
        tmax: &[f32],
        out: &mut [bool],
    ) {
        assert!(rays.len() == out.len() && rays.len() == tmax.len(), "one answer and one end per ray");
        let mut q = Occluded { rays, tmin, tmax, out };
        self.dispatch(width, rays, tmin, &mut q);
    }

    fn dispatch<Q: Query>(&self, width: PacketWidth, rays: &[(Vec3, Vec3)], tmin: f32, q: &mut Q) {
        if self.root == NO_CHILD {
            (0..rays.len()).for_each(|r| q.single(self, r));
            return;
        }
        // A width this CPU lacks (asked for by a caller that did not check) goes one ray at a
        // time rather than running instructions the CPU does not have.
        let width = match (width, PacketWidth::of(self)) {
            (PacketWidth::Sixteen, PacketWidth::Sixteen) => PacketWidth::Sixteen,
            (PacketWidth::Sixteen | PacketWidth::Eight, PacketWidth::Sixteen | PacketWidth::Eight) => {
                PacketWidth::Eight
            }
            _ => PacketWidth::Single,
        };
        match (&self.nodes, width) {
            // SAFETY: `PacketWidth::of` gives Sixteen only where the CPU has AVX-512F and
            // Eight only for 8-wide trees, which are built only where it has AVX2 and FMA;
            // `width` is at most what it gives.
            #[cfg(target_arch = "x86_64")]
            (Nodes::Eight(nodes), PacketWidth::Sixteen) => unsafe { run_avx512(self, nodes, rays, tmin, q) },
            #[cfg(target_arch = "x86_64")]
            (Nodes::Eight(nodes), PacketWidth::Eight) => unsafe { run_avx2(self, nodes, rays, tmin, q) },
            _ => (0..rays.len()).for_each(|r| q.single(self, r)),
        }
    }
}

/// `run` with 16 lanes, compiled for AVX-512.
///
/// # Safety
/// The CPU must support AVX-512F, AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn run_avx512<Q: Query>(
    bvh: &WideBvh,
    nodes: &[super::node::Node8],
    rays: &[(Vec3, Vec3)],
    tmin: f32,
    q: &mut Q,
) {
    run::<L16, _, Q>(bvh, nodes, rays, tmin, q)
}

/// `run` with 8 lanes, compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2<Q: Query>(bvh: &WideBvh, nodes: &[super::node::Node8], rays: &[(Vec3, Vec3)], tmin: f32, q: &mut Q) {
    run::<L8, _, Q>(bvh, nodes, rays, tmin, q)
}

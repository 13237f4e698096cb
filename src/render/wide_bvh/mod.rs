//! A wide BVH (4 or 8 children per node) traced one ray at a time with vector box and triangle
//! tests, as Embree traces single rays, or coherent rays (a pixel's camera rays) as packets of 8
//! or 16 with one lane per ray (`packet`, on `lanes`).
//!
//! obvhs builds the tree (a binary BVH: PLOC and reinsertion, down to single triangles); this
//! module chooses its leaves (`LeafCost`: the surface area heuristic counting 4-triangle blocks),
//! collapses it to 8 children per node where the CPU has AVX2 and FMA (checked at run time, so
//! the portable binary uses them too) and to 4 otherwise (SSE, part of every x86-64, or plain
//! code elsewhere), and packs each leaf's triangles into 4-lane `Tri4` blocks. One vector slab
//! test gives the entry distance of all children of a node; they are visited nearest first.
//! Compared with obvhs's own compressed 8-wide traversal (CWBVH: quantised boxes, decoded per
//! node, designed for GPUs), this spends fewer instructions per node on a CPU.
mod lanes;
mod node;
mod packet;
mod refit;
mod simd;
mod tri4;
pub use packet::{PacketWidth, MAX_PACKET, MIN_PACKET};
pub use tri4::gamma;

use glam::Vec3;
#[cfg(target_arch = "x86_64")]
use node::Node8;
use node::{Node4, RayBox, WideNode, LEAF, NO_CHILD};
use obvhs::bvh2::Bvh2;
use simd::F4;
use std::mem::MaybeUninit;
use tri4::{Ray4, Tri4};

/// Blocks per leaf are counted in three bits.
const MAX_LEAF_BLOCKS: usize = 8;
/// Traversal stack kept on the machine stack when the tree is shallow enough (width - 1 entries
/// per level at most); deeper trees, which only degenerate inputs give, use a heap stack.
const INLINE_STACK: usize = 64;

/// Children per node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Width {
    Four,
    /// Needs AVX2 and FMA.
    Eight,
}

impl Width {
    /// The widest this CPU traces fast: 8 with AVX2 and FMA, else 4.
    pub fn best() -> Width {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            return Width::Eight;
        }
        Width::Four
    }

    fn children(self) -> usize {
        match self {
            Width::Four => 4,
            Width::Eight => 8,
        }
    }
}

/// A closest hit: distance, triangle slot and the barycentrics of the second and third vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WideHit {
    pub t: f32,
    pub slot: u32,
    pub u: f32,
    pub v: f32,
}

#[derive(Clone)]
enum Nodes {
    Four(Vec<Node4>),
    #[cfg(target_arch = "x86_64")]
    Eight(Vec<Node8>),
}

#[derive(Clone)]
pub struct WideBvh {
    nodes: Nodes,
    blocks: Vec<Tri4>,
    root: u32,
    /// Stack entries a traversal can need: width - 1 per level below the root, plus one.
    stack_need: usize,
}

/// A node while the tree is collapsed: child minima and maxima per axis, child references.
type NodeArrays = ([[f32; 8]; 3], [[f32; 8]; 3], [u32; 8]);

#[derive(Clone, Copy)]
struct Entry {
    node: u32,
    t: f32,
}

impl WideBvh {
    /// Collapses `bvh2` (built over triangles whose slot `i` has vertices `slot_tris[i]`) to
    /// `width` children per node, with leaves chosen by `leaves` (None: `bvh2`'s own leaves).
    /// `Width::Eight` on a CPU without AVX2 and FMA (or not x86-64) falls back to four.
    pub fn from_bvh2(bvh2: &Bvh2, slot_tris: &[[Vec3; 3]], width: Width, leaves: Option<LeafCost>) -> Self {
        let width = if width == Width::Eight && Width::best() == Width::Eight { width } else { Width::Four };
        let w = width.children();
        let is_leaf = leaf_subtrees(bvh2, leaves);
        let mut blocks = Vec::new();
        let mut nodes: Vec<NodeArrays> = Vec::new();
        // Unused lanes keep an empty box (min +inf, max -inf), which no ray enters.
        let empty = ([[f32::INFINITY; 8]; 3], [[f32::NEG_INFINITY; 8]; 3], [NO_CHILD; 8]);
        let mut depth = 0;
        // (bvh2 inner node, its index here, its depth). A node's children are all created when
        // it is, so that they sit next to each other in memory (as do their leaves' blocks): the
        // traversal tests a node and then reads some of its children.
        let mut todo: Vec<(usize, usize, usize)> = Vec::new();
        let root = match bvh2.nodes.first() {
            _ if slot_tris.is_empty() => NO_CHILD,
            None => NO_CHILD,
            Some(_) if is_leaf[0] => leaf(&mut blocks, &subtree_slots(bvh2, 0), slot_tris),
            Some(_) => {
                nodes.push(empty);
                todo.push((0, 0, 0));
                0
            }
        };
        while let Some((n, index, level)) = todo.pop() {
            depth = depth.max(level);
            for (lane, k) in open_up_to(bvh2, &is_leaf, n, w).into_iter().enumerate() {
                let kid = &bvh2.nodes[k];
                let reference = if is_leaf[k] {
                    leaf(&mut blocks, &subtree_slots(bvh2, k), slot_tris)
                } else {
                    nodes.push(empty);
                    todo.push((k, nodes.len() - 1, level + 1));
                    (nodes.len() - 1) as u32
                };
                let node = &mut nodes[index];
                for a in 0..3 {
                    node.0[a][lane] = kid.aabb.min[a];
                    node.1[a][lane] = kid.aabb.max[a];
                }
                node.2[lane] = reference;
            }
        }
        // Leaves hang one level below the deepest inner node.
        let depth = if nodes.is_empty() { 0 } else { depth + 1 };
        let nodes = match width {
            Width::Four => Nodes::Four(crate::render::huge_pages::advise(
                nodes.iter().map(|n| Node4::new(n.0, n.1, n.2)).collect(),
            )),
            #[cfg(target_arch = "x86_64")]
            Width::Eight => Nodes::Eight(crate::render::huge_pages::advise(
                nodes.iter().map(|n| Node8::new(n.0, n.1, n.2)).collect(),
            )),
            #[cfg(not(target_arch = "x86_64"))]
            Width::Eight => unreachable!("eight-wide nodes fall back to four off x86-64"),
        };
        WideBvh { nodes, blocks: crate::render::huge_pages::advise(blocks), root, stack_need: (w - 1) * depth + 1 }
    }

    pub fn width(&self) -> Width {
        match self.nodes {
            Nodes::Four(_) => Width::Four,
            #[cfg(target_arch = "x86_64")]
            Nodes::Eight(_) => Width::Eight,
        }
    }

    pub fn node_count(&self) -> usize {
        match &self.nodes {
            Nodes::Four(n) => n.len(),
            #[cfg(target_arch = "x86_64")]
            Nodes::Eight(n) => n.len(),
        }
    }

    pub fn block_count(&self) -> usize {
        self.blocks.len()
    }

    /// Closest hit with t in [tmin, tmax].
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<WideHit> {
        let mut leaf = ClosestHit { ray: Ray4::new(o, d), tmin, best: None };
        let mut tmax = tmax;
        self.walk(o, d, tmin, &mut tmax, true, &mut leaf);
        leaf.best
    }

    /// True when some triangle lies on the segment at t in [tmin, tmax].
    pub fn occluded(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
        let mut tmax = tmax;
        self.walk(o, d, tmin, &mut tmax, false, &mut AnyHit { ray: Ray4::new(o, d), tmin })
    }

    /// Calls `f` with the distance of every hit on the segment (a triangle in several leaves,
    /// which spatial splits allow, may be reported more than once).
    pub fn for_each_hit(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32, f: impl FnMut(f32)) {
        let mut tmax = tmax;
        self.walk(o, d, tmin, &mut tmax, false, &mut EachHit { ray: Ray4::new(o, d), tmin, f });
    }

    /// Visits the leaves whose boxes the segment enters, nearest child first when `ordered`;
    /// `leaf` may shorten `tmax` and returns true to stop. Returns whether a leaf stopped it.
    #[inline(always)]
    fn walk(&self, o: Vec3, d: Vec3, tmin: f32, tmax: &mut f32, ordered: bool, leaf: &mut impl Leaf) -> bool {
        if self.root == NO_CHILD {
            return false;
        }
        let ray = RayBox::new(o, d);
        let q = Query { blocks: &self.blocks, root: self.root, ray: &ray, tmin, ordered };
        // Left uninitialised: the traversal writes every entry before reading it, and clearing
        // the stack for every ray showed in profiles as a memset.
        let mut inline = [MaybeUninit::<Entry>::uninit(); INLINE_STACK];
        let mut heap = Vec::new();
        let stack: &mut [MaybeUninit<Entry>] = if self.stack_need <= INLINE_STACK {
            &mut inline
        } else {
            heap.resize(self.stack_need, MaybeUninit::uninit());
            &mut heap
        };
        match &self.nodes {
            // SAFETY: Node4 needs nothing beyond the build target.
            Nodes::Four(nodes) => unsafe { q.run(nodes, stack, tmax, leaf) },
            // SAFETY: eight-wide nodes are only built when the CPU has AVX2 and FMA.
            #[cfg(target_arch = "x86_64")]
            Nodes::Eight(nodes) => unsafe { q.run_avx2(nodes, stack, tmax, leaf) },
        }
    }
}

/// What a traversal does at a leaf: tests the leaf's blocks, may shorten `tmax`, and returns
/// true to stop. A trait whose method is always inlined rather than a closure: a closure's body
/// is compiled on its own, without the traversal's AVX2 and FMA, and called once per leaf.
trait Leaf {
    fn visit(&mut self, blocks: &[Tri4], tmax: &mut f32) -> bool;
}

/// The closest hit so far.
struct ClosestHit {
    ray: Ray4,
    tmin: f32,
    best: Option<WideHit>,
}

impl Leaf for ClosestHit {
    #[inline(always)]
    fn visit(&mut self, blocks: &[Tri4], tmax: &mut f32) -> bool {
        for b in blocks {
            let h = b.intersect(&self.ray, F4::splat(self.tmin), F4::splat(*tmax));
            let mut m = h.mask;
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                if h.t[i] <= *tmax {
                    *tmax = h.t[i];
                    self.best =
                        Some(WideHit { t: h.t[i], slot: b.slots[i], u: h.u.to_array()[i], v: h.v.to_array()[i] });
                }
            }
        }
        false
    }
}

/// Any hit: stops at the first.
struct AnyHit {
    ray: Ray4,
    tmin: f32,
}

impl Leaf for AnyHit {
    #[inline(always)]
    fn visit(&mut self, blocks: &[Tri4], tmax: &mut f32) -> bool {
        // A loop, not `any` with a closure: the closure would not take the caller's features.
        for b in blocks {
            if b.intersect(&self.ray, F4::splat(self.tmin), F4::splat(*tmax)).mask != 0 {
                return true;
            }
        }
        false
    }
}

/// Every hit, to `f`.
struct EachHit<F: FnMut(f32)> {
    ray: Ray4,
    tmin: f32,
    f: F,
}

impl<F: FnMut(f32)> Leaf for EachHit<F> {
    #[inline(always)]
    fn visit(&mut self, blocks: &[Tri4], tmax: &mut f32) -> bool {
        for b in blocks {
            let h = b.intersect(&self.ray, F4::splat(self.tmin), F4::splat(*tmax));
            for i in 0..4 {
                if h.mask >> i & 1 == 1 {
                    (self.f)(h.t[i]);
                }
            }
        }
        false
    }
}

/// One traversal's inputs.
struct Query<'a> {
    blocks: &'a [Tri4],
    root: u32,
    ray: &'a RayBox,
    tmin: f32,
    ordered: bool,
}

impl Query<'_> {
    /// `run` compiled with AVX2 and FMA enabled, so that the inlined node, triangle and
    /// traversal code all use them.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn run_avx2<N: WideNode>(
        &self,
        nodes: &[N],
        stack: &mut [MaybeUninit<Entry>],
        tmax: &mut f32,
        leaf: &mut impl Leaf,
    ) -> bool {
        // SAFETY: forwarded from this function's contract.
        unsafe { self.run(nodes, stack, tmax, leaf) }
    }

    /// The traversal loop. `stack` must hold `stack_need` entries; entries below `sp` are
    /// always initialised (each is written when pushed), and only those are read.
    ///
    /// # Safety
    /// The CPU must support `N`'s instruction set (see `WideNode::enter`).
    #[inline(always)]
    unsafe fn run<N: WideNode>(
        &self,
        nodes: &[N],
        stack: &mut [MaybeUninit<Entry>],
        tmax: &mut f32,
        leaf: &mut impl Leaf,
    ) -> bool {
        let mut t = [0.0f32; 8];
        let mut sp = 0;
        let mut cur = self.root;
        loop {
            // Descend through inner nodes, pushing the farther children.
            while cur & LEAF == 0 {
                let node = &nodes[cur as usize];
                // SAFETY: forwarded from this function's contract.
                let mut mask = unsafe { node.enter(self.ray, self.tmin, *tmax, &mut t) };
                if mask == 0 {
                    cur = NO_CHILD;
                    break;
                }
                let first = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if mask == 0 {
                    cur = node.child(first);
                    continue;
                }
                // Several children: push them all, sorted so the nearest is on top, then pop it
                // straight away.
                let base = sp;
                stack[sp] = MaybeUninit::new(Entry { node: node.child(first), t: t[first] });
                sp += 1;
                while mask != 0 {
                    let lane = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let e = Entry { node: node.child(lane), t: t[lane] };
                    let mut j = sp;
                    if self.ordered {
                        // Insertion keeping entries in decreasing distance upwards.
                        while j > base && pushed(stack, j - 1).t < e.t {
                            stack[j] = stack[j - 1];
                            j -= 1;
                        }
                    }
                    stack[j] = MaybeUninit::new(e);
                    sp += 1;
                }
                sp -= 1;
                cur = pushed(stack, sp).node;
            }
            if cur != NO_CHILD {
                let start = ((cur & !LEAF) >> 3) as usize;
                let count = (cur & 7) as usize + 1;
                if leaf.visit(&self.blocks[start..start + count], tmax) {
                    return true;
                }
            }
            // Pop the next node still nearer than the closest hit.
            loop {
                if sp == 0 {
                    return false;
                }
                sp -= 1;
                let e = pushed(stack, sp);
                if e.t <= *tmax {
                    cur = e.node;
                    break;
                }
            }
        }
    }
}

/// Stack entry `i`, which the traversal has pushed (every entry below its stack pointer was).
#[inline(always)]
fn pushed(stack: &[MaybeUninit<Entry>], i: usize) -> Entry {
    // SAFETY: `run` reads only entries below its stack pointer, each written when pushed.
    unsafe { stack[i].assume_init() }
}

/// Packs the triangles of `slots` into blocks of four; returns the leaf reference.
fn leaf(blocks: &mut Vec<Tri4>, slots: &[u32], slot_tris: &[[Vec3; 3]]) -> u32 {
    let start = blocks.len();
    let lanes: Vec<([Vec3; 3], u32)> = slots.iter().map(|&s| (slot_tris[s as usize], s)).collect();
    for chunk in lanes.chunks(4) {
        blocks.push(Tri4::new(chunk));
    }
    let n = blocks.len() - start;
    assert!(n <= MAX_LEAF_BLOCKS, "a leaf of {} triangles exceeds {MAX_LEAF_BLOCKS} blocks", slots.len());
    assert!(start < 1 << 28, "too many triangle blocks for a 28-bit index");
    LEAF | (start as u32) << 3 | (n as u32 - 1)
}

/// Which subtrees of the binary tree become leaves of the wide one.
///
/// The surface area heuristic with leaf costs counted in 4-triangle blocks, as Embree's wide
/// builders count them: a leaf of 5 triangles costs two block tests, as one of 8 does. obvhs's
/// own leaf collapse (a binary tree's: cost proportional to the triangle count, and only where
/// both children are already leaves) leaves many blocks part-empty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafCost {
    /// Cost of one binary node's box test in the wide tree, relative to one block test.
    pub node: f32,
    /// Largest leaf, in triangles (at most 4 * 8).
    pub max_triangles: usize,
}

impl Default for LeafCost {
    /// The fastest of node costs 0.25 to 3 and leaves of 8 to 32 triangles on the 1M-triangle
    /// terrain (`wedge bench rays`, BENCHMARKS.md "Rays"), against obvhs's own leaves of up to
    /// 8 triangles, for primary, shadow and bounce rays.
    fn default() -> Self {
        LeafCost { node: 1.5, max_triangles: 16 }
    }
}

/// Per bvh2 node: whether its subtree becomes one leaf. Bottom-up dynamic programming over
/// SAH(n) = min(A(n) * blocks(n), A(n) * node + SAH(left) + SAH(right)); bvh2 leaves stay
/// leaves. `None` keeps obvhs's leaves as they are.
fn leaf_subtrees(bvh2: &Bvh2, cost: Option<LeafCost>) -> Vec<bool> {
    let nodes = &bvh2.nodes;
    let mut is_leaf: Vec<bool> = nodes.iter().map(|n| n.prim_count > 0).collect();
    let Some(cost) = cost else { return is_leaf };
    let max = cost.max_triangles.min(4 * MAX_LEAF_BLOCKS);
    // Parents before children, then reversed.
    let mut order = Vec::with_capacity(nodes.len());
    let mut todo = if nodes.is_empty() { vec![] } else { vec![0usize] };
    while let Some(i) = todo.pop() {
        order.push(i);
        if nodes[i].prim_count == 0 {
            let first = nodes[i].first_index as usize;
            todo.extend([first, first + 1]);
        }
    }
    let blocks = |count: usize| count.div_ceil(4) as f32;
    let mut count = vec![0usize; nodes.len()];
    let mut sah = vec![0.0f32; nodes.len()];
    for &i in order.iter().rev() {
        let area = nodes[i].aabb.half_area();
        if nodes[i].prim_count > 0 {
            count[i] = nodes[i].prim_count as usize;
            sah[i] = area * blocks(count[i]);
            continue;
        }
        let first = nodes[i].first_index as usize;
        count[i] = count[first] + count[first + 1];
        let split = area * cost.node + sah[first] + sah[first + 1];
        let whole = area * blocks(count[i]);
        is_leaf[i] = count[i] <= max && whole <= split;
        sah[i] = if is_leaf[i] { whole } else { split };
    }
    is_leaf
}

/// The slots of the triangles under bvh2 node `n`, each triangle once (spatial splits can put a
/// triangle in several leaves of one subtree).
fn subtree_slots(bvh2: &Bvh2, n: usize) -> Vec<u32> {
    let mut slots: Vec<u32> = Vec::new();
    let mut todo = vec![n];
    while let Some(i) = todo.pop() {
        let node = &bvh2.nodes[i];
        let first = node.first_index as usize;
        if node.prim_count > 0 {
            for s in first..first + node.prim_count as usize {
                let prim = bvh2.primitive_indices[s];
                if !slots.iter().any(|&o| bvh2.primitive_indices[o as usize] == prim) {
                    slots.push(s as u32);
                }
            }
        } else {
            todo.extend([first + 1, first]);
        }
    }
    slots
}

/// The bvh2 nodes that become the children of bvh2 node `n` in a `w`-wide tree: starting from
/// its two children, the inner child of largest surface area is replaced by its own two children
/// until there are `w` (SAH-style collapse, as Embree's wide BVH builders open nodes).
fn open_up_to(bvh2: &Bvh2, is_leaf: &[bool], n: usize, w: usize) -> Vec<usize> {
    let first = bvh2.nodes[n].first_index as usize;
    let mut kids = vec![first, first + 1];
    while kids.len() < w {
        let widest = kids
            .iter()
            .enumerate()
            .filter(|(_, &k)| !is_leaf[k])
            .max_by(|a, b| bvh2.nodes[*a.1].aabb.half_area().total_cmp(&bvh2.nodes[*b.1].aabb.half_area()));
        let Some((i, &k)) = widest else { break };
        let f = bvh2.nodes[k].first_index as usize;
        kids[i] = f;
        kids.push(f + 1);
    }
    kids
}

#[cfg(test)]
mod tests;

//! Moving triangles without rebuilding the tree (a refit, as Embree's "refit" build quality
//! does for dynamic geometry): the moved lanes of their blocks get the new vertices, and the
//! boxes on the paths from those leaves to the root are recomputed bottom-up. The tree's
//! structure stays, so a triangle moved far from where it was makes traversal slower, never
//! wrong; boxes off those paths are untouched, bit for bit.
use super::node::{WideNode, LEAF, NO_CHILD};
use super::{Nodes, WideBvh};
use glam::Vec3;
use std::collections::BTreeSet;

impl WideBvh {
    /// Moves the triangle in each listed slot to its new vertices. Slots the tree does not hold
    /// are ignored.
    pub fn move_triangles(&mut self, moved: &[(u32, [Vec3; 3])]) {
        if moved.is_empty() || self.root == NO_CHILD {
            return;
        }
        let mut changed_blocks = BTreeSet::new();
        for (b, block) in self.blocks.iter_mut().enumerate() {
            for lane in 0..4 {
                if let Some((_, p)) = moved.iter().find(|(s, _)| *s == block.slots[lane]) {
                    block.set_lane(lane, *p);
                    changed_blocks.insert(b);
                }
            }
        }
        let blocks = &self.blocks;
        let leaf_bounds = |reference: u32| {
            let start = ((reference & !LEAF) >> 3) as usize;
            let count = (reference & 7) as usize + 1;
            blocks[start..start + count].iter().map(|b| b.bounds()).fold(empty(), union)
        };
        let touches = |reference: u32| {
            let start = ((reference & !LEAF) >> 3) as usize;
            changed_blocks.range(start..start + (reference & 7) as usize + 1).next().is_some()
        };
        match &mut self.nodes {
            Nodes::Four(nodes) => refit(nodes, self.root, touches, leaf_bounds),
            #[cfg(target_arch = "x86_64")]
            Nodes::Eight(nodes) => refit(nodes, self.root, touches, leaf_bounds),
        }
    }
}

fn empty() -> (Vec3, Vec3) {
    (Vec3::INFINITY, Vec3::NEG_INFINITY)
}

fn union(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> (Vec3, Vec3) {
    (a.0.min(b.0), a.1.max(b.1))
}

/// Recomputes the lane boxes of leaves that `touches` and of every inner node above them.
/// Children always have larger indices than their parent (the build creates a node's children
/// after it), so visiting dirty nodes from the largest index down finishes each node before
/// its parent reads it.
fn refit<N: WideNode>(
    nodes: &mut [N],
    root: u32,
    touches: impl Fn(u32) -> bool,
    leaf_bounds: impl Fn(u32) -> (Vec3, Vec3),
) {
    if root & LEAF != 0 {
        return; // A single leaf has no boxes above it: the traversal tests its blocks directly.
    }
    let mut parent = vec![(u32::MAX, 0usize); nodes.len()];
    let mut dirty = BTreeSet::new();
    for (n, node) in nodes.iter_mut().enumerate() {
        for lane in 0..N::LANES {
            let child = node.child(lane);
            if child == NO_CHILD {
                continue;
            }
            if child & LEAF == 0 {
                parent[child as usize] = (n as u32, lane);
            } else if touches(child) {
                let (lo, hi) = leaf_bounds(child);
                node.set_lane_box(lane, lo, hi);
                dirty.insert(n);
            }
        }
    }
    while let Some(n) = dirty.pop_last() {
        let (p, lane) = parent[n];
        if p == u32::MAX {
            continue;
        }
        let node = &nodes[n];
        let (lo, hi) =
            (0..N::LANES).filter(|&l| node.child(l) != NO_CHILD).map(|l| node.lane_box(l)).fold(empty(), union);
        nodes[p as usize].set_lane_box(lane, lo, hi);
        dirty.insert(p as usize);
    }
}

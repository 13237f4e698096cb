use super::*;
use crate::render::test_rng::Rng;
use obvhs::BvhBuildParams;
use obvhs::{bvh2::builder::build_bvh2_from_tris, triangle::Triangle};
use simd::F4;
use std::time::Duration;
use tri4::{Ray4, Tri4};

/// The widths this CPU can trace.
fn widths() -> Vec<Width> {
    if Width::best() == Width::Eight {
        vec![Width::Four, Width::Eight]
    } else {
        vec![Width::Four]
    }
}

/// obvhs's binary tree over `tris`, with leaves of at most `leaf` triangles.
fn bvh2(tris: &[[Vec3; 3]], leaf: u32, pre_split: bool) -> Bvh2 {
    let input: Vec<Triangle> =
        tris.iter().map(|p| Triangle { v0: p[0].into(), v1: p[1].into(), v2: p[2].into() }).collect();
    let params = BvhBuildParams { max_prims_per_leaf: leaf, pre_split, ..BvhBuildParams::medium_build() };
    build_bvh2_from_tris(&input, params, &mut Duration::default())
}

/// Builds the tree over `tris` with obvhs leaves of at most `leaf` triangles (kept as they are
/// when `leaves` is None); returns it with the triangles in slot order.
fn build_with(
    tris: &[[Vec3; 3]],
    leaf: u32,
    pre_split: bool,
    width: Width,
    leaves: Option<LeafCost>,
) -> (WideBvh, Vec<[Vec3; 3]>) {
    let bvh2 = bvh2(tris, leaf, pre_split);
    let slots: Vec<[Vec3; 3]> = bvh2.primitive_indices.iter().map(|&i| tris[i as usize]).collect();
    let bvh = WideBvh::from_bvh2(&bvh2, &slots, width, leaves);
    assert_eq!(bvh.width(), width);
    (bvh, slots)
}

fn build(tris: &[[Vec3; 3]], leaf: u32, pre_split: bool, width: Width) -> (WideBvh, Vec<[Vec3; 3]>) {
    build_with(tris, leaf, pre_split, width, None)
}

/// Distance of every triangle the segment hits, by brute force: each triangle tested alone
/// with the same triangle test (compared with obvhs's in `tri4`), so that these tests check
/// the traversal exactly.
fn brute_hits(tris: &[[Vec3; 3]], o: Vec3, d: Vec3, tmax: f32) -> Vec<f32> {
    let ray = Ray4::new(o, d);
    tris.iter()
        .filter_map(|&p| {
            let h = Tri4::new(&[(p, 0)]).intersect(&ray, F4::splat(0.0), F4::splat(tmax));
            (h.mask & 1 == 1).then_some(h.t[0])
        })
        .collect()
}

/// Closest t over all triangles by brute force.
fn brute(tris: &[[Vec3; 3]], o: Vec3, d: Vec3, tmax: f32) -> Option<f32> {
    brute_hits(tris, o, d, tmax).into_iter().min_by(f32::total_cmp)
}

/// Every query agrees with brute force: closest distance, the slot's triangle holds the hit
/// point, occlusion, and the number of hits on the segment.
fn check(bvh: &WideBvh, slots: &[[Vec3; 3]], tris: &[[Vec3; 3]], rays: &[(Vec3, Vec3, f32)]) -> usize {
    let mut hits = 0;
    for &(o, d, tmax) in rays {
        let expect = brute(tris, o, d, tmax);
        let got = bvh.intersect(o, d, 0.0, tmax);
        assert_eq!(got.is_some(), expect.is_some(), "ray {o:?} {d:?}: {got:?} vs {expect:?}");
        assert_eq!(bvh.occluded(o, d, 0.0, tmax), expect.is_some());
        if let (Some(h), Some(t)) = (got, expect) {
            hits += 1;
            // Two triangles through one seam point may round its distance differently.
            assert!((h.t - t).abs() <= 1e-6 * t.max(1.0), "{} vs {t}", h.t);
            let p = slots[h.slot as usize];
            let x = p[0] * (1.0 - h.u - h.v) + p[1] * h.u + p[2] * h.v;
            assert!((x - (o + d * h.t)).length() < 1e-4 * (1.0 + h.t), "barycentrics");
        }
        let all = brute_hits(tris, o, d, tmax).len();
        let mut seen = 0;
        bvh.for_each_hit(o, d, 0.0, tmax, |_| seen += 1);
        assert_eq!(seen, all, "hits on the segment");
    }
    hits
}

fn random_rays(rng: &mut Rng, n: usize) -> Vec<(Vec3, Vec3, f32)> {
    (0..n).map(|_| (rng.v() * 6.0, rng.v().normalize(), 1.0 + rng.f() * 10.0)).collect()
}

/// Rays from around the triangles towards points near random triangles' centroids.
fn aimed_rays(rng: &mut Rng, tris: &[[Vec3; 3]], n: usize) -> Vec<(Vec3, Vec3, f32)> {
    (0..n)
        .map(|_| {
            let o = rng.v() * 6.0;
            let p = tris[(rng.f() * tris.len() as f32) as usize % tris.len()];
            let target = (p[0] + p[1] + p[2]) / 3.0 + rng.v() * 0.05;
            (o, (target - o).normalize(), 30.0)
        })
        .collect()
}

fn soup(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = rng.v() * 4.0;
            [c + rng.v() * 0.4, c + rng.v() * 0.4, c + rng.v() * 0.4]
        })
        .collect()
}

/// `n` small triangles and 8 long diagonal ones, which pre-splitting cuts into several leaves
/// (it splits triangles whose boxes are far larger than the average and mostly empty).
fn soup_with_long_triangles(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    let mut tris = soup(rng, n);
    for _ in 0..8 {
        let (c, e) = (rng.v(), Vec3::new(4.0, 4.0 * rng.f(), -4.0));
        tris.push([c - e, c + e, c + e + rng.v() * 0.3]);
    }
    tris
}

#[test]
fn queries_equal_brute_force_for_leaf_sizes_of_one_to_several_blocks() {
    let mut rng = Rng(0x1234_5678);
    let tris = soup(&mut rng, 1500);
    let rays = random_rays(&mut rng, 1500);
    // Leaves of up to 8 and 16 triangles span two and four blocks.
    for width in widths() {
        for leaf in [1, 4, 8, 16] {
            let (bvh, slots) = build(&tris, leaf, false, width);
            assert!(check(&bvh, &slots, &tris, &rays) > 200, "{width:?} leaf {leaf}");
        }
    }
}

#[test]
fn spatial_splits_put_a_triangle_in_several_leaves_and_hits_stay_exact() {
    let mut rng = Rng(0x0bad_cafe);
    let tris = soup_with_long_triangles(&mut rng, 400);
    let rays = aimed_rays(&mut rng, &tris, 1000);
    for width in widths() {
        let (bvh, slots) = build(&tris, 4, true, width);
        assert!(slots.len() > tris.len(), "no triangle was split: {} slots", slots.len());
        let mut hits = 0;
        for &(o, d, tmax) in &rays {
            let expect = brute(&tris, o, d, tmax);
            let got = bvh.intersect(o, d, 0.0, tmax);
            assert_eq!(got.map(|h| h.t), expect, "{width:?} ray {o:?} {d:?}");
            assert_eq!(bvh.occluded(o, d, 0.0, tmax), expect.is_some());
            hits += got.is_some() as usize;
        }
        assert!(hits > 200, "{width:?}: {hits}");
    }
}

#[test]
fn a_tree_that_is_a_single_leaf_and_the_heap_stack_give_the_same_answers() {
    let mut rng = Rng(0x7777_1111);
    let one = soup(&mut rng, 1);
    let few = soup(&mut rng, 3);
    let tris = soup(&mut rng, 800);
    let rays = aimed_rays(&mut rng, &tris, 800);
    for width in widths() {
        let (bvh, slots) = build(&one, 4, false, width);
        assert_eq!((bvh.node_count(), bvh.block_count()), (0, 1), "one triangle makes a root leaf");
        assert!(check(&bvh, &slots, &one, &aimed_rays(&mut rng, &one, 500)) > 50);
        let (bvh, slots) = build(&few, 4, false, width);
        assert!(check(&bvh, &slots, &few, &aimed_rays(&mut rng, &few, 500)) > 50);

        let (mut bvh, slots) = build(&tris, 4, false, width);
        let inline: Vec<_> = rays.iter().map(|&(o, d, t)| bvh.intersect(o, d, 0.0, t)).collect();
        // Pretend the tree is too deep for the inline stack.
        bvh.stack_need = INLINE_STACK + 1;
        let heap: Vec<_> = rays.iter().map(|&(o, d, t)| bvh.intersect(o, d, 0.0, t)).collect();
        assert_eq!(inline, heap);
        assert!(check(&bvh, &slots, &tris, &rays) > 100);
    }
}

#[test]
fn rays_on_a_flat_grid_lose_no_hit_at_box_boundaries() {
    // A 48x48 quad grid at y = 0: every inner box is flat, and rays from above land on box
    // edges and corners (x, z on the grid lines) as well as inside cells.
    let n = 48;
    let p = |i: usize, j: usize| Vec3::new(i as f32 / n as f32 * 4.0 - 2.0, 0.0, j as f32 / n as f32 * 4.0 - 2.0);
    let mut tris = Vec::new();
    for i in 0..n {
        for j in 0..n {
            tris.push([p(i, j), p(i + 1, j + 1), p(i + 1, j)]);
            tris.push([p(i, j), p(i, j + 1), p(i + 1, j + 1)]);
        }
    }
    let mut rng = Rng(0x3141_5926);
    let mut rays = Vec::new();
    for k in 0..3000 {
        // Targets 1e-4 from a grid vertex (k even: close to the boxes' faces and corners, not on
        // a triangle edge, where the two triangle tests could round differently) or anywhere.
        let (a, b) = (1 + (rng.f() * (n - 2) as f32) as usize, 1 + (rng.f() * (n - 2) as f32) as usize);
        let target = if k % 2 == 0 {
            p(a, b) + Vec3::new(1e-4, 0.0, if k % 4 == 0 { 3e-4 } else { -2e-4 })
        } else {
            p(a, b) + Vec3::new(rng.f(), 0.0, rng.f()) * 0.05
        };
        let o = target + Vec3::new(rng.f() - 0.5, 1.0 + rng.f(), rng.f() - 0.5) * 3.0;
        rays.push((o, (target - o).normalize(), 100.0));
    }
    // Axis-aligned rays straight down, including -0.0 components.
    for k in 0..200 {
        let t = p(1 + k % (n - 2), 1 + (k * 7) % (n - 2)) + Vec3::new(0.013, 0.0, 0.029);
        rays.push((t + Vec3::Y * 2.0, Vec3::new(-0.0, -1.0, 0.0), 100.0));
    }
    // Targets exactly on grid vertices and on the cells' diagonals and edges, shared by two or
    // more triangles: the watertight triangle test hits at least one of them, so every ray of
    // this group must hit.
    let mut seams = Vec::new();
    for k in 0..1500 {
        let (a, b) = (1 + (rng.f() * (n - 2) as f32) as usize, 1 + (rng.f() * (n - 2) as f32) as usize);
        let s = rng.f();
        let target = match k % 3 {
            0 => p(a, b),
            1 => p(a, b).lerp(p(a + 1, b + 1), s),
            _ => p(a, b).lerp(p(a + 1, b), s),
        };
        let o = target + Vec3::new(rng.f() - 0.5, 1.0 + rng.f(), rng.f() - 0.5) * 3.0;
        seams.push((o, (target - o).normalize(), 100.0));
    }
    for width in widths() {
        let (bvh, slots) = build(&tris, 4, false, width);
        let hits = check(&bvh, &slots, &tris, &rays);
        assert!(hits > 3000, "{width:?}: {hits} hits");
        assert_eq!(check(&bvh, &slots, &tris, &seams), seams.len(), "{width:?}: a ray fell through a seam");
    }
}

/// The cost `leaf_subtrees` minimises, for any choice of leaves: A * node per inner node above
/// the leaves, A * blocks per leaf.
fn cut_cost(bvh2: &Bvh2, is_leaf: &[bool], cost: LeafCost) -> f32 {
    let mut total = 0.0;
    let mut todo = vec![0usize];
    while let Some(i) = todo.pop() {
        let area = bvh2.nodes[i].aabb.half_area();
        if is_leaf[i] {
            total += area * subtree_slots(bvh2, i).len().div_ceil(4) as f32;
        } else {
            total += area * cost.node;
            let first = bvh2.nodes[i].first_index as usize;
            todo.extend([first, first + 1]);
        }
    }
    total
}

#[test]
fn chosen_leaves_cover_every_triangle_once_and_cost_no_more_than_other_choices() {
    let mut rng = Rng(0x5eed_1eaf);
    let tris = soup(&mut rng, 600);
    let tree = bvh2(&tris, 1, false);
    for cost in
        [LeafCost { node: 0.5, max_triangles: 8 }, LeafCost::default(), LeafCost { node: 4.0, max_triangles: 32 }]
    {
        let chosen = leaf_subtrees(&tree, Some(cost));
        // The leaves (the chosen nodes with no chosen ancestor) partition the triangles.
        let mut seen = vec![0; tree.primitive_indices.len()];
        let mut todo = vec![0usize];
        while let Some(i) = todo.pop() {
            if chosen[i] {
                let slots = subtree_slots(&tree, i);
                assert!(slots.len() <= cost.max_triangles, "{cost:?}: a leaf of {}", slots.len());
                slots.iter().for_each(|&s| seen[s as usize] += 1);
            } else {
                let first = tree.nodes[i].first_index as usize;
                todo.extend([first, first + 1]);
            }
        }
        assert!(seen.iter().all(|&n| n == 1), "{cost:?}");
        // Optimal among the tree's cuts: no cheaper than the binary tree's own leaves, nor than
        // random cuts (each node made a leaf with some probability where it fits).
        let best = cut_cost(&tree, &chosen, cost);
        let singles: Vec<bool> = tree.nodes.iter().map(|n| n.prim_count > 0).collect();
        assert!(best <= cut_cost(&tree, &singles, cost) * (1.0 + 1e-5), "{cost:?}");
        let single_cost = cut_cost(&tree, &singles, cost);
        assert!(best < single_cost * 0.99, "{cost:?}: merging leaves should pay: {best} vs {single_cost}");
        for _ in 0..50 {
            let p = rng.f();
            let random: Vec<bool> = (0..tree.nodes.len())
                .map(|i| {
                    let n = subtree_slots(&tree, i).len();
                    tree.nodes[i].prim_count > 0 || (n <= cost.max_triangles && rng.f() < p)
                })
                .collect();
            assert!(best <= cut_cost(&tree, &random, cost) * (1.0 + 1e-5), "{cost:?}, p {p}");
        }
    }
}

#[test]
fn queries_equal_brute_force_with_chosen_leaves() {
    let mut rng = Rng(0x00dd_ba11);
    let tris = soup(&mut rng, 1500);
    let rays = random_rays(&mut rng, 1500);
    for width in widths() {
        // Up to 32 triangles (eight blocks, the most a leaf reference counts), and the default.
        for cost in [LeafCost { node: 100.0, max_triangles: 32 }, LeafCost::default()] {
            let (bvh, slots) = build_with(&tris, 1, false, width, Some(cost));
            let hits = check(&bvh, &slots, &tris, &rays);
            assert!(hits > 150, "{width:?} {cost:?}: {hits}");
        }
        // With spatial splits a subtree can hold pieces of one triangle in several of its
        // leaves; a wide leaf gathered from it holds the triangle once.
        let long = soup_with_long_triangles(&mut rng, 300);
        let tree = bvh2(&long, 1, true);
        assert!(tree.primitive_indices.len() > long.len(), "no triangle was split");
        let mut prims: Vec<u32> = subtree_slots(&tree, 0).iter().map(|&s| tree.primitive_indices[s as usize]).collect();
        prims.sort();
        assert_eq!(prims, (0..long.len() as u32).collect::<Vec<_>>());
        let (bvh, _) = build_with(&long, 1, true, width, Some(LeafCost { node: 100.0, max_triangles: 32 }));
        let mut hits = 0;
        for (o, d, tmax) in aimed_rays(&mut rng, &long, 600) {
            let expect = brute(&long, o, d, tmax);
            assert_eq!(bvh.intersect(o, d, 0.0, tmax).map(|h| h.t), expect, "{width:?} pre-split");
            assert_eq!(bvh.occluded(o, d, 0.0, tmax), expect.is_some());
            hits += expect.is_some() as usize;
        }
        assert!(hits > 150, "{width:?} pre-split: {hits}");
    }
}

#[test]
fn moved_triangles_are_found_where_they_went_and_not_where_they_were() {
    let mut rng = Rng(0x5eed_0f17);
    for (pre_split, leaves) in [(false, Some(LeafCost::default())), (true, None)] {
        let mut tris = soup_with_long_triangles(&mut rng, 600);
        for width in widths() {
            let (mut bvh, mut slots) = build_with(&tris, 4, pre_split, width, leaves);
            // Every 7th triangle (long ones included, which pre-splitting put in several
            // slots) jumps across the scene; every 11th moves a little.
            let mut moved_tris = tris.clone();
            for (i, t) in moved_tris.iter_mut().enumerate() {
                let shift = match i {
                    _ if i % 7 == 0 => Vec3::new(-5.0, 3.0, 2.0) + rng.v(),
                    _ if i % 11 == 0 => rng.v() * 0.2,
                    _ => continue,
                };
                *t = t.map(|p| p + shift);
            }
            let mut moved = Vec::new();
            for (s, slot) in slots.iter_mut().enumerate() {
                let i = tris.iter().position(|t| t == slot).expect("every slot holds an input triangle");
                if moved_tris[i] != tris[i] {
                    *slot = moved_tris[i];
                    moved.push((s as u32, moved_tris[i]));
                }
            }
            bvh.move_triangles(&moved);
            let mut rays = aimed_rays(&mut rng, &moved_tris, 1500);
            rays.extend(aimed_rays(&mut rng, &tris, 500));
            // (Hit counts on a segment are not compared: a moved triangle that pre-splitting put
            // in several leaves is now whole in each of them.)
            let mut hits = 0;
            for &(o, d, tmax) in &rays {
                let expect = brute(&moved_tris, o, d, tmax);
                let got = bvh.intersect(o, d, 0.0, tmax);
                assert_eq!(got.map(|h| h.t), expect, "{width:?} pre-split {pre_split}: ray {o:?} {d:?}");
                assert_eq!(bvh.occluded(o, d, 0.0, tmax), expect.is_some());
                if let Some(h) = got {
                    hits += 1;
                    let p = slots[h.slot as usize];
                    let x = p[0] * (1.0 - h.u - h.v) + p[1] * h.u + p[2] * h.v;
                    assert!((x - (o + d * h.t)).length() < 1e-4 * (1.0 + h.t), "barycentrics");
                }
            }
            assert!(hits > 500, "{width:?} pre-split {pre_split}: {hits}");
        }
        tris.clear();
    }
}

/// The packet widths this CPU can trace `bvh` with.
fn packet_widths(bvh: &WideBvh) -> Vec<PacketWidth> {
    let mut widths = vec![PacketWidth::Single];
    if bvh.width() == Width::Eight {
        widths.push(PacketWidth::Eight);
        if bvh.packet_width() == PacketWidth::Sixteen {
            widths.push(PacketWidth::Sixteen);
        }
    }
    widths
}

/// Fans of rays from one point into a narrow cone around a triangle (as a pixel's camera rays
/// leave the camera), `per_fan` rays each.
fn fans(rng: &mut Rng, tris: &[[Vec3; 3]], fans: usize, per_fan: usize, spread: f32) -> Vec<(Vec3, Vec3)> {
    let mut rays = Vec::new();
    for _ in 0..fans {
        let o = rng.v() * 6.0;
        let p = tris[(rng.f() * tris.len() as f32) as usize % tris.len()];
        let target = (p[0] + p[1] + p[2]) / 3.0;
        for _ in 0..per_fan {
            rays.push((o, (target + rng.v() * spread - o).normalize()));
        }
    }
    rays
}

/// Packets find what each ray finds alone: the same closest distance bit for bit, the same
/// triangle unless another lies at exactly that distance, the same occlusion. Coherent fans
/// (one packet each) and rays in every direction (split into groups by direction signs and
/// dominant axis, small groups traced alone), in packets of 8 and 16 where the CPU has them.
#[test]
fn packets_find_what_single_rays_find() {
    let mut rng = Rng(0x7a3c_51e9);
    let tris = soup(&mut rng, 1500);
    let coherent = fans(&mut rng, &tris, 120, 16, 0.05);
    let mixed: Vec<(Vec3, Vec3)> = random_rays(&mut rng, 700).into_iter().map(|(o, d, _)| (o, d)).collect();
    let ends: Vec<f32> = (0..coherent.len().max(mixed.len())).map(|_| 0.5 + rng.f() * 12.0).collect();
    let mut packed = 0;
    for width in widths() {
        let (bvh, slots) = build_with(&tris, 8, false, width, Some(LeafCost::default()));
        for pw in packet_widths(&bvh) {
            for rays in [&coherent, &mixed] {
                for tmax in [f32::INFINITY, 4.0] {
                    let mut got = vec![None; rays.len()];
                    bvh.intersect_many_as(pw, rays, 0.0, tmax, &mut got);
                    for (&(o, d), g) in rays.iter().zip(&got) {
                        let alone = bvh.intersect(o, d, 0.0, tmax);
                        assert_eq!(g.map(|h| h.t.to_bits()), alone.map(|h| h.t.to_bits()), "{pw:?}: {o} {d}");
                        if let (Some(g), Some(a)) = (g, alone) {
                            if g.slot != a.slot {
                                let other = Tri4::new(&[(slots[g.slot as usize], 0)]);
                                let h = other.intersect(&Ray4::new(o, d), F4::splat(0.0), F4::splat(tmax));
                                assert!(h.mask & 1 == 1 && h.t[0] == a.t, "{pw:?}: a tie names slot {}", g.slot);
                            } else {
                                assert_eq!((g.u, g.v), (a.u, a.v));
                            }
                        }
                    }
                    packed += (pw != PacketWidth::Single) as usize;
                }
                let mut blocked = vec![false; rays.len()];
                bvh.occluded_many_as(pw, rays, 0.0, &ends[..rays.len()], &mut blocked);
                for ((&(o, d), &b), &end) in rays.iter().zip(&blocked).zip(&ends) {
                    assert_eq!(b, bvh.occluded(o, d, 0.0, end), "{pw:?}: {o} {d} to {end}");
                }
            }
        }
    }
    if Width::best() == Width::Eight {
        assert!(packed > 0, "no packet width was tried");
    }
}

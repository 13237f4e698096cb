//! Coarse-to-fine shading on nested grids (Bagher et al. 2012, Sec. 3.2): which pixels a pass
//! shades and how the others take their values from their parents.
//!
//! Grids are nested on pixels: grid `l` holds the pixels whose x and y are multiples of 2^l,
//! and a pixel belongs to the coarsest grid that holds it (`grid_level`). A pixel on grid `l`
//! stands for the 2^l x 2^l block starting at it; it is shaded when the finest level any pixel
//! of that block asks for (the min-mipmap of levels) is `l` or finer, and otherwise takes its
//! value from its parents on grid `l + 1` with `upsample::weights` (bilinear x depth x the
//! anisotropic normal term), always with its own, finest-level G-buffer data. A pixel with no
//! usable parent (all across a depth edge, on another object, or none: the coarsest grid) is
//! shaded.
use super::levels::pyramid;
use super::upsample::{weights, Parent, UpsampleOptions};
use crate::render::camera::Camera;
use crate::render::gbuffer::GBuffer;

/// The coarsest grid holding pixel (x, y), at most `coarsest`.
pub fn grid_level(x: u32, y: u32, coarsest: i32) -> i32 {
    (x.trailing_zeros().min(y.trailing_zeros()) as i32).min(coarsest)
}

/// The parents of pixel (x, y) on grid `level + 1` inside a `w` x `h` image: index, offset in
/// parent spacings and bilinear weight (1/2 on an edge between two, 1/4 at the centre of four).
pub fn parents(x: u32, y: u32, level: i32, w: u32, h: u32) -> Vec<(usize, [f64; 2], f64)> {
    let s = 1i64 << (level + 1);
    let half = s / 2;
    let (x, y) = (x as i64, y as i64);
    let xs: &[i64] = if x % s == 0 { &[0] } else { &[-half, half] };
    let ys: &[i64] = if y % s == 0 { &[0] } else { &[-half, half] };
    let alpha = 1.0 / (xs.len() * ys.len()) as f64;
    let mut out = Vec::with_capacity(4);
    for &dy in ys {
        for &dx in xs {
            let (px, py) = (x + dx, y + dy);
            if px >= 0 && py >= 0 && px < w as i64 && py < h as i64 {
                let offset = [dx as f64 / s as f64, dy as f64 / s as f64];
                out.push(((py * w as i64 + px) as usize, offset, alpha));
            }
        }
    }
    out
}

/// For every pixel, the parents it takes its value from and their weights; `None` for pixels
/// that have to be shaded whenever they are seen (no usable parent). Fixed for a render: it
/// reads only the G-buffer.
pub struct Upsampling {
    pub width: u32,
    pub height: u32,
    pub coarsest: i32,
    pub weights: Vec<Option<Vec<(usize, f64)>>>,
    /// Pixel indices from the coarsest grid to the finest (parents before children).
    pub order: Vec<usize>,
}

impl Upsampling {
    pub fn new(g: &GBuffer, view: &Camera, coarsest: i32, opts: &UpsampleOptions, same_object: bool) -> Self {
        let (w, h) = (g.width, g.height);
        let weights = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let level = grid_level(x, y, coarsest);
                let p = g.at(x, y);
                if level >= coarsest || !p.is_valid() {
                    return None;
                }
                let list = parents(x, y, level, w, h);
                let candidates: Vec<Parent> = list
                    .iter()
                    .map(|&(j, offset, alpha)| {
                        let q = &g.pixels[j];
                        let same = q.object == p.object && q.kd == p.kd && q.ks == p.ks && q.exponent == p.exponent;
                        let computed = q.is_valid() && (!same_object || same);
                        Parent { offset, depth: q.depth as f64, alpha, computed }
                    })
                    .collect();
                // The screen-projected normal's angle (image y grows downwards) and the cosine
                // of the normal with the view.
                let (nx, ny) = (p.normal.dot(view.right()) as f64, -p.normal.dot(view.up()) as f64);
                let phi = ny.atan2(nx);
                let view_dir = (view.position - p.position).normalize_or_zero();
                let cos_theta = p.normal.dot(view_dir) as f64;
                let ws = weights(&candidates, p.depth as f64, phi, cos_theta, opts)?;
                Some(list.iter().zip(ws).filter(|(_, w)| *w > 0.0).map(|(&(j, _, _), w)| (j, w)).collect())
            })
            .collect();
        let mut order: Vec<usize> = (0..(w * h) as usize).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(grid_level(i as u32 % w, i as u32 / w, coarsest)));
        Upsampling { width: w, height: h, coarsest, weights, order }
    }

    /// Which surface pixels to shade for the per-pixel `levels` (Eq. 9's, as lowered by the
    /// passes): those whose block asks for their grid's level or finer, and those with no usable
    /// parent. `surface[i]` says whether pixel i sees a surface (background pixels are never
    /// shaded: nothing there reflects the environment).
    pub fn shaded(&self, levels: &[i32], surface: &[bool]) -> Vec<bool> {
        let (w, h) = (self.width as usize, self.height as usize);
        let mins = pyramid(levels, w, h, i32::min);
        (0..w * h)
            .map(|i| {
                if !surface[i] {
                    return false;
                }
                let (x, y) = ((i % w) as u32, (i / w) as u32);
                let level = grid_level(x, y, self.coarsest);
                let (bw, _, ref block) = mins[level as usize];
                let block_min = block[(y as usize >> level) * bw + (x as usize >> level)];
                block_min <= level || self.weights[i].is_none()
            })
            .collect()
    }

    /// How much each pixel's own value counts in the image: `I_p = 1 + sum over children c of
    /// (w_pc / W_c)^2 I_c`, over the pixels that take values from parents (`has_value` false),
    /// `W_c` the sum of their parents' weights. An independent error of variance `v` in pixel
    /// p's value adds `I_p v` to the summed squared error of the image (exactly where a child's
    /// parents share no ancestor; shared ancestors add cross terms, which this leaves out).
    /// Computed fine to coarse, so every child is final before its parents read it.
    pub fn influence(&self, has_value: &[bool]) -> Vec<f64> {
        let mut influence = vec![1.0f64; self.weights.len()];
        for &i in self.order.iter().rev() {
            if has_value[i] {
                continue;
            }
            let Some(ws) = &self.weights[i] else { continue };
            let total: f64 = ws.iter().map(|&(_, w)| w).sum();
            if !(total > 0.0) {
                continue;
            }
            let own = influence[i];
            for &(j, w) in ws {
                influence[j] += (w / total).powi(2) * own;
            }
        }
        influence
    }

    /// Every pixel's value, coarse to fine: its own where it has one, else its parents'
    /// weighted by `weights` (renormalised over the parents that have a value); `None` where
    /// neither exists.
    pub fn resolve(&self, own: &[Option<[f64; 3]>]) -> Vec<Option<[f64; 3]>> {
        let mut out: Vec<Option<[f64; 3]>> = own.to_vec();
        for &i in &self.order {
            if out[i].is_some() {
                continue;
            }
            let Some(ws) = &self.weights[i] else { continue };
            let (mut sum, mut total) = ([0.0f64; 3], 0.0f64);
            for &(j, w) in ws {
                if let Some(v) = out[j] {
                    for c in 0..3 {
                        sum[c] += w * v[c];
                    }
                    total += w;
                }
            }
            if total > 0.0 {
                out[i] = Some(sum.map(|s| s / total));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The nested grids of a `size` x `size` image of one flat surface: every pixel below the
    /// coarsest grid takes its bilinear parents.
    fn flat_grids(size: u32, coarsest: i32) -> Upsampling {
        let weights = (0..size * size)
            .map(|i| {
                let (x, y) = (i % size, i / size);
                let level = grid_level(x, y, coarsest);
                (level < coarsest)
                    .then(|| parents(x, y, level, size, size).into_iter().map(|(j, _, a)| (j, a)).collect())
            })
            .collect();
        let mut order: Vec<usize> = (0..(size * size) as usize).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(grid_level(i as u32 % size, i as u32 / size, coarsest)));
        Upsampling { width: size, height: size, coarsest, weights, order }
    }

    /// The summed squared coefficient with which each valued pixel reaches the image, by
    /// resolving one unit impulse at a time: the oracle for `influence`.
    fn influence_by_impulses(up: &Upsampling, has_value: &[bool]) -> Vec<f64> {
        (0..has_value.len())
            .map(|p| {
                if !has_value[p] {
                    return 1.0;
                }
                let own: Vec<Option<[f64; 3]>> = (0..has_value.len())
                    .map(|i| has_value[i].then_some([if i == p { 1.0 } else { 0.0 }, 0.0, 0.0]))
                    .collect();
                up.resolve(&own).iter().map(|v| v.map_or(0.0, |v| v[0] * v[0])).sum()
            })
            .collect()
    }

    #[test]
    fn influence_is_the_squared_weight_a_value_reaches_the_image_with() {
        let (size, coarsest) = (16u32, 4);
        let up = flat_grids(size, coarsest);
        let level = |i: usize| grid_level(i as u32 % size, i as u32 / size, coarsest);
        // Every child's parents are valued: no shared ancestors, the recursion is exact.
        let one_step: Vec<bool> = (0..(size * size) as usize).map(|i| level(i) >= 1).collect();
        let (fast, oracle) = (up.influence(&one_step), influence_by_impulses(&up, &one_step));
        for i in 0..fast.len() {
            assert!((fast[i] - oracle[i]).abs() < 1e-12, "pixel {i}: {} vs {}", fast[i], oracle[i]);
        }
        // A centre child of four parents passes each 1/16, an edge child of two 1/4: a parent
        // inside the image with its 8 level-0 neighbours (4 edge, 4 centre children) gets
        // 1 + 4/4 + 4/16 = 2.25.
        let inner = (6 * size + 6) as usize;
        assert!((fast[inner] - 2.25).abs() < 1e-12, "{}", fast[inner]);
        // Deeper chains: children share ancestors, whose cross terms the recursion leaves
        // out, so it stays at or below the oracle; still, each valued pixel stands for several.
        let deep: Vec<bool> = (0..(size * size) as usize).map(|i| level(i) >= 3).collect();
        let (fast, oracle) = (up.influence(&deep), influence_by_impulses(&up, &deep));
        for i in (0..fast.len()).filter(|&i| deep[i]) {
            assert!(fast[i] >= 1.0 && fast[i] <= oracle[i] + 1e-12, "pixel {i}: {} vs {}", fast[i], oracle[i]);
        }
        let valued: f64 = (0..fast.len()).filter(|&i| deep[i]).map(|i| fast[i]).sum();
        assert!(valued > deep.iter().filter(|&&d| d).count() as f64 * 4.0, "{valued}");
    }

    #[test]
    fn grid_levels_nest_and_parents_sit_on_the_next_grid() {
        assert_eq!(grid_level(0, 0, 5), 5);
        assert_eq!(grid_level(4, 8, 5), 2);
        assert_eq!(grid_level(3, 8, 5), 0);
        for (x, y) in [(2u32, 0u32), (0, 6), (6, 2), (5, 7), (12, 4)] {
            let level = grid_level(x, y, 4);
            // Inside a 32 x 32 image every parent exists.
            let ps = parents(x, y, level, 32, 32);
            assert!(!ps.is_empty());
            let alpha: f64 = ps.iter().map(|p| p.2).sum();
            assert!((alpha - 1.0).abs() < 1e-12, "({x}, {y})");
            for (j, offset, _) in ps {
                let (px, py) = (j as u32 % 32, j as u32 / 32);
                assert!(grid_level(px, py, 4) > level, "({x}, {y}) -> ({px}, {py})");
                // Offsets are half a parent spacing along each axis that moves.
                for a in offset {
                    assert!(a == 0.0 || a.abs() == 0.5);
                }
            }
        }
        // At the image's edge the parent outside is dropped.
        assert_eq!(parents(15, 0, 0, 16, 16).len(), 1);
    }
}

//! Two scales of the diffuse indirect filter: each pixel leans from the AAF-width filter towards
//! one of a fraction of its width as far as the wide filter's bias, read off the difference of
//! the two over the pixel's neighbourhood, outweighs the narrow one's noise (methods.md §5.3).
//!
//! The AAF widths (Mehta 2013 Eqs. 15-16) come from the neighbourhood's reflector distances and
//! are capped by a screen kernel; both are smooth over a surface, so next to a room's crease,
//! where the incident light falls off into the corner over a few pixels, the filter averages it
//! with the open surface and the crease comes out too bright. A second gather at `narrow_scale`
//! of each width, fitting a line through its taps in each pass (`narrow_linear`), has less of
//! that bias: a quarter of the mean's curvature term, and none of its slope term, which is what
//! a one-sided kernel beside a crease carries (the lobe weight shuts the other face out). It has
//! more variance, above all there, where the line extrapolates. The two frames differ by about
//! the wide one's bias plus the narrow one's noise; a bias is shared by a neighbourhood and
//! noise is not, so `blend::pooled_weights` reads it as the unfiltered mix does, with the
//! narrow frame in the unfiltered one's place: `W + a (N - W)`, a = b^2 / (b^2 + v_N). The
//! narrow frame's variance v_N is the pixel's sample variance of the mean times the frame's
//! noise power, the sum of its two passes' squared effective weights (`gather_with_power`): an
//! upper estimate, since it counts the direct light's noise too, which the two frames share and
//! their difference does not carry. A Gaussian's power in its place, blind to the cut kernels
//! and the fit's extrapolation, took the fit's noise for bias at creases and edges.
//!
//! The glossy light keeps one scale: its sample variance, drawn from a spiky lobe, misses its
//! tail at these counts, and narrowing it on that reading raised the error on `cornell-glossy`.
use super::blend;
use super::sample::PixelSums;
use crate::methods::lobe_aware::packed::PackedGuide;
use crate::pipeline::allocation::window;
use glam::Vec3;
use rayon::prelude::*;

/// A pixel's frame value with the diffuse indirect light filtered at the AAF width (`wide`) and
/// at `narrow_scale` of it (`narrow`), and its unfiltered value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Composed {
    pub wide: [f64; 3],
    pub narrow: [f64; 3],
    pub unfiltered: [f64; 3],
}

/// Per pixel, (frame value, unfiltered value): the wide value leaning towards the narrow one
/// where the neighbourhood shows the wide filter's bias (module docs). `narrow_sigma[p]` is the
/// narrow diffuse width in pixels and `narrow_power[p]` the narrow frame's noise power; pixels
/// with fewer than `from_spp(p)` samples, or a `narrow_sigma` of 0 (nothing filtered), keep the
/// wide value exactly.
pub(super) fn select(
    width: usize,
    composed: &[Composed],
    sums: &[PixelSums],
    narrow_sigma: &[f32],
    narrow_power: &[f32],
    from_spp: &(dyn Fn(usize) -> u32 + Sync),
) -> Vec<([f64; 3], [f64; 3])> {
    let variance: Vec<f64> =
        (sums.par_iter().zip(narrow_sigma).zip(narrow_power).enumerate())
            .map(|(p, ((s, &sigma), &power))| {
                if s.x_n >= from_spp(p).max(2) && sigma > 0.0 {
                    s.mean_variance() * power as f64
                } else {
                    f64::INFINITY
                }
            })
            .collect();
    let pairs: Vec<([f64; 3], [f64; 3])> = composed.par_iter().map(|c| (c.wide, c.narrow)).collect();
    let weights = blend::pooled_weights(width, &pairs, &variance);
    (composed.par_iter().zip(&weights)).map(|(c, &a)| (blend::mix(c.wide, c.narrow, a), c.unfiltered)).collect()
}

/// Per pixel, whether a valid guide within `radius` pixels (a square window) has a lobe axis
/// more than about 26 degrees (cosine 0.9) from the pixel's own: the pixels next to a change of
/// the surface normal, a room's creases and objects' edges, where the wide filter's bias lies.
pub(super) fn creases(guides: &[PackedGuide], width: usize, radius: usize) -> Vec<bool> {
    let height = guides.len() / width.max(1);
    (0..guides.len())
        .into_par_iter()
        .map(|p| {
            let g = &guides[p];
            let axis = Vec3::from(g.axis);
            g.is_valid()
                && window(width, height, p, radius).any(|q| {
                    let o = &guides[q];
                    o.is_valid() && axis.dot(Vec3::from(o.axis)) < 0.9
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pixel(n: u32, sd: f64) -> PixelSums {
        // Samples 1 +- sd alternately: sample variance sd^2 n/(n-1) per channel.
        let mut s = PixelSums::default();
        for i in 0..n {
            let x = if i % 2 == 0 { 1.0 + sd } else { 1.0 - sd };
            s.x_n += 1;
            for c in 0..3 {
                s.x[c] += x;
                s.x2[c] += x * x;
            }
        }
        s
    }

    /// A crease along row 4 where the wide filter is 0.3 too bright: the frame there takes the
    /// narrow value (up to the noise weight), and elsewhere, where the two differ by the narrow
    /// frame's noise alone, it keeps the wide one; with too few samples it keeps the wide value
    /// everywhere, bit for bit.
    #[test]
    fn the_narrow_scale_is_taken_where_the_wide_filter_is_biased_and_only_there() {
        let (w, h) = (8, 9);
        let sd = 0.5;
        let sums = vec![pixel(64, sd); w * h];
        let sigma = vec![1.5f32; w * h];
        let power = vec![0.05f32; w * h];
        let v = sums[0].mean_variance() * 0.05;
        // Off the crease, narrow - wide alternates +-sqrt(v) (noise at its own level).
        let composed: Vec<Composed> = (0..w * h)
            .map(|p| {
                let noise = if (p % w + p / w) % 2 == 0 { v.sqrt() } else { -v.sqrt() };
                let (wide, narrow) = if p / w == 4 { (1.3, 1.0) } else { (1.0, 1.0 + noise / 3f64.sqrt()) };
                Composed { wide: [wide; 3], narrow: [narrow; 3], unfiltered: [1.0; 3] }
            })
            .collect();
        let out = select(w, &composed, &sums, &sigma, &power, &|_| 32);
        let crease = out[4 * w + 3].0[0];
        assert!((crease - 1.0).abs() < 0.05, "crease {crease}");
        for p in (0..w * h).filter(|p| (p / w) < 2 || (p / w) > 6) {
            assert_eq!(out[p].0, composed[p].wide, "pixel {p} is noise only");
            assert_eq!(out[p].1, composed[p].unfiltered);
        }
        let early = select(w, &composed, &sums, &sigma, &power, &|_| 65);
        assert!(early.iter().zip(&composed).all(|(o, c)| o.0 == c.wide));
        let unfiltered = select(w, &composed, &sums, &vec![0.0; w * h], &power, &|_| 32);
        assert!(unfiltered.iter().zip(&composed).all(|(o, c)| o.0 == c.wide));
        // A threshold per pixel: only the crease's rows start early enough at 64 samples.
        let by_row = select(w, &composed, &sums, &sigma, &power, &|p| if (3..=5).contains(&(p / w)) { 32 } else { 65 });
        assert!((by_row[4 * w + 3].0[0] - 1.0).abs() < 0.05);
        assert!((0..w * h).filter(|p| !(3..=5).contains(&(p / w))).all(|p| by_row[p].0 == composed[p].wide));
    }

    /// A floor meeting a wall along row 5 (normals +y above, +z from row 5 on): the pixels
    /// within the radius of the change are creases, the others not; invalid guides (the sky)
    /// are never creases and mark none.
    #[test]
    fn creases_are_the_pixels_near_a_change_of_the_normal() {
        let (w, h) = (6, 10);
        let guide = |axis: [f32; 3]| PackedGuide { axis, sharpness: 1.0, ln_sharpness: 0.0, depth: 1.0, valid: 1.0 };
        let mut guides: Vec<PackedGuide> =
            (0..w * h).map(|p| if p / w < 5 { guide([0.0, 1.0, 0.0]) } else { guide([0.0, 0.0, 1.0]) }).collect();
        let c = creases(&guides, w, 2);
        for (p, &crease) in c.iter().enumerate() {
            assert_eq!(crease, (3..=6).contains(&(p / w)), "pixel {p}");
        }
        // 20 degrees apart: not a crease.
        let tilted = [0.0, 20f32.to_radians().cos(), 20f32.to_radians().sin()];
        let gentle: Vec<PackedGuide> =
            (0..w * h).map(|p| guide(if p / w < 5 { [0.0, 1.0, 0.0] } else { tilted })).collect();
        assert!(creases(&gentle, w, 2).iter().all(|&x| !x));
        // The wall's rows invalid: nothing is a crease.
        for g in &mut guides[5 * w..] {
            *g = PackedGuide::INVALID;
        }
        assert!(creases(&guides, w, 2).iter().all(|&x| !x));
    }
}

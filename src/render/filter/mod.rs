//! The screen-space filter of both AAF papers: a Gaussian gather per pixel with the centre
//! pixel's width beta over world distances, separable into a horizontal and a vertical 1-D pass
//! (Mehta et al. 2012, Eqs. 10-12 and Sec. 6; Mehta et al. 2013, Eq. 16 and Sec. 5). The
//! caller chooses the coordinates distances are measured in: the light plane for soft shadows
//! (2012 Eq. 12: offsets along the light normal do not count, third coordinate 0), the world
//! for indirect light. Neighbours whose normal differs too much (or, as an option, whose object
//! differs) are left out; the centre always counts with weight 1, so the weights never sum to
//! zero (methods.md §0.2). Blocks of pixels are filtered in parallel; the result does not
//! depend on the thread count. `gather` holds the vectorised passes and their memory layout.
mod gather;

use gather::Surface;
use glam::{DVec3, Vec3};

/// One pixel as the filter sees it, surface and kernel together: the one-shot form of
/// `separable` (strategies keep a `FilterSurface` and pass `FilterKernel`s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterPixel {
    /// Position in the coordinates distances are measured in (see the module comment).
    pub position: DVec3,
    pub normal: Vec3,
    pub object: u32,
    /// Whether this pixel has a value to contribute (a valid hit that receives this light).
    pub valid: bool,
    /// Filter width (std. dev., world units) when this pixel is a filtered centre; 0: kept.
    pub beta: f64,
    /// Projected pixel size, world units (sets the kernel radius in pixels).
    pub d: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterOptions {
    /// Neighbours whose normal is more than this angle from the centre's are left out (the
    /// paper's "check on normal variation"; 20 degrees as in the authors' code).
    pub max_normal_angle_deg: f32,
    /// Leave out neighbours of another object (optional in the paper, Sec. 6 footnote 7).
    pub object_id_check: bool,
    /// Kernel radius cap in pixels (the radius is ceil(3 beta / d) otherwise).
    pub max_radius: u32,
    /// Measure distances in the centre's tangent plane, |D|^2 - (D.n)^2, as the authors' AAF
    /// indirect code did; the papers use the plain distance.
    pub tangent_plane: bool,
}

impl Default for FilterOptions {
    fn default() -> Self {
        FilterOptions { max_normal_angle_deg: 20.0, object_id_check: true, max_radius: 32, tangent_plane: false }
    }
}

/// A pixel's filter as a centre: what changes from pass to pass (the surface does not).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilterKernel {
    /// Whether this pixel has a value to contribute (a valid hit that receives this light).
    pub valid: bool,
    /// Filter width (std. dev., world units) when this pixel is a filtered centre; 0: kept.
    pub beta: f64,
    /// Projected pixel size, world units (sets the kernel radius in pixels).
    pub d: f64,
}

impl FilterPixel {
    fn kernel(&self) -> FilterKernel {
        FilterKernel { valid: self.valid, beta: self.beta, d: self.d }
    }
}

/// Kernel radius in pixels, ceil(3 beta / d) capped; 0 for a pixel that is not filtered.
fn radius(k: &FilterKernel, o: &FilterOptions) -> u32 {
    if !(k.valid && k.beta > 0.0 && k.d > 0.0) {
        return 0;
    }
    ((3.0 * k.beta / k.d).ceil() as i64).clamp(1, o.max_radius as i64) as u32
}

/// The surface a filter gathers over: each pixel's position (in the coordinates distances
/// are measured in), normal and object. It depends only on the G-buffer, so a strategy builds
/// it once per render (once per light for soft shadows) and filters every pass and component
/// over it.
pub struct FilterSurface {
    len: usize,
    options: FilterOptions,
    surface: Surface,
}

impl FilterSurface {
    /// `point(p)` gives pixel p's (position, normal, object), row-major, `width` wide.
    pub fn new(
        len: usize,
        width: usize,
        options: &FilterOptions,
        point: impl Fn(usize) -> (DVec3, Vec3, u32) + Sync,
    ) -> Self {
        let height = len.checked_div(width).unwrap_or(0);
        FilterSurface { len, options: *options, surface: Surface::new(width, height, options, point) }
    }

    /// Filters `values` (one per pixel, row-major) in place with the separable filter and
    /// the pixels' `kernels`. Pixels that are not filtered centres keep their values (they
    /// still feed their neighbours if valid).
    pub fn filter(&self, kernels: &[FilterKernel], values: &mut [[f64; 3]]) {
        assert!(kernels.len() == self.len, "filter: one kernel per pixel");
        self.filter_by(|p| kernels[p], values);
    }

    /// `filter` with pixel p's kernel given by `kernel(p)`, so that no per-pixel list of
    /// kernels need be built (each is read once).
    pub fn filter_by(&self, kernel: impl Fn(usize) -> FilterKernel + Sync, values: &mut [[f64; 3]]) {
        assert!(values.len() == self.len, "filter: one value per pixel");
        self.surface.filter(kernel, values, &self.options);
    }
}

/// Weight of neighbour `j` for centre `c` (Eq. 11, unnormalised; the gather normalises) in
/// f64 with libm's exp: the reference that `gather` computes in f32 lanes.
#[cfg(test)]
fn weight(c: &FilterPixel, j: &FilterPixel, cos_min: f32, o: &FilterOptions) -> f64 {
    if !j.valid || c.normal.dot(j.normal) < cos_min || (o.object_id_check && c.object != j.object) {
        return 0.0;
    }
    let delta = c.position - j.position;
    let mut d2 = delta.length_squared();
    if o.tangent_plane {
        d2 = (d2 - delta.dot(c.normal.as_dvec3()).powi(2)).max(0.0);
    }
    let x = d2 / (2.0 * c.beta * c.beta);
    if x > gather::EXP_CUTOFF {
        0.0
    } else {
        (-x).exp()
    }
}

/// Filters `values` (row-major, `width` wide) in place with the separable filter: a
/// `FilterSurface` used once.
pub fn separable(pixels: &[FilterPixel], values: &mut [[f64; 3]], width: usize, o: &FilterOptions) {
    let surface =
        FilterSurface::new(pixels.len(), width, o, |i| (pixels[i].position, pixels[i].normal, pixels[i].object));
    let kernels: Vec<FilterKernel> = pixels.iter().map(FilterPixel::kernel).collect();
    surface.filter(&kernels, values);
}

/// The same filter as a full 2-D gather over the square window: the test oracle the separable
/// form approximates (exact where beta is constant and nothing is rejected).
#[cfg(test)]
fn full_2d(pixels: &[FilterPixel], values: &[[f64; 3]], width: usize, o: &FilterOptions) -> Vec<[f64; 3]> {
    let height = pixels.len().checked_div(width).unwrap_or(0);
    let cos_min = o.max_normal_angle_deg.to_radians().cos();
    let mut out = values.to_vec();
    for y in 0..height as i64 {
        for x in 0..width as i64 {
            let i = (y * width as i64 + x) as usize;
            let c = &pixels[i];
            let r = radius(&c.kernel(), o) as i64;
            if r == 0 {
                continue;
            }
            let (mut sum, mut wsum) = ([0.0; 3], 0.0);
            for ny in (y - r).max(0)..=(y + r).min(height as i64 - 1) {
                for nx in (x - r).max(0)..=(x + r).min(width as i64 - 1) {
                    let j = (ny * width as i64 + nx) as usize;
                    let w = if i == j { 1.0 } else { weight(c, &pixels[j], cos_min, o) };
                    for ch in 0..3 {
                        sum[ch] += w * values[j][ch];
                    }
                    wsum += w;
                }
            }
            out[i] = sum.map(|s| s / wsum);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plane parallel to the light, seen so that pixel (x, y) sits at (x, y) * spacing in the
    /// light plane: the world grid is aligned with the light axes (methods.md §1.6).
    fn plane(w: usize, h: usize, spacing: f64, beta_px: f64) -> Vec<FilterPixel> {
        (0..w * h)
            .map(|i| FilterPixel {
                position: DVec3::new((i % w) as f64, (i / w) as f64, 0.0) * spacing,
                normal: Vec3::Z,
                object: 0,
                valid: true,
                beta: beta_px * spacing,
                d: spacing,
            })
            .collect()
    }

    fn noise(n: usize) -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| {
                let h = crate::render::sampler::mix64(i as u64);
                [
                    (h & 0xffff) as f64 / 65535.0,
                    ((h >> 16) & 0xffff) as f64 / 65535.0,
                    ((h >> 32) & 0xffff) as f64 / 65535.0,
                ]
            })
            .collect()
    }

    #[test]
    fn separable_equals_2d_for_constant_beta() {
        // The second image is not square, has radius 6 and more taps than a block of lanes,
        // and rows that end mid-block: an index mix-up or a padding lane would show there.
        for (w, h, beta_px) in [(23, 17, 1.7), (75, 41, 2.0)] {
            let px = plane(w, h, 0.01, beta_px);
            let v = noise(w * h);
            let mut sep = v.clone();
            separable(&px, &mut sep, w, &FilterOptions::default());
            let full = full_2d(&px, &v, w, &FilterOptions::default());
            // Away from the border (where the window is clipped differently), to the f32
            // weights' precision (about 1e-7 relative).
            for y in 6..h - 6 {
                for x in 6..w - 6 {
                    let i = y * w + x;
                    for c in 0..3 {
                        assert!(
                            (sep[i][c] - full[i][c]).abs() < 1e-6,
                            "{w}x{h} ({x},{y}): {} vs {}",
                            sep[i][c],
                            full[i][c]
                        );
                    }
                }
            }
        }
    }

    /// The separable filter written out in f64, pixel by pixel: a horizontal gather with each
    /// pixel's own kernel, then a vertical gather of its results with the centre's kernel
    /// (Mehta et al. 2012, Sec. 6), the centre counted with weight 1 in both.
    fn two_pass_reference(pixels: &[FilterPixel], values: &[[f64; 3]], w: usize, o: &FilterOptions) -> Vec<[f64; 3]> {
        let h = pixels.len() / w;
        let cos_min = o.max_normal_angle_deg.to_radians().cos();
        let pass = |input: &[[f64; 3]], horizontal: bool| -> Vec<[f64; 3]> {
            (0..w * h)
                .map(|i| {
                    let r = radius(&pixels[i].kernel(), o) as i64;
                    if r == 0 {
                        return input[i];
                    }
                    let (x, y) = ((i % w) as i64, (i / w) as i64);
                    let (mut sum, mut wsum) = ([0.0; 3], 0.0);
                    for t in -r..=r {
                        let (nx, ny) = if horizontal { (x + t, y) } else { (x, y + t) };
                        if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                            continue;
                        }
                        let j = (ny * w as i64 + nx) as usize;
                        let wt = if j == i { 1.0 } else { weight(&pixels[i], &pixels[j], cos_min, o) };
                        for c in 0..3 {
                            sum[c] += wt * input[j][c];
                        }
                        wsum += wt;
                    }
                    sum.map(|s| s / wsum)
                })
                .collect()
        };
        pass(&pass(values, true), false)
    }

    #[test]
    fn separable_equals_its_two_pass_definition_with_varying_kernels() {
        // Widths that end mid-block, radii from 1 to 9 that change from pixel to pixel,
        // invalid pixels, other normals and objects, a bumpy surface, both distance measures.
        for (w, h) in [(29, 14), (8, 9), (3, 20)] {
            for tangent_plane in [false, true] {
                let o = FilterOptions { tangent_plane, ..FilterOptions::default() };
                let mut px = plane(w, h, 0.1, 1.0);
                for (i, p) in px.iter_mut().enumerate() {
                    p.beta = 0.1 * (0.3 + (i * 7 % 10) as f64 * 0.3);
                    p.valid = i % 9 != 4;
                    p.position.z = ((i % w) as f64 * 0.7).sin() * 0.03;
                    if i % 23 == 0 {
                        p.normal = Vec3::new(0.0, 0.6, 0.8);
                    }
                    p.object = (i % 31 == 0) as u32;
                }
                let v = noise(w * h);
                let mut sep = v.clone();
                separable(&px, &mut sep, w, &o);
                let reference = two_pass_reference(&px, &v, w, &o);
                for (i, (a, b)) in sep.iter().zip(&reference).enumerate() {
                    for c in 0..3 {
                        assert!(
                            (a[c] - b[c]).abs() < 1e-6,
                            "{w}x{h} tangent {tangent_plane} pixel {i}: {a:?} vs {b:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn constant_image_stays_constant() {
        let (w, h) = (19, 11);
        let mut px = plane(w, h, 0.5, 3.0);
        // Vary beta, validity and normals: partition of unity must hold regardless.
        for (i, p) in px.iter_mut().enumerate() {
            p.beta *= 0.2 + (i % 7) as f64;
            p.valid = i % 13 != 0;
            if i % 5 == 0 {
                p.normal = Vec3::X;
            }
        }
        let mut v = vec![[0.25, 1.0, 3.0]; w * h];
        separable(&px, &mut v, w, &FilterOptions { object_id_check: true, ..FilterOptions::default() });
        for x in &v {
            for (c, e) in x.iter().zip([0.25, 1.0, 3.0]) {
                assert!((c - e).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn unfiltered_and_tiny_beta_pixels_keep_their_values() {
        let (w, h) = (9, 9);
        let mut px = plane(w, h, 1.0, 0.0);
        let v = noise(w * h);
        let mut out = v.clone();
        separable(&px, &mut out, w, &FilterOptions::default());
        assert_eq!(out, v);
        // beta = 0.2 px: neighbour weights exp(-12.5) ~ 4e-6.
        for p in &mut px {
            p.beta = 0.2;
        }
        let mut out = v.clone();
        separable(&px, &mut out, w, &FilterOptions::default());
        for (a, b) in out.iter().zip(&v) {
            assert!((a[0] - b[0]).abs() < 1e-4);
        }
    }

    #[test]
    fn rejected_neighbours_do_not_leak_across_edges() {
        let (w, h) = (12, 3);
        let mut px = plane(w, h, 1.0, 4.0);
        let mut v = vec![[0.0; 3]; w * h];
        for (i, p) in px.iter_mut().enumerate() {
            if i % w >= 6 {
                p.normal = Vec3::Y; // a wall at right angles
                v[i] = [1.0; 3];
            }
        }
        separable(&px, &mut v, w, &FilterOptions::default());
        for (i, x) in v.iter().enumerate() {
            assert_eq!(x[0], if i % w >= 6 { 1.0 } else { 0.0 });
        }
    }

    #[test]
    fn distance_along_the_light_normal_does_not_count() {
        // Two pixels with the same light-plane coordinates are full neighbours whatever their
        // depth below the light: the filter only sees plane coordinates (Eq. 12).
        let a = FilterPixel { position: DVec3::ZERO, normal: Vec3::Z, object: 0, valid: true, beta: 1.0, d: 1.0 };
        let o = FilterOptions::default();
        assert_eq!(weight(&a, &a, 0.9, &o), 1.0);
        // The tangent-plane option drops the offset along the centre's normal.
        let b = FilterPixel { position: DVec3::new(0.0, 0.0, 5.0), ..a };
        assert!(weight(&a, &b, 0.9, &o) < 1e-5);
        assert_eq!(weight(&a, &b, 0.9, &FilterOptions { tangent_plane: true, ..o }), 1.0);
    }
}

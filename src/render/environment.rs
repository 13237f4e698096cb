//! The environment light: radiance arriving from infinitely far away in every direction, from a
//! constant colour or an equirectangular (latitude-longitude) map. Camera rays and shadow-free
//! escaping rays see it; direct light from it is sampled in proportion to the map's luminance
//! times sin(theta) and combined with BRDF sampling by multiple importance sampling
//! (`integrator::environment_direct`).
//!
//! The map's frame and texel layout follow Mitsuba 3's `envmap` (so that the same file lights
//! the same scene the same way in both): +Y is the zenith (the top row, v = 0), u runs from
//! the -Z direction (u = 0) towards +X (u = 1/4), and the first and last rows lie on the poles
//! (`LatLongMap`). A light's `to_map` rotation takes world directions into that frame.
use super::distribution::{prefetch, Distribution2D};
use super::material::luminance;
use glam::{Mat3, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

/// An equirectangular map of RGB radiance, rows from the zenith to the nadir. As in Mitsuba 3,
/// columns are centred in their spans of longitude (texel x at u = (x + 1/2) / width, wrapping
/// around) while rows run from pole to pole (texel y at v = y / (height - 1): the first row is
/// the zenith itself, the last the nadir); radiance between texels is bilinear.
#[derive(Clone, Debug, PartialEq)]
pub struct LatLongMap {
    width: usize,
    height: usize,
    texels: Vec<Vec3>,
    /// Over (u, v) in [0, 1)^2, `width` columns centred on the texels' columns by `bands`
    /// rows, each row the band between two texel rows (where radiance blends just those
    /// two): each cell's mean bilinear luminance times sin(theta) at its centre.
    distribution: Distribution2D,
}

impl LatLongMap {
    /// A map from row-major texels (`height` rows of `width`). Negative and non-finite
    /// values must have been refused or cleaned by the caller; negative ones are read as 0.
    pub fn new(width: usize, height: usize, texels: Vec<Vec3>) -> Self {
        assert!(width > 0 && height > 0 && texels.len() == width * height, "a {width} x {height} map");
        let texels: Vec<Vec3> = texels.into_iter().map(|t| t.max(Vec3::ZERO)).collect();
        let mut map = LatLongMap { width, height, texels, distribution: Distribution2D::new(&[1.0], 1, 1) };
        map.distribution = Distribution2D::new(&map.importance(), width, map.bands());
        map
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    pub fn texel(&self, x: usize, y: usize) -> Vec3 {
        self.texels[y * self.width + x]
    }

    /// Rows of the sampling table: the bands between texel rows (one for a one-row map).
    fn bands(&self) -> usize {
        (self.height - 1).max(1)
    }

    /// The (u, v) of texel (x, y)'s centre.
    pub fn texel_uv(&self, x: usize, y: usize) -> [f32; 2] {
        let v = if self.height > 1 { y as f32 / (self.height - 1) as f32 } else { 0.5 };
        [(x as f32 + 0.5) / self.width as f32, v]
    }

    /// The solid angle texel (x, y) stands for: its share of longitude times the band of
    /// latitude halfway to the neighbouring rows (half a band at the poles).
    pub fn texel_solid_angle(&self, y: usize) -> f32 {
        let dphi = 2.0 * PI / self.width as f32;
        if self.height == 1 {
            return dphi * 2.0;
        }
        let step = PI / (self.height - 1) as f32;
        let theta = y as f32 * step;
        let (lo, hi) = ((theta - 0.5 * step).max(0.0), (theta + 0.5 * step).min(PI));
        dphi * (lo.cos() - hi.cos())
    }

    /// The table the directions are drawn from. Radiance between texels is bilinear, so a
    /// cell can be lit while the texel it is centred on is black (a neighbour's light reaches
    /// into it): each cell is weighted by the mean of the bilinear luminance at four points
    /// inside it, which is positive wherever the radiance is anywhere in the cell (a
    /// neighbour's weight is positive at both points on its side), so the estimate stays
    /// unbiased. sin(theta) turns density over (u, v) into density over solid angle without
    /// favouring the poles.
    fn importance(&self) -> Vec<f32> {
        let (w, bands) = (self.width as f32, self.bands() as f32);
        let mut table = Vec::with_capacity(self.width * self.bands());
        for y in 0..self.bands() {
            let sin_theta = (PI * (y as f32 + 0.5) / bands).sin();
            for x in 0..self.width {
                let mut sum = 0.0;
                for (dx, dy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                    sum += luminance(self.lookup([(x as f32 + dx) / w, (y as f32 + dy) / bands]));
                }
                table.push(0.25 * sum * sin_theta);
            }
        }
        table
    }

    /// Bilinear radiance at (u, v): wrapping around in u, from pole to pole in v.
    #[inline]
    pub fn lookup(&self, uv: [f32; 2]) -> Vec3 {
        let x = uv[0] * self.width as f32 - 0.5;
        let y = (uv[1] * (self.height - 1) as f32).clamp(0.0, (self.height - 1) as f32);
        // floor() is a libm call on baseline x86-64 and rem_euclid a division; both are kept
        // off the common path (an interior texel), with the same results.
        let truncated = x as i64 as f32;
        let x0 = if truncated > x { truncated - 1.0 } else { truncated };
        let y0 = y as usize as f32; // y >= 0: truncation is floor
        let (fx, fy) = (x - x0, y - y0);
        let (w, i0) = (self.width as i64, x0 as i64);
        let (c0, c1) = if i0 >= 0 && i0 + 1 < w {
            (i0 as usize, i0 as usize + 1)
        } else {
            (i0.rem_euclid(w) as usize, (i0 + 1).rem_euclid(w) as usize)
        };
        let r0 = y0 as usize;
        let r1 = (r0 + 1).min(self.height - 1);
        let at = |r: usize, c: usize| self.texels[r * self.width + c];
        (at(r0, c0) * (1.0 - fx) + at(r0, c1) * fx) * (1.0 - fy) + (at(r1, c0) * (1.0 - fx) + at(r1, c1) * fx) * fy
    }

    /// Asks for the texels `lookup(uv)` reads (the start of each of its two rows' pairs), for
    /// a lookup soon after.
    #[inline]
    pub fn prefetch(&self, uv: [f32; 2]) {
        let x = ((uv[0] * self.width as f32 - 0.5).max(0.0) as usize).min(self.width - 1);
        let r0 = ((uv[1] * (self.height - 1) as f32).max(0.0) as usize).min(self.height - 1);
        let r1 = (r0 + 1).min(self.height - 1);
        prefetch(&self.texels[r0 * self.width + x]);
        prefetch(&self.texels[r1 * self.width + x]);
    }

    /// The mean radiance over the sphere (each texel weighted by its solid angle).
    pub fn mean_radiance(&self) -> Vec3 {
        let mut sum = Vec3::ZERO;
        let mut weight = 0.0;
        for y in 0..self.height {
            let omega = self.texel_solid_angle(y);
            for x in 0..self.width {
                sum += self.texel(x, y) * omega;
            }
            weight += omega * self.width as f32;
        }
        sum / weight
    }
}

/// Where an environment light's radiance comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentRadiance {
    Constant(Vec3),
    /// Shared: scene edits and copies of the scene do not copy the texels.
    Map(Arc<LatLongMap>),
}

#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentLight {
    pub radiance: EnvironmentRadiance,
    /// Multiplies the radiance.
    pub scale: f32,
    /// World directions into the map's frame (a rotation).
    pub to_map: Mat3,
}

/// A direction drawn towards the environment: the direction, the radiance arriving from it and
/// its density over solid angle.
#[derive(Clone, Copy, Debug)]
pub struct EnvironmentSample {
    pub wi: Vec3,
    pub radiance: Vec3,
    pub pdf: f32,
}

impl EnvironmentLight {
    /// A light with the map's zenith along `up` (world) and the map turned by `rotation_deg`
    /// about it (positive: counter-clockwise seen from above). `up` must be non-zero.
    pub fn new(radiance: EnvironmentRadiance, scale: f32, up: Vec3, rotation_deg: f32) -> Self {
        EnvironmentLight { radiance, scale, to_map: to_map_frame(up, rotation_deg) }
    }

    /// Radiance arriving from world direction `w` (unit; pointing away from the receiver).
    #[inline]
    pub fn radiance(&self, w: Vec3) -> Vec3 {
        match &self.radiance {
            EnvironmentRadiance::Constant(c) => *c * self.scale,
            EnvironmentRadiance::Map(m) => m.lookup(direction_to_uv(self.to_map * w)) * self.scale,
        }
    }

    /// Draws a direction for `u` in [0, 1)^2: uniformly over the sphere for a constant
    /// colour; for a map, in proportion to its luminance times sin(theta). None for a black
    /// light (nothing to sample).
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> Option<EnvironmentSample> {
        match &self.radiance {
            EnvironmentRadiance::Constant(c) => {
                let radiance = *c * self.scale;
                if radiance == Vec3::ZERO {
                    return None;
                }
                let z = 1.0 - 2.0 * u[0];
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * PI * u[1];
                Some(EnvironmentSample { wi: Vec3::new(r * phi.cos(), r * phi.sin(), z), radiance, pdf: 0.25 / PI })
            }
            EnvironmentRadiance::Map(m) => {
                if !(m.distribution.integral() > 0.0) || self.scale == 0.0 {
                    return None;
                }
                let (uv, pdf_uv) = m.distribution.sample(u);
                self.drawn_from(m, uv, pdf_uv)
            }
        }
    }

    /// The sample of map `m` (this light's) at the point `uv` its distribution drew with
    /// density `pdf_uv` over (u, v).
    #[inline]
    fn drawn_from(&self, m: &LatLongMap, uv: [f32; 2], pdf_uv: f32) -> Option<EnvironmentSample> {
        let (local, sin_theta) = uv_to_direction(uv);
        if !(sin_theta > 0.0 && pdf_uv > 0.0) {
            return None;
        }
        let pdf = pdf_uv / (2.0 * PI * PI * sin_theta);
        let wi = self.to_map.transpose() * local;
        let radiance = m.lookup(uv) * self.scale;
        pdf.is_finite().then_some(EnvironmentSample { wi, radiance, pdf })
    }

    /// `sample` of each of `us`: the same numbers, with the lanes' memory reads (the
    /// distribution's rows, then the texels) issued together, so that on a large map their
    /// cache misses overlap.
    #[inline]
    pub fn sample_many<const N: usize>(&self, us: &[[f32; 2]; N]) -> [Option<EnvironmentSample>; N] {
        let EnvironmentRadiance::Map(m) = &self.radiance else {
            return us.map(|u| self.sample(u));
        };
        if !(m.distribution.integral() > 0.0) || self.scale == 0.0 {
            return [None; N];
        }
        let drawn = m.distribution.sample_many(us);
        for (uv, _) in &drawn {
            m.prefetch(*uv);
        }
        drawn.map(|(uv, pdf_uv)| self.drawn_from(m, uv, pdf_uv))
    }

    /// `radiance_and_pdf` of each direction of `ws` (None: nothing asked, (0, 0) given): the
    /// same numbers, the lanes' texels and distribution cells asked for together first.
    #[inline]
    pub fn radiance_and_pdf_many<const N: usize>(&self, ws: &[Option<Vec3>; N]) -> [(Vec3, f32); N] {
        let EnvironmentRadiance::Map(m) = &self.radiance else {
            return ws.map(|w| w.map_or((Vec3::ZERO, 0.0), |w| self.radiance_and_pdf(w)));
        };
        let at = ws.map(|w| {
            w.map(|w| {
                let local = self.to_map * w;
                let uv = direction_to_uv(local);
                m.prefetch(uv);
                m.distribution.prefetch_pdf(uv);
                (local, uv)
            })
        });
        at.map(|a| a.map_or((Vec3::ZERO, 0.0), |(local, uv)| self.map_radiance_and_pdf(m, local, uv)))
    }

    /// `(radiance(w), pdf(w))`, the direction turned into the map's coordinates once: the
    /// same numbers as the two calls.
    #[inline]
    pub fn radiance_and_pdf(&self, w: Vec3) -> (Vec3, f32) {
        match &self.radiance {
            EnvironmentRadiance::Constant(_) => (self.radiance(w), self.pdf(w)),
            EnvironmentRadiance::Map(m) => {
                let local = self.to_map * w;
                self.map_radiance_and_pdf(m, local, direction_to_uv(local))
            }
        }
    }

    /// `radiance_and_pdf` on map `m` (this light's) of the map-frame direction `local`, whose
    /// (u, v) is `uv`.
    #[inline]
    fn map_radiance_and_pdf(&self, m: &LatLongMap, local: Vec3, uv: [f32; 2]) -> (Vec3, f32) {
        let radiance = m.lookup(uv) * self.scale;
        if !(m.distribution.integral() > 0.0) || self.scale == 0.0 {
            return (radiance, 0.0);
        }
        let sin_theta = (1.0 - local.y * local.y).max(0.0).sqrt();
        if sin_theta <= 0.0 {
            return (radiance, 0.0);
        }
        (radiance, m.distribution.pdf(uv) / (2.0 * PI * PI * sin_theta))
    }

    /// The density over solid angle with which `sample` draws world direction `w`.
    #[inline]
    pub fn pdf(&self, w: Vec3) -> f32 {
        match &self.radiance {
            EnvironmentRadiance::Constant(c) => {
                if *c * self.scale == Vec3::ZERO {
                    0.0
                } else {
                    0.25 / PI
                }
            }
            EnvironmentRadiance::Map(m) => {
                if !(m.distribution.integral() > 0.0) || self.scale == 0.0 {
                    return 0.0;
                }
                let local = self.to_map * w;
                let sin_theta = (1.0 - local.y * local.y).max(0.0).sqrt();
                if sin_theta <= 0.0 {
                    return 0.0;
                }
                m.distribution.pdf(direction_to_uv(local)) / (2.0 * PI * PI * sin_theta)
            }
        }
    }
}

/// The rotation taking world directions into the map frame: `up` to +Y, then a turn of
/// `rotation_deg` about it.
fn to_map_frame(up: Vec3, rotation_deg: f32) -> Mat3 {
    let up = up.normalize();
    let align = glam::Quat::from_rotation_arc(up, Vec3::Y);
    let turn = glam::Quat::from_rotation_y(-rotation_deg.to_radians());
    Mat3::from_quat(turn * align)
}

/// Map-frame direction to (u, v) (Mitsuba 3's `envmap`: u = atan2(x, -z) / 2 pi wrapped into
/// [0, 1), v = acos(y) / pi).
#[inline]
pub fn direction_to_uv(d: Vec3) -> [f32; 2] {
    let u = d.x.atan2(-d.z) * (0.5 / PI);
    let u = if u < 0.0 { u + 1.0 } else { u };
    let v = d.y.clamp(-1.0, 1.0).acos() / PI;
    [u.min(1.0 - f32::EPSILON / 2.0), v.min(1.0 - f32::EPSILON / 2.0)]
}

/// (u, v) to the map-frame direction and its sin(theta).
#[inline]
pub fn uv_to_direction(uv: [f32; 2]) -> (Vec3, f32) {
    let (phi, theta) = (2.0 * PI * uv[0], PI * uv[1]);
    let (sin_t, cos_t) = theta.sin_cos();
    let (sin_p, cos_p) = phi.sin_cos();
    (Vec3::new(sin_t * sin_p, cos_t, -sin_t * cos_p), sin_t)
}

#[cfg(test)]
mod tests;

//! Lights: one-sided rectangular area lights (uniform or Gaussian emission), point lights and
//! the environment (`environment`). A Gaussian rectangle's importance sampling is in `profile`,
//! the unshadowed irradiance of a rect light (closed form or quadrature) in `irradiance`.
pub use super::environment::EnvironmentLight;
use super::far_rule::FarRule;
use glam::Vec3;
use irradiance::{gaussian_rule, truncated_normal_variance};
use profile::ProfileSampler;

mod irradiance;
mod profile;
#[cfg(test)]
mod tests;

pub use irradiance::polygon_irradiance;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmissionProfile {
    Uniform,
    /// Radiance falls off as exp(-|y - c|^2 / (2 sigma^2)) over the rectangle: the Gaussian
    /// light of Mehta et al. 2012 (Sec. 4). sigma is sqrt(area)/2 unless given (the authors'
    /// code, methods.md §1.1: a square then ends at one sigma); samples follow the
    /// profile (`ProfileSampler`).
    Gaussian,
}

#[derive(Clone, Debug, PartialEq)]
pub struct RectLight {
    pub corner: Vec3,
    pub edge_u: Vec3,
    pub edge_v: Vec3,
    /// Unit normal, edge_u x edge_v: the side it emits towards.
    pub normal: Vec3,
    pub area: f32,
    /// Radiance at the centre.
    pub radiance: Vec3,
    pub profile: EmissionProfile,
    /// Standard deviation of the Gaussian profile (scene units).
    sigma: f32,
    /// Gaussian lights: the nodes of an 8 x 8 Gauss-Legendre rule over the rectangle with their
    /// weights (area and profile folded in), for the irradiance of distant receivers.
    gauss_rule: FarRule,
    /// Gaussian rectangles: where to place light samples so that their density follows the
    /// profile (`ProfileSampler`); None for uniform lights and skewed parallelograms, which
    /// are sampled uniformly by area.
    profile_sampler: Option<Box<ProfileSampler>>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    pub intensity: Vec3,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    Rect(RectLight),
    Point(PointLight),
    /// Light from infinitely far away: at most one per scene (`scene::compile` checks).
    Environment(EnvironmentLight),
}

/// A light sample as seen from a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point to the light point.
    pub wi: Vec3,
    pub dist: f32,
    /// The light point (for the shadow ray).
    pub point: Vec3,
    /// Incident radiance divided by the density, per unit solid angle measure already folded in:
    /// the direct-light estimate is `f(wo, wi) * cos_x * weight`.
    pub weight: Vec3,
    /// The density of `wi` per unit solid angle at the shading point (infinite for a point
    /// light, which no other strategy can find): what multiple importance sampling weighs.
    pub pdf: f32,
}

/// Where a ray from a shading point meets a rectangular light's emitting side.
#[derive(Clone, Copy, Debug)]
pub struct LightHit {
    /// The light point (for the shadow ray).
    pub point: Vec3,
    /// Radiance leaving that point towards the shading point.
    pub radiance: Vec3,
    /// The density per unit solid angle with which `RectLight::sample` draws this direction.
    pub pdf: f32,
}

impl RectLight {
    pub fn new(corner: Vec3, edge_u: Vec3, edge_v: Vec3, radiance: Vec3, profile: EmissionProfile) -> Self {
        let sigma = edge_u.cross(edge_v).length().sqrt() * 0.5;
        RectLight::with_sigma(corner, edge_u, edge_v, radiance, profile, sigma)
    }

    /// A Gaussian light of standard deviation `sigma` (scene units) over this rectangle, which
    /// then holds its tails: a square of side 6 sigma spans +-3 sigma, whose edges emit 1% of
    /// the centre, the Gaussian light the paper's analysis assumes (Omega_L = 1/sigma). `new`
    /// takes sigma = sqrt(area)/2 instead, as the authors' code does: that rectangle spans
    /// +-1 sigma and its edges still emit 61% of the centre, close to a uniform light.
    /// Callers validate `sigma` (positive, finite; `scene::compile` also bounds the span).
    pub fn gaussian(corner: Vec3, edge_u: Vec3, edge_v: Vec3, radiance: Vec3, sigma: f32) -> Self {
        RectLight::with_sigma(corner, edge_u, edge_v, radiance, EmissionProfile::Gaussian, sigma)
    }

    /// The same light moved to `corner` and scaled by `scale` (its profile with it).
    /// The profile's sampling tables depend only on the edges over sigma, which scaling keeps,
    /// so they are shared rather than built again; the far-field rule's nodes move with it.
    pub fn rescaled(&self, corner: Vec3, scale: f32) -> Self {
        let (u, v) = (self.edge_u * scale, self.edge_v * scale);
        let mut light = RectLight::plain(corner, u, v, self.radiance, self.profile, self.sigma * scale);
        light.profile_sampler = self.profile_sampler.clone();
        light.gauss_rule = light.far_rule();
        light
    }

    /// The constructor (`rescaled` aside): the Gaussian tables are built once, for the final
    /// sigma.
    fn with_sigma(
        corner: Vec3,
        edge_u: Vec3,
        edge_v: Vec3,
        radiance: Vec3,
        profile: EmissionProfile,
        sigma: f32,
    ) -> Self {
        let mut light = RectLight::plain(corner, edge_u, edge_v, radiance, profile, sigma);
        if light.separable_gaussian() {
            let (len_u, len_v) = (edge_u.length() as f64, edge_v.length() as f64);
            light.profile_sampler = Some(Box::new(ProfileSampler::new(len_u, len_v, sigma as f64)));
        }
        light.gauss_rule = light.far_rule();
        light
    }

    /// The light without its Gaussian tables.
    fn plain(corner: Vec3, edge_u: Vec3, edge_v: Vec3, radiance: Vec3, profile: EmissionProfile, sigma: f32) -> Self {
        let c = edge_u.cross(edge_v);
        RectLight {
            corner,
            edge_u,
            edge_v,
            normal: c.normalize_or_zero(),
            area: c.length(),
            radiance,
            profile,
            sigma,
            gauss_rule: FarRule::default(),
            profile_sampler: None,
        }
    }

    /// A Gaussian profile over a rectangle, not a skewed parallelogram: the profile is then
    /// separable, which the far-field rule (`far_gaussian_irradiance`, `gaussian_rule`) and the
    /// importance sampler (`ProfileSampler`) need.
    fn separable_gaussian(&self) -> bool {
        let orthogonal = self.edge_u.dot(self.edge_v).abs() <= 1e-4 * self.edge_u.length() * self.edge_v.length();
        self.profile == EmissionProfile::Gaussian && orthogonal
    }

    /// The far-field rule of a separable Gaussian light (empty otherwise).
    fn far_rule(&self) -> FarRule {
        if !self.separable_gaussian() {
            return FarRule::default();
        }
        let (c, u, v) = (self.center().as_dvec3(), self.edge_u.as_dvec3(), self.edge_v.as_dvec3());
        FarRule::new(&gaussian_rule(c, u, v, self.sigma as f64))
    }

    pub fn center(&self) -> Vec3 {
        self.corner + 0.5 * (self.edge_u + self.edge_v)
    }

    /// Standard deviation of the Gaussian profile: sqrt(area)/2 (methods.md §1.1) unless the
    /// light was made by `gaussian`.
    pub fn sigma(&self) -> f32 {
        self.sigma
    }

    /// Standard deviation of the emitted power across the light, in scene units, along the
    /// narrower of its two directions: the spread of the light that the soft-shadow analysis
    /// models as a Gaussian of standard deviation sigma (Mehta et al. 2012, Sec. 4).
    /// - A Gaussian profile cut off by the rectangle has a smaller spread than its sigma: at
    ///   the authors' +-1 sigma, 0.54 sigma (`truncated_normal_variance`); at +-3 sigma,
    ///   0.987 sigma.
    /// - A uniform light of width w has w / sqrt(12).
    ///
    /// Each direction is the in-plane normal of the other edge, across which the light's
    /// extent is its height area / |other edge| (the edge itself for a rectangle; for a skewed
    /// parallelogram the profile's marginal there is only close to a truncated Gaussian).
    pub fn emission_std(&self) -> f32 {
        let (lu, lv) = (self.edge_u.length() as f64, self.edge_v.length() as f64);
        if !(lu > 0.0 && lv > 0.0 && self.area > 0.0) {
            return 0.0;
        }
        let area = self.area as f64;
        let narrow_half = 0.5 * (area / lv).min(area / lu);
        let std = match self.profile {
            EmissionProfile::Uniform => narrow_half / 3f64.sqrt(),
            EmissionProfile::Gaussian => {
                let sigma = self.sigma as f64;
                sigma * truncated_normal_variance(narrow_half / sigma).sqrt()
            }
        };
        std as f32
    }

    /// Relative emission at light point `y` (1 at the centre; 1 everywhere when uniform).
    #[inline]
    pub fn profile_weight(&self, y: Vec3) -> f32 {
        match self.profile {
            EmissionProfile::Uniform => 1.0,
            EmissionProfile::Gaussian => {
                let s = self.sigma();
                (-(y - self.center()).length_squared() / (2.0 * s * s)).exp()
            }
        }
    }

    /// Radiance leaving light point `y` in direction `w` (zero behind the light).
    #[inline]
    pub fn emitted(&self, y: Vec3, w: Vec3) -> Vec3 {
        if self.normal.dot(w) <= 0.0 {
            Vec3::ZERO
        } else {
            self.radiance * self.profile_weight(y)
        }
    }

    /// The light point at stratified coordinates `u` in [0,1)^2.
    #[inline]
    pub fn point(&self, u: [f32; 2]) -> Vec3 {
        self.corner + u[0] * self.edge_u + u[1] * self.edge_v
    }

    /// The light point for `u` in [0,1)^2 and the reciprocal of its density by area: uniform
    /// by area, or following a Gaussian rectangle's profile (`ProfileSampler`). Monotone in
    /// each coordinate, so stratified `u` give stratified points.
    #[inline]
    pub fn place(&self, u: [f32; 2]) -> (Vec3, f32) {
        match &self.profile_sampler {
            None => (self.point(u), self.area),
            Some(p) => {
                let (a, ra) = p.u.place(u[0]);
                let (b, rb) = p.v.place(u[1]);
                (self.corner + a * self.edge_u + b * self.edge_v, self.area * (ra * rb))
            }
        }
    }

    /// Samples a point by `place`: weight = Le cos_L / dist^2 / density.
    #[inline]
    pub fn sample(&self, x: Vec3, u: [f32; 2]) -> Option<LightSample> {
        let (y, inv_density) = self.place(u);
        let d = y - x;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0) {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        let cos_l = -self.normal.dot(wi);
        if cos_l <= 0.0 {
            return None;
        }
        let weight = self.radiance * (self.profile_weight(y) * cos_l * inv_density / dist2);
        let pdf = dist2 / (cos_l * inv_density);
        weight.is_finite().then_some(LightSample { wi, dist, point: y, weight, pdf })
    }

    /// Where the ray from `x` along unit `w` meets the light's emitting side, with the density
    /// `sample` would draw that direction with (so that a direction found by another strategy
    /// can be weighed against light sampling); None where it misses or meets the back.
    #[inline]
    pub fn hit(&self, x: Vec3, w: Vec3) -> Option<LightHit> {
        let cos_l = -self.normal.dot(w);
        if !(cos_l > 0.0) {
            return None;
        }
        let t = self.normal.dot(x - self.corner) / cos_l;
        if !(t > 0.0 && t.is_finite()) {
            return None;
        }
        let y = x + t * w;
        // The edge parameters of y: its offset against the dual basis of the two edges.
        let d = y - self.corner;
        let c = self.normal * self.area;
        let inv = 1.0 / (self.area * self.area);
        let a = d.cross(self.edge_v).dot(c) * inv;
        let b = self.edge_u.cross(d).dot(c) * inv;
        if !((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)) {
            return None;
        }
        let inv_density = match &self.profile_sampler {
            None => self.area,
            Some(p) => self.area * (p.u.reciprocal_density(a) * p.v.reciprocal_density(b)),
        };
        let pdf = t * t / (cos_l * inv_density);
        let radiance = self.radiance * self.profile_weight(y);
        pdf.is_finite().then_some(LightHit { point: y, radiance, pdf })
    }
}

impl PointLight {
    #[inline]
    pub fn sample(&self, x: Vec3) -> Option<LightSample> {
        let d = self.position - x;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0) {
            return None;
        }
        let dist = dist2.sqrt();
        let weight = self.intensity / dist2;
        let pdf = f32::INFINITY;
        weight.is_finite().then_some(LightSample { wi: d / dist, dist, point: self.position, weight, pdf })
    }
}

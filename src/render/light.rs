//! Lights: one-sided rectangular area lights (uniform or Gaussian emission), point lights and
//! the environment (`environment`).
pub use super::environment::EnvironmentLight;
use super::far_rule::FarRule;
use glam::Vec3;

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

/// Importance sampling of a Gaussian rectangle's profile, one edge at a time (the profile of a
/// rectangle is separable): each edge's truncated Gaussian distribution function is inverted
/// exactly (erf, Newton's method inside a bracket) at `SEGMENTS` + 1 evenly spaced
/// probabilities, and `place` interpolates the inverse linearly between them. Segment j = floor(u
/// SEGMENTS) holds probability 1 / SEGMENTS, so the density actually sampled is piecewise
/// constant, 1 / (SEGMENTS (x_{j+1} - x_j)), and `sample` divides by exactly that density: the
/// estimate is unbiased, and a lookup is one read of two neighbours with no search (it runs
/// twice per light sample; the two tables take 32 KB). Within a segment the profile barely
/// changes where its mass lies (by under 1% within 2 sigma of the centre); in the tails the
/// segments widen and a sample's weight varies more (by 18% across the segment at 3 sigma),
/// but they hold a few samples in a thousand. Sample weights therefore
/// barely vary instead of ranging over the profile's whole span (a factor e^4.5 at +-3 sigma
/// under uniform placement, which made such lights far noisier). The authors placed samples
/// uniformly and weighted them by the profile (methods.md §1.1); either way a sample's weight is
/// radiance over density, and AAF's visibility ratio (Eq. 10) is the same estimator.
#[derive(Clone, Debug, PartialEq)]
struct ProfileSampler {
    u: EdgeDistribution,
    v: EdgeDistribution,
}

#[derive(Clone, Debug, PartialEq)]
struct EdgeDistribution {
    /// inverse[j]: the edge parameter (0 to 1) below which a fraction j / SEGMENTS of the
    /// edge's emitted power lies.
    inverse: Box<[f32; ProfileSampler::SEGMENTS + 1]>,
}

impl ProfileSampler {
    const SEGMENTS: usize = 4096;

    fn new(len_u: f64, len_v: f64, sigma: f64) -> Self {
        ProfileSampler { u: EdgeDistribution::new(len_u, sigma), v: EdgeDistribution::new(len_v, sigma) }
    }
}

impl EdgeDistribution {
    /// An edge of length `len` under a profile of standard deviation `sigma`.
    fn new(len: f64, sigma: f64) -> Self {
        const N: usize = ProfileSampler::SEGMENTS;
        // At edge parameter x the point lies z = (x - 1/2) len / sigma sigmas from the centre,
        // and erf's argument z / sqrt(2) is bound (2x - 1): F(x) = (erf(bound (2x - 1)) +
        // erf(bound)) / (2 erf(bound)).
        let bound = 0.5 * len / (sigma * std::f64::consts::SQRT_2);
        let half = libm::erf(bound);
        let mass = 2.0 * half;
        let cdf = |x: f64| (libm::erf(bound * (2.0 * x - 1.0)) + half) / mass;
        let pdf = |x: f64| {
            let z = bound * (2.0 * x - 1.0);
            4.0 * bound * (-z * z).exp() / (std::f64::consts::PI.sqrt() * mass)
        };
        let mut inverse = Box::new([0.0f32; N + 1]);
        inverse[N] = 1.0;
        let mut x = 0.0f64;
        for (j, out) in inverse.iter_mut().enumerate().take(N).skip(1) {
            let u = j as f64 / N as f64;
            // F is increasing: keep the root bracketed and fall back to bisection wherever a
            // Newton step would leave the bracket (in the flat tails). The first guess steps
            // one segment's mass along the density at the last root.
            let (mut lo, mut hi) = (x, 1.0f64);
            let guess = x + 1.0 / (N as f64 * pdf(x));
            x = if guess > lo && guess < hi { guess } else { 0.5 * (lo + hi) };
            for _ in 0..100 {
                let f = cdf(x) - u;
                if f.abs() <= 1e-15 {
                    break;
                }
                if f < 0.0 {
                    lo = x;
                } else {
                    hi = x;
                }
                let step = x - f / pdf(x);
                x = if step > lo && step < hi { step } else { 0.5 * (lo + hi) };
                if hi - lo <= 1e-15 {
                    break;
                }
            }
            *out = x as f32;
        }
        EdgeDistribution { inverse }
    }

    /// The edge parameter for `u` in [0, 1) and the reciprocal of the density of that
    /// parameter there.
    #[inline]
    fn place(&self, u: f32) -> (f32, f32) {
        const N: usize = ProfileSampler::SEGMENTS;
        let s = u.clamp(0.0, 1.0) * N as f32;
        let j = (s as usize).min(N - 1);
        let (x0, x1) = (self.inverse[j], self.inverse[j + 1]);
        let width = x1 - x0;
        (x0 + (s - j as f32) * width, width * N as f32)
    }

    /// The reciprocal density `place` gives edge parameter `x` in [0, 1]: that of the segment
    /// holding it (a binary search; `place`'s inverse, for a point found by a ray).
    fn reciprocal_density(&self, x: f32) -> f32 {
        const N: usize = ProfileSampler::SEGMENTS;
        let j = self.inverse.partition_point(|&e| e <= x).clamp(1, N) - 1;
        (self.inverse[j + 1] - self.inverse[j]) * N as f32
    }
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

/// 4-point Gauss-Legendre rule on [-1, 1]: (node, weight) for the positive nodes. Exact for
/// polynomials of degree 7; the Gaussian-weighted geometry term is smooth over a light seen
/// from outside it, and the rule is evaluated once per sample, so it must be cheap.
const GAUSS_LEGENDRE_4: [(f64, f64); 2] =
    [(0.339_981_043_584_856_3, 0.652_145_154_862_546_1), (0.861_136_311_594_052_6, 0.347_854_845_137_453_9)];

impl RectLight {
    /// Unshadowed irradiance at `x` per unit of centre radiance: integral over the light of
    /// profile(y) cos_x cos_L / |y - x|^2 dA with cos_x against the shading normal `n`,
    /// counting only light above both the shading and the geometric (`ng`) horizon and in
    /// front of the light: the same integrand the path tracer samples. Deterministic (no sampling noise):
    /// Lambert's closed form on the polygon clipped to the horizon for uniform lights, and a
    /// 4 x 4 Gauss-Legendre rule for the smooth Gaussian profile (clipped by the max(0, cos)
    /// factors, where the rule loses a little accuracy).
    pub fn unshadowed_irradiance(&self, x: Vec3, n: Vec3, ng: Vec3) -> f64 {
        if self.normal.dot(x - self.center()) <= 0.0 {
            return 0.0;
        }
        match self.profile {
            EmissionProfile::Uniform => {
                let clipped = clip_above_both(x, n, ng, &self.quad());
                if clipped.len < 3 {
                    0.0
                } else {
                    polygon_irradiance(x, n, clipped.as_slice())
                }
            }
            EmissionProfile::Gaussian => {
                self.far_gaussian_irradiance(x, n, ng).unwrap_or_else(|| self.adaptive_gaussian_irradiance(x, n, ng))
            }
        }
    }

    /// The diagonal of the part of the rectangle within 2 sigma of the centre along each edge,
    /// which holds 91% of a Gaussian profile's weight or more: the size the far-field rule's
    /// nodes must resolve the geometry over. The whole diagonal for the authors' light (+-1
    /// sigma), two thirds of it for a rectangle spanning +-3 sigma.
    fn weighted_diagonal(&self) -> f64 {
        let half = |e: Vec3| (0.5 * e.length() as f64).min(2.0 * self.sigma as f64);
        2.0 * half(self.edge_u).hypot(half(self.edge_v))
    }

    fn quad(&self) -> [Vec3; 4] {
        [self.corner, self.corner + self.edge_u, self.corner + self.edge_u + self.edge_v, self.corner + self.edge_v]
    }

    /// Irradiance of a Gaussian light by the fixed 8 x 8 rule (nodes and weights precomputed),
    /// for rectangular lights and receivers that see all of it, at least 0.8 `weighted_diagonal`
    /// above its plane: there the geometry term is smooth where the profile's weight lies, and
    /// the rule agrees with brute force to 1e-6 (tested for rectangles spanning 1 to 4 sigma;
    /// the adaptive rule reaches about 1e-4 there) at a small part of the adaptive rule's cost.
    /// None elsewhere.
    fn far_gaussian_irradiance(&self, x: Vec3, n: Vec3, ng: Vec3) -> Option<f64> {
        let (xd, nd) = (x.as_dvec3(), n.as_dvec3());
        let height = self.normal.as_dvec3().dot(xd - self.center().as_dvec3());
        let sees_all = self.quad().iter().all(|&c| n.dot(c - x) > 0.0 && ng.dot(c - x) > 0.0);
        if self.gauss_rule.is_empty() || !(height >= 0.8 * self.weighted_diagonal()) || !sees_all {
            return None;
        }
        Some(height * self.gauss_rule.sum(xd, nd))
    }

    /// Irradiance of a Gaussian light by adaptive quadrature: the integrand is smooth on the
    /// part of the light above both horizons, so clip the rectangle to it, fan it into
    /// triangles and integrate each with a 4 x 4 Gauss-Legendre rule through the Duffy map (no
    /// kink inside any triangle), splitting triangles that are large seen from `x`.
    fn adaptive_gaussian_irradiance(&self, x: Vec3, n: Vec3, ng: Vec3) -> f64 {
        let poly = clip_above_both(x, n, ng, &self.quad());
        let (xd, nd, nl) = (x.as_dvec3(), n.as_dvec3(), self.normal.as_dvec3());
        let (centre, s2) = (self.center().as_dvec3(), 2.0 * (self.sigma() as f64).powi(2));
        let f = |y: glam::DVec3| {
            let d = y - xd;
            let r2 = d.length_squared();
            (-(y - centre).length_squared() / s2).exp() * nd.dot(d).max(0.0) * (-nl.dot(d)).max(0.0) / (r2 * r2)
        };
        let p: Vec<glam::DVec3> = poly.as_slice().iter().map(|v| v.as_dvec3()).collect();
        // Triangles wider than 3 sigma are split as well, so a narrow profile is resolved.
        let resolve = 3.0 * self.sigma as f64;
        (1..p.len().saturating_sub(1)).map(|i| triangle_integral(p[0], p[i], p[i + 1], xd, resolve, &f, 0)).sum()
    }
}

/// The 4-point rule mapped to [0, 1]: (node, weight).
const GL4_UNIT: [(f64, f64); 4] = [
    ((1.0 - GAUSS_LEGENDRE_4[1].0) / 2.0, GAUSS_LEGENDRE_4[1].1 / 2.0),
    ((1.0 - GAUSS_LEGENDRE_4[0].0) / 2.0, GAUSS_LEGENDRE_4[0].1 / 2.0),
    ((1.0 + GAUSS_LEGENDRE_4[0].0) / 2.0, GAUSS_LEGENDRE_4[0].1 / 2.0),
    ((1.0 + GAUSS_LEGENDRE_4[1].0) / 2.0, GAUSS_LEGENDRE_4[1].1 / 2.0),
];

/// Gauss-Legendre rule with 8 points on [0, 1]: (node, weight).
const GL8_UNIT: [(f64, f64); 8] = {
    const T: [(f64, f64); 4] = [
        (0.183_434_642_495_649_8, 0.362_683_783_378_362),
        (0.525_532_409_916_329, 0.313_706_645_877_887_3),
        (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
        (0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
    ];
    [
        ((1.0 - T[3].0) / 2.0, T[3].1 / 2.0),
        ((1.0 - T[2].0) / 2.0, T[2].1 / 2.0),
        ((1.0 - T[1].0) / 2.0, T[1].1 / 2.0),
        ((1.0 - T[0].0) / 2.0, T[0].1 / 2.0),
        ((1.0 + T[0].0) / 2.0, T[0].1 / 2.0),
        ((1.0 + T[1].0) / 2.0, T[1].1 / 2.0),
        ((1.0 + T[2].0) / 2.0, T[2].1 / 2.0),
        ((1.0 + T[3].0) / 2.0, T[3].1 / 2.0),
    ]
};

/// The far-field rule of a Gaussian light over the rectangle y = c + s u + t v, s and t in
/// [-1/2, 1/2]: (node, weight), with the area and the profile folded into the weights. Along
/// each edge it is the 8-point Gaussian quadrature for the truncated Gaussian weight itself
/// (`truncated_gaussian_rule`), exact for the profile times any polynomial of degree 15, so
/// only the smooth geometry term is left to the rule, whether the rectangle spans 1 sigma or 4.
/// The profile is separable because the edges are orthogonal (`far_gaussian_irradiance` is
/// not used otherwise).
fn gaussian_rule(c: glam::DVec3, u: glam::DVec3, v: glam::DVec3, sigma: f64) -> Vec<(glam::DVec3, f64)> {
    let (lu, lv) = (u.length(), v.length());
    let (nodes_u, nodes_v) = (truncated_gaussian_rule(0.5 * lu / sigma), truncated_gaussian_rule(0.5 * lv / sigma));
    let mut rule = Vec::with_capacity(64);
    for &(x, wx) in &nodes_u {
        for &(y, wy) in &nodes_v {
            // x, y are in units of sigma; so is the 1-D weight's integral, hence sigma^2.
            rule.push((c + (x * sigma / lu) * u + (y * sigma / lv) * v, wx * wy * sigma * sigma));
        }
    }
    rule
}

/// Variance of a standard normal variable restricted to [-a, a]:
/// 1 - 2 a phi(a) / (2 Phi(a) - 1), with phi, Phi the normal density and distribution
/// function. Below a = 0.05 the difference cancels, so the series a^2/3 - 2 a^4/45 +
/// 2 a^6/945 (the uniform variance a^2/3, then the profile's corrections; 7e-12 relative
/// error at the switch) takes over; it is 1 for a = inf.
fn truncated_normal_variance(a: f64) -> f64 {
    if !(a > 0.0) {
        return 0.0;
    }
    if a < 0.05 {
        let a2 = a * a;
        return a2 / 3.0 - 2.0 * a2 * a2 / 45.0 + 2.0 * a2 * a2 * a2 / 945.0;
    }
    if a > 40.0 {
        return 1.0;
    }
    let phi = (-0.5 * a * a).exp() / (2.0 * std::f64::consts::PI).sqrt();
    1.0 - 2.0 * a * phi / libm::erf(a / std::f64::consts::SQRT_2)
}

/// The 8-point Gaussian quadrature rule for the weight exp(-z^2/2) on [-a, a]: (node, weight)
/// with sum w_i p(z_i) = integral of exp(-z^2/2) p(z) for every polynomial p of degree <= 15.
/// The recurrence of the weight's orthogonal polynomials comes from the Stieltjes procedure on
/// a fine discretisation of the weight (40 panels of 8-point Gauss-Legendre, exact for the
/// polynomials involved to rounding); the nodes are the roots of the 8th polynomial (found by
/// bisection, symmetric pairs) and the weights the Christoffel numbers 1 / sum_k phat_k(z)^2.
fn truncated_gaussian_rule(a: f64) -> [(f64, f64); 8] {
    const DEGREE: usize = 8;
    const PANELS: usize = 40;
    // Discrete measure: points and masses, on [-a, a].
    let mut measure = Vec::with_capacity(PANELS * 8);
    for p in 0..PANELS {
        let (lo, width) = (-a + 2.0 * a * p as f64 / PANELS as f64, 2.0 * a / PANELS as f64);
        for &(g, w) in &GL8_UNIT {
            let z = lo + g * width;
            measure.push((z, w * width * (-0.5 * z * z).exp()));
        }
    }
    // Monic recurrence p_{k+1} = z p_k - beta_k p_{k-1} (alpha_k = 0: the weight is even).
    // norms[k] = <p_k, p_k>.
    let mut norms = [0.0f64; DEGREE];
    let mut beta = [0.0f64; DEGREE];
    let (mut prev, mut cur): (Vec<f64>, Vec<f64>) = (vec![0.0; measure.len()], vec![1.0; measure.len()]);
    for k in 0..DEGREE {
        norms[k] = measure.iter().zip(&cur).map(|(&(_, m), &p)| m * p * p).sum();
        beta[k] = if k == 0 { 0.0 } else { norms[k] / norms[k - 1] };
        let next: Vec<f64> =
            measure.iter().zip(cur.iter().zip(&prev)).map(|(&(z, _), (&p, &q))| z * p - beta[k] * q).collect();
        (prev, cur) = (cur, next);
    }
    // phat_0..phat_7 (orthonormal) and p_8 at z.
    let eval = |z: f64| -> ([f64; DEGREE], f64) {
        let (mut q, mut p) = (0.0, 1.0);
        let mut hat = [0.0; DEGREE];
        for k in 0..DEGREE {
            hat[k] = p / norms[k].sqrt();
            (q, p) = (p, z * p - beta[k] * q);
        }
        (hat, p)
    };
    // The four positive roots of p_8 (all simple, inside (0, a)): sign changes on a fine grid,
    // then bisection.
    let mut roots = Vec::with_capacity(DEGREE / 2);
    let steps = 4000;
    let mut z0 = 0.0;
    for i in 1..=steps {
        let z1 = a * i as f64 / steps as f64;
        if eval(z0).1.signum() != eval(z1).1.signum() {
            let (mut lo, mut hi) = (z0, z1);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if eval(mid).1.signum() == eval(lo).1.signum() {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            roots.push(0.5 * (lo + hi));
        }
        z0 = z1;
    }
    debug_assert_eq!(roots.len(), DEGREE / 2, "a = {a}");
    let mut rule = [(0.0, 0.0); DEGREE];
    for (i, &z) in roots.iter().enumerate() {
        let w = 1.0 / eval(z).0.iter().map(|h| h * h).sum::<f64>();
        rule[DEGREE / 2 - 1 - i] = (-z, w);
        rule[DEGREE / 2 + i] = (z, w);
    }
    rule
}

/// Integral of `f` over the triangle (a, b, c): the Duffy map (s, t) -> a + s (b - a) +
/// s t (c - b) of the unit square, Jacobian 2 area s, with a 4 x 4 Gauss-Legendre rule. The
/// integrand has a 1/r^2 peak at the receiver `x`: a triangle that is large seen from `x`
/// (longest edge over nearest-vertex distance above 1/2) is split into four first, so the
/// rule stays accurate when the receiver is close to the light; so is a triangle with an edge
/// longer than `resolve` (the scale on which the integrand's profile varies).
fn triangle_integral(
    a: glam::DVec3,
    b: glam::DVec3,
    c: glam::DVec3,
    x: glam::DVec3,
    resolve: f64,
    f: &impl Fn(glam::DVec3) -> f64,
    depth: u32,
) -> f64 {
    let edge = (b - a).length().max((c - b).length()).max((a - c).length());
    let near = (a - x).length().min((b - x).length()).min((c - x).length()).min(((a + b + c) / 3.0 - x).length());
    if depth < 7 && (edge > 0.5 * near || edge > resolve) {
        let (ab, bc, ca) = ((a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0);
        return triangle_integral(a, ab, ca, x, resolve, f, depth + 1)
            + triangle_integral(ab, b, bc, x, resolve, f, depth + 1)
            + triangle_integral(ca, bc, c, x, resolve, f, depth + 1)
            + triangle_integral(ab, bc, ca, x, resolve, f, depth + 1);
    }
    let area2 = (b - a).cross(c - a).length();
    let mut sum = 0.0;
    for &(s, ws) in &GL4_UNIT {
        for &(t, wt) in &GL4_UNIT {
            sum += ws * wt * s * f(a + s * (b - a) + s * t * (c - b));
        }
    }
    sum * area2
}

/// A convex polygon of at most `MAX_CLIPPED` vertices, kept on the stack: the light's quad
/// clipped by two planes (each clip adds at most one vertex). It is built once per sample
/// (the unshadowed irradiance behind AAF's shadow filter), so it must not allocate.
#[derive(Clone, Copy)]
struct ClippedPolygon {
    vertices: [Vec3; MAX_CLIPPED],
    len: usize,
}

const MAX_CLIPPED: usize = 8;

impl ClippedPolygon {
    fn new(poly: &[Vec3]) -> Self {
        let mut out = ClippedPolygon { vertices: [Vec3::ZERO; MAX_CLIPPED], len: poly.len() };
        out.vertices[..poly.len()].copy_from_slice(poly);
        out
    }

    fn as_slice(&self) -> &[Vec3] {
        &self.vertices[..self.len]
    }

    /// The part above the plane through `x` with normal `n` (Sutherland-Hodgman).
    fn clip_above(&self, x: Vec3, n: Vec3) -> Self {
        let poly = self.as_slice();
        let h = |p: Vec3| height_above(x, n, p);
        let mut out = ClippedPolygon { vertices: [Vec3::ZERO; MAX_CLIPPED], len: 0 };
        let mut push = |v: Vec3| {
            // A convex polygon crosses a plane at most twice, so at most one vertex is added;
            // the guard only keeps a degenerate input from writing out of bounds.
            if out.len < MAX_CLIPPED {
                out.vertices[out.len] = v;
                out.len += 1;
            }
        };
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let (ha, hb) = (h(a), h(b));
            if ha > 0.0 {
                push(a);
            }
            if (ha > 0.0) != (hb > 0.0) && ha != hb {
                let t = (ha / (ha - hb)) as f32;
                push(a + (b - a) * t);
            }
        }
        out
    }
}

/// The signed distance (times |n|) of `p` above the plane through `x` with normal `n`.
#[inline]
fn height_above(x: Vec3, n: Vec3, p: Vec3) -> f64 {
    n.as_dvec3().dot((p - x).as_dvec3())
}

/// The part of polygon `poly` above the planes through `x` with normals `n` and `ng`.
fn clip_above_both(x: Vec3, n: Vec3, ng: Vec3, poly: &[Vec3; 4]) -> ClippedPolygon {
    // Most receivers see the whole light: then the clips would copy it unchanged (the same
    // signed distances decide, so the result is the same bit for bit).
    let above = |n: Vec3| poly.iter().all(|&p| height_above(x, n, p) > 0.0);
    if above(n) && above(ng) {
        return ClippedPolygon::new(poly);
    }
    ClippedPolygon::new(poly).clip_above(x, n).clip_above(x, ng)
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

/// Irradiance at `x` with normal `n` from a uniform one-sided polygon of radiance 1 with no
/// occluders: Lambert's closed form E = 1/2 sum_i theta_i (n . gamma_i), where theta_i is the
/// angle edge i subtends at x and gamma_i the unit normal of the plane through x and edge i
/// (e.g. Arvo 1995, "Applications of Irradiance Tensors"). Valid when the whole polygon is
/// above x's horizon. The analytic oracle for the direct-lighting tests.
pub fn polygon_irradiance(x: Vec3, n: Vec3, vertices: &[Vec3]) -> f64 {
    // theta and gamma below depend on the directions alone, so the vertices need no
    // normalising.
    let dir = |v: Vec3| (v - x).as_dvec3();
    let n = n.as_dvec3();
    let Some(&first) = vertices.first() else { return 0.0 };
    // Each vertex's offset once: it ends one edge and starts the next.
    let first = dir(first);
    let mut a = first;
    let mut sum = 0.0f64;
    for i in 0..vertices.len() {
        let b = if i + 1 < vertices.len() { dir(vertices[i + 1]) } else { first };
        // theta = atan2(|a x b|, a . b) and n . gamma = n . (a x b) / |a x b|: one square root
        // for both, and atan2 keeps theta accurate on the short edges of a far light, where
        // acos of a dot product near 1 loses it (`atan2_nonneg`: |a x b| is never negative).
        let c = a.cross(b);
        let s = c.length();
        // A repeated vertex (a corner on the clipping plane is emitted twice) is an empty edge.
        if s > 0.0 {
            sum += super::fast_math::atan2_nonneg(s, a.dot(b)) / s * n.dot(c);
        }
        a = b;
    }
    0.5 * sum.abs()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sampler::PixelSampler;

    #[test]
    fn polygon_irradiance_matches_the_corner_form_factor() {
        // Point under the corner of an a x b rectangle at height h (Howell's catalogue C-11):
        // F = 1/(2 pi) [A/sqrt(1+A^2) atan(B/sqrt(1+A^2)) + B/sqrt(1+B^2) atan(A/sqrt(1+B^2))].
        let (a, b, h) = (2.0f64, 1.0f64, 1.5f64);
        let (aa, bb) = (a / h, b / h);
        let f = (aa / (1.0 + aa * aa).sqrt() * (bb / (1.0 + aa * aa).sqrt()).atan()
            + bb / (1.0 + bb * bb).sqrt() * (aa / (1.0 + bb * bb).sqrt()).atan())
            / (2.0 * std::f64::consts::PI);
        let v =
            [Vec3::new(0.0, 0.0, 1.5), Vec3::new(2.0, 0.0, 1.5), Vec3::new(2.0, 1.0, 1.5), Vec3::new(0.0, 1.0, 1.5)];
        let e = polygon_irradiance(Vec3::ZERO, Vec3::Z, &v);
        assert!((e - std::f64::consts::PI * f).abs() < 1e-6, "{e} vs {}", std::f64::consts::PI * f);
    }

    #[test]
    fn area_sampling_estimates_the_analytic_irradiance() {
        // A 1 x 0.5 light facing down at height 1, offset from the receiver point.
        let light = RectLight::new(
            Vec3::new(-0.2, 0.3, 1.0),
            Vec3::new(0.0, 0.5, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::ONE,
            EmissionProfile::Uniform,
        );
        assert!(light.normal.z < 0.0);
        let x = Vec3::ZERO;
        let exact = polygon_irradiance(
            x,
            Vec3::Z,
            &[
                light.corner,
                light.corner + light.edge_u,
                light.corner + light.edge_u + light.edge_v,
                light.corner + light.edge_v,
            ],
        );
        let n = 4096;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let s = light.sample(x, PixelSampler::new(11, 0, i).next_2d()).unwrap();
            let e = (s.weight.x * s.wi.z) as f64;
            sum += e;
            sum2 += e * e;
        }
        let mean = sum / n as f64;
        let sd = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        // Stratified samples beat the iid standard error; 4 sigma of the iid error is generous
        // yet fails on any radiometric factor error (pi, area, cos_L, 1/r^2).
        assert!((mean - exact).abs() < 4.0 * sd + 1e-6, "mean {mean} exact {exact} sd {sd}");
    }

    /// Stratified Monte Carlo estimate of the unshadowed irradiance (unit radiance) and its
    /// standard error, from `sample`.
    fn mc_irradiance(l: &RectLight, x: Vec3, n: Vec3, ng: Vec3, count: u32) -> (f64, f64) {
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for i in 0..count {
            let e = l.sample(x, PixelSampler::new(21, 0, i).next_2d()).map_or(0.0, |s| {
                if ng.dot(s.wi) <= 0.0 {
                    return 0.0;
                }
                (s.weight.x * n.dot(s.wi).max(0.0)) as f64 / l.radiance.x as f64
            });
            sum += e;
            sum2 += e * e;
        }
        let mean = sum / count as f64;
        (mean, ((sum2 / count as f64 - mean * mean) / count as f64).sqrt())
    }

    #[test]
    fn deterministic_irradiance_matches_monte_carlo_for_both_profiles() {
        for profile in [EmissionProfile::Uniform, EmissionProfile::Gaussian] {
            let l = RectLight::new(Vec3::new(-0.5, 1.0, -0.5), Vec3::X, Vec3::Z * 1.5, Vec3::ONE, profile);
            assert!(l.normal.y < 0.0);
            // Facing up below the light; tilted so the horizon cuts the light; grazing.
            let cases = [
                (Vec3::new(0.3, 0.0, 0.2), Vec3::Y),
                (Vec3::new(0.0, 0.2, 0.1), Vec3::new(0.6, 0.8, 0.0).normalize()),
                (Vec3::new(2.0, 0.5, 0.0), Vec3::new(-1.0, 0.05, 0.0).normalize()),
                (Vec3::new(0.0, 0.5, 0.0), Vec3::new(1.0, 0.0, 0.0)),
            ];
            // A shading normal tilted off the geometric one: both horizons clip.
            let tilted = (
                Vec3::new(0.0, 0.3, 0.1),
                Vec3::new(0.5, 0.85, 0.0).normalize(),
                Vec3::new(-0.4, 0.9, 0.0).normalize(),
            );
            for (x, n, ng) in cases.into_iter().map(|(x, n)| (x, n, n)).chain([tilted]) {
                let exact = l.unshadowed_irradiance(x, n, ng);
                let (mc, se) = mc_irradiance(&l, x, n, ng, 1 << 15);
                assert!(
                    (exact - mc).abs() < 4.0 * se + 2e-3 * mc.abs() + 1e-7,
                    "{profile:?} at {x} n {n}: {exact} vs {mc} ± {se}"
                );
            }
            // Behind the light, or facing away: nothing.
            assert_eq!(l.unshadowed_irradiance(Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Y, Vec3::NEG_Y), 0.0);
            assert_eq!(l.unshadowed_irradiance(Vec3::new(0.0, 0.0, 0.0), Vec3::NEG_Y, Vec3::NEG_Y), 0.0);
        }
    }

    #[test]
    fn near_field_irradiance_of_a_gaussian_light_is_accurate() {
        // Receivers very close to the light, where the 1/r^2 peak defeats a fixed rule (a single
        // 4 x 4 rule was off by 15-50% here): the adaptive rule must match Monte Carlo.
        let l = RectLight::new(Vec3::new(-0.5, 1.0, -0.5), Vec3::X, Vec3::Z, Vec3::ONE, EmissionProfile::Gaussian);
        for (x, n) in [
            (Vec3::new(0.0, 0.8, 0.0), Vec3::Y),
            (Vec3::new(0.1, 0.95, -0.1), Vec3::Y),
            (Vec3::new(0.6, 0.9, 0.0), Vec3::new(-1.0, 0.0, 0.0)),
            (Vec3::new(0.53, 0.97, 0.2), Vec3::new(-1.0, 0.3, 0.0).normalize()),
        ] {
            let e = l.unshadowed_irradiance(x, n, n);
            let (mc, se) = mc_irradiance(&l, x, n, n, 1 << 17);
            assert!((e - mc).abs() < 4.0 * se + 2e-3 * mc, "at {x}: {e} vs {mc} ± {se}");
        }
        let u = RectLight::new(Vec3::new(-0.5, 1.0, -0.5), Vec3::X, Vec3::Z, Vec3::ONE, EmissionProfile::Uniform);
        let e = u.unshadowed_irradiance(Vec3::new(0.0, 1.0 - 1e-4, 0.0), Vec3::Y, Vec3::Y);
        assert!((e - std::f64::consts::PI).abs() < 1e-2, "a light filling the hemisphere gives pi: {e}");
    }

    /// Irradiance of a Gaussian light by a 600 x 600 midpoint rule over the whole rectangle
    /// (receivers that see all of it).
    fn brute_force_gaussian_irradiance(l: &RectLight, x: Vec3, n: Vec3) -> f64 {
        let k = 600;
        let (xd, nd, nl) = (x.as_dvec3(), n.as_dvec3(), l.normal.as_dvec3());
        let mut sum = 0.0;
        for i in 0..k {
            for j in 0..k {
                let (s, t) = ((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
                let y = l.corner.as_dvec3() + s * l.edge_u.as_dvec3() + t * l.edge_v.as_dvec3();
                let d = y - xd;
                let r2 = d.length_squared();
                sum += l.profile_weight(y.as_vec3()) as f64 * nd.dot(d).max(0.0) * (-nl.dot(d)).max(0.0) / (r2 * r2);
            }
        }
        sum * l.area as f64 / (k * k) as f64
    }

    /// A square Gaussian light of side `2 span sigma` centred over the origin at height 1,
    /// facing down (sigma = 0.25).
    fn gaussian_light_spanning(span: f32) -> RectLight {
        let side = 2.0 * span * 0.25;
        let corner = Vec3::new(-0.5 * side, 1.0, -0.5 * side);
        RectLight::gaussian(corner, Vec3::X * side, Vec3::Z * side, Vec3::ONE, 0.25)
    }

    #[test]
    fn far_field_rule_matches_a_brute_force_quadrature() {
        // Receivers from 0.8 weighted diagonals (`weighted_diagonal`) to fifty away, tilted,
        // seeing the whole light; the authors' light (a 1 x 1.4 rectangle spanning +-1 sigma)
        // and Gaussians whose tails the rectangle holds (+-3 and +-4 sigma), where Gauss-Legendre
        // nodes mapped through the profile's inverse distribution function were off by 2e-3.
        let lights = [
            RectLight::new(Vec3::new(-0.5, 1.0, -0.7), Vec3::X, Vec3::Z * 1.4, Vec3::ONE, EmissionProfile::Gaussian),
            gaussian_light_spanning(3.0),
            gaussian_light_spanning(4.0),
        ];
        for l in &lights {
            let diagonal = l.weighted_diagonal() as f32;
            let full = (l.edge_u + l.edge_v).length();
            // The squares span +-3 and +-4 sigma: 2/3 and 1/2 of the diagonal lie within 2 sigma.
            let span = l.edge_u.length() / (2.0 * l.sigma());
            let expected = if span > 2.0 { full * 2.0 / span } else { full };
            assert!((diagonal - expected).abs() < 1e-5 * full, "{diagonal} vs {expected}");
            let mut used = 0;
            for k in 0..120 {
                let h = diagonal * (0.8 + 49.2 * ((k % 20) as f32 / 19.0).powi(3));
                let off = Vec3::new(((k * 7) % 11) as f32 - 5.0, 0.0, ((k * 3) % 13) as f32 - 6.0) * 0.1 * h;
                let x = l.center() - Vec3::Y * h + off;
                let n = (Vec3::Y + Vec3::new(0.3 * ((k % 5) as f32 - 2.0), 0.0, 0.2)).normalize();
                let Some(far) = l.far_gaussian_irradiance(x, n, n) else { continue };
                used += 1;
                let exact = brute_force_gaussian_irradiance(l, x, n);
                assert!((far - exact).abs() <= 1e-6 * exact, "sigma {} at {x} (h = {h}): {far} vs {exact}", l.sigma());
                assert_eq!(l.unshadowed_irradiance(x, n, n), far);
            }
            assert!(used > 100, "{used}");
            // Nearer than 0.8 weighted diagonals, or with the light across the horizon: the adaptive rule.
            assert!(l.far_gaussian_irradiance(l.center() - Vec3::Y * 0.75 * diagonal, Vec3::Y, Vec3::Y).is_none());
            assert!(l.far_gaussian_irradiance(l.center() - Vec3::Y * 3.0, Vec3::X, Vec3::X).is_none());
        }
    }

    /// Integral of z^(2m) exp(-z^2/2) over [-a, a], by the series of the exponential for small
    /// a (the recursion below cancels there) and, by parts, M_2m = (2m - 1) M_{2m-2} -
    /// 2 a^{2m-1} exp(-a^2/2) from M_0 = sqrt(2 pi) erf(a / sqrt 2) otherwise (where the series
    /// cancels instead).
    fn truncated_gaussian_moment(a: f64, m: i32) -> f64 {
        if a <= 2.0 {
            let (mut sum, mut coeff) = (0.0, 1.0);
            for j in 0..60 {
                sum += coeff * a.powi(2 * m + 2 * j + 1) / (2 * m + 2 * j + 1) as f64;
                coeff *= -0.5 / (j + 1) as f64;
            }
            2.0 * sum
        } else {
            let mut moment = (2.0 * std::f64::consts::PI).sqrt() * libm::erf(a / std::f64::consts::SQRT_2);
            for k in 1..=m {
                moment = (2 * k - 1) as f64 * moment - 2.0 * a.powi(2 * k - 1) * (-0.5 * a * a).exp();
            }
            moment
        }
    }

    #[test]
    fn truncated_gaussian_rule_integrates_polynomials_of_degree_15_exactly() {
        for a in [0.3, 1.0, 2.0, 3.0, 4.0, 8.0] {
            let rule = truncated_gaussian_rule(a);
            for degree in 0..16 {
                let exact = if degree % 2 == 1 { 0.0 } else { truncated_gaussian_moment(a, degree / 2) };
                let sum: f64 = rule.iter().map(|&(z, w)| w * z.powi(degree)).sum();
                let scale = rule.iter().map(|&(z, w)| w * z.abs().powi(degree)).sum::<f64>();
                assert!((sum - exact).abs() <= 1e-11 * scale, "a {a} degree {degree}: {sum} vs {exact}");
            }
            assert!(rule.iter().all(|&(z, w)| z.abs() < a && w > 0.0), "a {a}: {rule:?}");
            assert!(rule.windows(2).all(|p| p[0].0 < p[1].0), "a {a}: nodes in order");
        }
    }

    #[test]
    fn a_narrow_gaussian_light_is_sampled_and_integrated_alike() {
        // The sampled estimate (uniform points weighted by the profile) and the deterministic
        // irradiance agree for a light spanning +-4 sigma, near (adaptive rule, split to the
        // profile's scale) and far; so do a skewed parallelogram's, which takes the adaptive rule.
        let narrow = gaussian_light_spanning(4.0);
        let skewed = RectLight::gaussian(Vec3::new(-0.5, 1.0, -0.5), Vec3::X, Vec3::new(0.4, 0.0, 1.0), Vec3::ONE, 0.2);
        assert!(skewed.gauss_rule.is_empty());
        for l in [&narrow, &skewed] {
            assert!((l.profile_weight(l.center() + Vec3::X * 3.0 * l.sigma()) - (-4.5f32).exp()).abs() < 1e-6);
            for (x, n) in [
                (Vec3::new(0.1, 0.7, 0.0), Vec3::Y),
                (Vec3::new(0.3, 0.9, -0.1), Vec3::new(-0.3, 1.0, 0.0).normalize()),
                (Vec3::new(0.5, -3.0, 0.2), Vec3::Y),
            ] {
                let e = l.unshadowed_irradiance(x, n, n);
                let (mc, se) = mc_irradiance(l, x, n, n, 1 << 16);
                assert!((e - mc).abs() < 4.0 * se + 2e-3 * mc, "sigma {} at {x}: {e} vs {mc} ± {se}", l.sigma());
            }
        }
    }

    #[test]
    fn gaussian_samples_follow_the_profile_and_stay_on_the_light() {
        // Far below the light the geometry term is almost constant, so a sample's weight is
        // the profile over the density: nearly constant when the density follows the profile
        // (it would range over a factor e^4.5 = 90 at +-3 sigma with uniform placement).
        for l in [
            gaussian_light_spanning(3.0),
            gaussian_light_spanning(4.0),
            RectLight::new(Vec3::new(-0.5, 1.0, -0.7), Vec3::X, Vec3::Z * 1.4, Vec3::ONE, EmissionProfile::Gaussian),
        ] {
            let x = l.center() - Vec3::Y * 40.0 * (l.edge_u + l.edge_v).length();
            let (mut sum, mut sum2, count) = (0.0f64, 0.0f64, 4096);
            for i in 0..count {
                let u = PixelSampler::new(5, 0, i).next_2d();
                let (y, _) = l.place(u);
                let rel = y - l.corner;
                let (a, b) =
                    (rel.dot(l.edge_u) / l.edge_u.length_squared(), rel.dot(l.edge_v) / l.edge_v.length_squared());
                assert!((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b), "{u:?} -> {a}, {b}");
                let w = l.sample(x, u).unwrap().weight.x as f64;
                (sum, sum2) = (sum + w, sum2 + w * w);
            }
            let mean = sum / count as f64;
            let spread = (sum2 / count as f64 - mean * mean).max(0.0).sqrt() / mean;
            // Within a segment of the table the profile still varies, most in the wide segments
            // of the tails.
            assert!(spread < 0.02, "sigma {}: weights spread {spread}", l.sigma());
        }
        // Uniform lights and skewed parallelograms are placed uniformly by area.
        let skewed = RectLight::gaussian(Vec3::ZERO, Vec3::X, Vec3::new(0.4, 0.0, 1.0), Vec3::ONE, 0.2);
        assert_eq!(skewed.place([0.25, 0.5]), (skewed.point([0.25, 0.5]), skewed.area));
    }

    #[test]
    fn the_edge_distribution_inverts_its_table() {
        // The table holds the exact inverse of the distribution function F at j / SEGMENTS;
        // place(u) lands inside u's segment, linearly between its ends, and returns that
        // segment's reciprocal density: for a narrow, a moderate and an almost flat profile.
        for (len, sigma) in [(8.0, 1.0), (2.0, 1.0), (1.0, 30.0)] {
            let e = EdgeDistribution::new(len, sigma);
            let bound = 0.5 * len / (sigma * std::f64::consts::SQRT_2);
            let f = |x: f64| (libm::erf(bound * (2.0 * x - 1.0)) + libm::erf(bound)) / (2.0 * libm::erf(bound));
            let n = ProfileSampler::SEGMENTS;
            for (j, &x) in e.inverse.iter().enumerate() {
                assert!((f(x as f64) - j as f64 / n as f64).abs() < 1e-6, "len {len} sigma {sigma}: F({x}) at {j}");
            }
            assert!(e.inverse.windows(2).all(|w| w[1] > w[0]), "len {len} sigma {sigma}: increasing");
            for i in 0..=4000 {
                let u = (i as f32 / 4000.0).min(1.0 - f32::EPSILON) * (1.0 - 1e-7) + [0.0, 1e-7][i % 2];
                let (a, reciprocal) = e.place(u);
                let j = ((u as f64 * n as f64) as usize).min(n - 1);
                let (x0, x1) = (e.inverse[j], e.inverse[j + 1]);
                assert!(a >= x0 && a <= x1, "len {len} sigma {sigma}: {u} -> {a} outside [{x0}, {x1}]");
                let t = u as f64 * n as f64 - j as f64;
                assert!((a as f64 - (x0 as f64 + t * (x1 - x0) as f64)).abs() < 1e-6, "{u} -> {a}");
                assert!((reciprocal - (x1 - x0) * n as f32).abs() <= 1e-5 * reciprocal, "{u}: {reciprocal}");
            }
            // A point found by a ray gets the density of the segment `place` drew it from: at
            // every segment's middle and at its ends, tails included.
            for j in 0..n {
                let (x0, x1) = (e.inverse[j], e.inverse[j + 1]);
                let (mid, reciprocal) = e.place((j as f32 + 0.5) / n as f32);
                assert_eq!(e.reciprocal_density(mid), reciprocal, "len {len} sigma {sigma}: segment {j}");
                assert_eq!(e.reciprocal_density(x0), reciprocal, "len {len} sigma {sigma}: segment {j} start");
                if j + 1 < n {
                    let next = (e.inverse[j + 2] - x1) * n as f32;
                    assert_eq!(e.reciprocal_density(x1), next, "len {len} sigma {sigma}: segment {j} end");
                }
            }
            assert_eq!(e.reciprocal_density(1.0), (e.inverse[n] - e.inverse[n - 1]) * n as f32);
        }
    }

    #[test]
    fn corners_on_the_horizon_stay_finite() {
        // The receiver's horizon passes exactly through a light corner.
        let u = RectLight::new(Vec3::new(0.0, 1.0, 0.0), Vec3::X, Vec3::Z, Vec3::ONE, EmissionProfile::Uniform);
        let x = Vec3::new(0.0, 0.0, 0.0);
        let n = Vec3::new(1.0, 0.0, 0.0).cross(Vec3::new(0.0, 1.0, 0.0) - x).normalize();
        let e = u.unshadowed_irradiance(x, n.normalize(), n.normalize());
        assert!(e.is_finite() && e >= 0.0, "{e}");
    }

    #[test]
    fn back_side_receives_nothing() {
        let light = RectLight::new(Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE, EmissionProfile::Uniform);
        // Normal is +z; a point below cannot see the emitting side.
        assert!(light.sample(Vec3::new(0.5, 0.5, -1.0), [0.5, 0.5]).is_none());
        assert!(light.sample(Vec3::new(0.5, 0.5, 1.0), [0.5, 0.5]).is_some());
    }

    #[test]
    fn gaussian_profile_is_one_at_centre_and_uses_sigma_sqrt_area_over_two() {
        let l = RectLight::new(Vec3::ZERO, Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::ONE, EmissionProfile::Gaussian);
        assert_eq!(l.sigma(), 1.0);
        assert_eq!(RectLight::gaussian(Vec3::ZERO, Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::ONE, 0.5).sigma(), 0.5);
        assert!((l.profile_weight(l.center()) - 1.0).abs() < 1e-7);
        let y = l.center() + Vec3::X;
        assert!((l.profile_weight(y) - (-0.5f32).exp()).abs() < 1e-6);
    }

    /// Variance of a profile's marginal along the u edge by brute force: the 1-D integrals of
    /// z^2 w(z) and w(z) with a 20000-panel midpoint rule.
    fn marginal_variance(profile: impl Fn(f64) -> f64, half: f64) -> f64 {
        let n = 20_000;
        let (mut m0, mut m2) = (0.0, 0.0);
        for i in 0..n {
            let z = -half + (i as f64 + 0.5) * 2.0 * half / n as f64;
            m0 += profile(z);
            m2 += z * z * profile(z);
        }
        m2 / m0
    }

    #[test]
    fn emission_std_is_the_spread_of_the_emitted_power() {
        // A 2 x 6 rectangle: the narrower direction is u, of half-width 1.
        let (u, v) = (Vec3::X * 2.0, Vec3::Y * 6.0);
        for sigma in [0.25f32, 0.5, 1.0, 2.0, 20.0] {
            let l = RectLight::gaussian(Vec3::ZERO, u, v, Vec3::ONE, sigma);
            let s = sigma as f64;
            let exact = marginal_variance(|z| (-z * z / (2.0 * s * s)).exp(), 1.0).sqrt();
            let got = l.emission_std() as f64;
            assert!((got - exact).abs() < 1e-5 * exact, "sigma {sigma}: {got} vs {exact}");
        }
        // The authors' light (sigma = sqrt(area)/2, a square spanning +-1 sigma): 0.54 sigma.
        let authors = RectLight::new(Vec3::ZERO, Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::ONE, EmissionProfile::Gaussian);
        assert!((authors.emission_std() - 0.539_55).abs() < 1e-4, "{}", authors.emission_std());
        // A square spanning +-3 sigma is nearly the whole Gaussian; +-40 sigma is all of it.
        let wide = RectLight::gaussian(Vec3::ZERO, Vec3::X * 6.0, Vec3::Y * 6.0, Vec3::ONE, 1.0);
        assert!((wide.emission_std() - 0.986_6).abs() < 1e-3, "{}", wide.emission_std());
        let whole = RectLight::gaussian(Vec3::ZERO, Vec3::X * 80.0, Vec3::Y * 80.0, Vec3::ONE, 1.0);
        assert_eq!(whole.emission_std(), 1.0);
        // Uniform: width / sqrt(12) of the narrower edge, whatever the order of the edges.
        let flat = RectLight::new(Vec3::ZERO, v, u, Vec3::ONE, EmissionProfile::Uniform);
        assert!((flat.emission_std() - 2.0 / 12f32.sqrt()).abs() < 1e-6);
        // Zero size: no spread.
        let none = RectLight::new(Vec3::ZERO, Vec3::ZERO, Vec3::Y, Vec3::ONE, EmissionProfile::Uniform);
        assert_eq!(none.emission_std(), 0.0);
    }

    #[test]
    fn truncated_normal_variance_joins_its_series_and_its_limits() {
        // Both sides of the switch to the series agree, and the uniform limit a^2/3 holds.
        let (below, above) = (truncated_normal_variance(0.05 - 1e-15), truncated_normal_variance(0.05));
        assert!((below - above).abs() < 1e-9 * below, "{below} vs {above}");
        assert!((truncated_normal_variance(1e-6) / (1e-12 / 3.0) - 1.0).abs() < 1e-9);
        assert!((truncated_normal_variance(1.0) - 0.291_125).abs() < 1e-5);
        assert_eq!(truncated_normal_variance(0.0), 0.0);
        assert_eq!(truncated_normal_variance(f64::INFINITY), 1.0);
        // Increasing in a.
        let mut last = 0.0;
        for i in 1..300 {
            let v = truncated_normal_variance(i as f64 * 0.02);
            assert!(v > last, "a = {}", i as f64 * 0.02);
            last = v;
        }
    }

    #[test]
    fn point_light_is_inverse_square() {
        let p = PointLight { position: Vec3::new(0.0, 0.0, 2.0), intensity: Vec3::splat(8.0) };
        let s = p.sample(Vec3::ZERO).unwrap();
        assert_eq!(s.weight, Vec3::splat(2.0));
        assert_eq!(s.dist, 2.0);
    }

    /// Shoelace area of a polygon in the z = 0 plane.
    fn area_xy(p: &[Vec3]) -> f32 {
        (0..p.len()).map(|i| p[i].x * p[(i + 1) % p.len()].y - p[(i + 1) % p.len()].x * p[i].y).sum::<f32>() / 2.0
    }

    #[test]
    fn clipping_the_quad_by_two_planes_keeps_the_part_above_both() {
        let quad =
            [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let x = Vec3::new(0.5, 0.5, 0.0);
        // Above both planes: the whole quad, unchanged.
        let all = clip_above_both(Vec3::new(-1.0, -1.0, 0.0), Vec3::X, Vec3::Y, &quad);
        assert_eq!(all.as_slice(), quad.as_slice());
        // x > 0.5 and y > 0.5: the top-right quarter.
        let quarter = clip_above_both(x, Vec3::X, Vec3::Y, &quad);
        assert!((area_xy(quarter.as_slice()) - 0.25).abs() < 1e-6);
        // Two diagonal cuts cut off two corners: six vertices, area 1 - 2 * (1/8).
        let (a, b) = (Vec3::new(1.0, 1.0, 0.0).normalize(), Vec3::new(-1.0, -1.0, 0.0).normalize());
        let hexagon = clip_above_both(Vec3::new(0.5, 0.0, 0.0), a, Vec3::ZERO, &quad);
        assert_eq!(hexagon.len, 0, "a zero normal keeps nothing");
        let hexagon =
            ClippedPolygon::new(&quad).clip_above(Vec3::new(0.5, 0.0, 0.0), a).clip_above(Vec3::new(1.0, 0.5, 0.0), b);
        assert_eq!(hexagon.len, 6);
        assert!((area_xy(hexagon.as_slice()) - 0.75).abs() < 1e-6, "{}", area_xy(hexagon.as_slice()));
        // Below a plane: nothing.
        assert_eq!(clip_above_both(Vec3::new(2.0, 0.0, 0.0), Vec3::X, Vec3::Y, &quad).len, 0);
    }
}

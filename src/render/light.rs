//! Lights: one-sided rectangular area lights (uniform or Gaussian emission) and point lights.
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmissionProfile {
    Uniform,
    /// Radiance falls off as exp(-|y - c|^2 / (2 sigma^2)) with sigma = sqrt(area)/2: the
    /// Gaussian light of Mehta et al. 2012 (Sec. 4, effective width 2 sigma), realised as a
    /// weight on uniformly placed samples as the authors do (methods.md §1.1).
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
    /// Gaussian lights: the nodes of an 8 x 8 Gauss-Legendre rule over the rectangle with their
    /// weights (area and profile folded in), for the irradiance of distant receivers.
    gauss_rule: Vec<(glam::DVec3, f64)>,
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
}

impl RectLight {
    pub fn new(corner: Vec3, edge_u: Vec3, edge_v: Vec3, radiance: Vec3, profile: EmissionProfile) -> Self {
        let c = edge_u.cross(edge_v);
        let mut light = RectLight {
            corner,
            edge_u,
            edge_v,
            normal: c.normalize_or_zero(),
            area: c.length(),
            radiance,
            profile,
            gauss_rule: Vec::new(),
        };
        if profile == EmissionProfile::Gaussian {
            let (o, u, v) = (corner.as_dvec3(), edge_u.as_dvec3(), edge_v.as_dvec3());
            let area = light.area as f64;
            light.gauss_rule = GL8_UNIT
                .iter()
                .flat_map(|&(s, ws)| GL8_UNIT.iter().map(move |&(t, wt)| (s, ws, t, wt)))
                .map(|(s, ws, t, wt)| {
                    let y = o + s * u + t * v;
                    (y, ws * wt * area * light.profile_weight(y.as_vec3()) as f64)
                })
                .collect();
        }
        light
    }

    pub fn center(&self) -> Vec3 {
        self.corner + 0.5 * (self.edge_u + self.edge_v)
    }

    /// Standard deviation of the Gaussian profile: sqrt(area)/2 (methods.md §1.1).
    pub fn sigma(&self) -> f32 {
        self.area.sqrt() * 0.5
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

    /// Samples a point uniformly by area: weight = Le cos_L / dist^2 * area.
    #[inline]
    pub fn sample(&self, x: Vec3, u: [f32; 2]) -> Option<LightSample> {
        let y = self.point(u);
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
        let weight = self.radiance * (self.profile_weight(y) * cos_l * self.area / dist2);
        weight.is_finite().then_some(LightSample { wi, dist, point: y, weight })
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
                let quad = [
                    self.corner,
                    self.corner + self.edge_u,
                    self.corner + self.edge_u + self.edge_v,
                    self.corner + self.edge_v,
                ];
                let clipped = clip_above(x, ng, &clip_above(x, n, &quad));
                if clipped.len() < 3 {
                    0.0
                } else {
                    polygon_irradiance(x, n, &clipped)
                }
            }
            EmissionProfile::Gaussian => {
                self.far_gaussian_irradiance(x, n, ng).unwrap_or_else(|| self.adaptive_gaussian_irradiance(x, n, ng))
            }
        }
    }

    fn quad(&self) -> [Vec3; 4] {
        [self.corner, self.corner + self.edge_u, self.corner + self.edge_u + self.edge_v, self.corner + self.edge_v]
    }

    /// Irradiance of a Gaussian light by the fixed 8 x 8 rule (Gaussian weights precomputed),
    /// for receivers at least the light's diagonal above its plane that see all of it: there
    /// the integrand is smooth over the whole rectangle, and the rule agrees with brute force to
    /// 1e-6 (tested; the adaptive rule reaches about 1e-4 there) at a small part of the adaptive
    /// rule's cost. None elsewhere.
    fn far_gaussian_irradiance(&self, x: Vec3, n: Vec3, ng: Vec3) -> Option<f64> {
        let (xd, nd) = (x.as_dvec3(), n.as_dvec3());
        let height = self.normal.as_dvec3().dot(xd - self.center().as_dvec3());
        let diagonal = (self.edge_u + self.edge_v).length() as f64;
        let sees_all = self.quad().iter().all(|&c| n.dot(c - x) > 0.0 && ng.dot(c - x) > 0.0);
        if !(height >= diagonal) || !sees_all {
            return None;
        }
        let sum = self.gauss_rule.iter().map(|&(y, w)| {
            let d = y - xd;
            let r2 = d.length_squared();
            w * nd.dot(d).max(0.0) / (r2 * r2)
        });
        Some(height * sum.sum::<f64>())
    }

    /// Irradiance of a Gaussian light by adaptive quadrature: the integrand is smooth on the
    /// part of the light above both horizons, so clip the rectangle to it, fan it into
    /// triangles and integrate each with a 4 x 4 Gauss-Legendre rule through the Duffy map (no
    /// kink inside any triangle), splitting triangles that are large seen from `x`.
    fn adaptive_gaussian_irradiance(&self, x: Vec3, n: Vec3, ng: Vec3) -> f64 {
        let poly = clip_above(x, ng, &clip_above(x, n, &self.quad()));
        let (xd, nd, nl) = (x.as_dvec3(), n.as_dvec3(), self.normal.as_dvec3());
        let (centre, s2) = (self.center().as_dvec3(), 2.0 * (self.sigma() as f64).powi(2));
        let f = |y: glam::DVec3| {
            let d = y - xd;
            let r2 = d.length_squared();
            (-(y - centre).length_squared() / s2).exp() * nd.dot(d).max(0.0) * (-nl.dot(d)).max(0.0) / (r2 * r2)
        };
        let p: Vec<glam::DVec3> = poly.iter().map(|v| v.as_dvec3()).collect();
        (1..p.len().saturating_sub(1)).map(|i| triangle_integral(p[0], p[i], p[i + 1], xd, &f, 0)).sum()
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

/// Integral of `f` over the triangle (a, b, c): the Duffy map (s, t) -> a + s (b - a) +
/// s t (c - b) of the unit square, Jacobian 2 area s, with a 4 x 4 Gauss-Legendre rule. The
/// integrand has a 1/r^2 peak at the receiver `x`: a triangle that is large seen from `x`
/// (longest edge over nearest-vertex distance above 1/2) is split into four first, so the
/// rule stays accurate when the receiver is close to the light.
fn triangle_integral(
    a: glam::DVec3,
    b: glam::DVec3,
    c: glam::DVec3,
    x: glam::DVec3,
    f: &impl Fn(glam::DVec3) -> f64,
    depth: u32,
) -> f64 {
    let edge = (b - a).length().max((c - b).length()).max((a - c).length());
    let near = (a - x).length().min((b - x).length()).min((c - x).length()).min(((a + b + c) / 3.0 - x).length());
    if depth < 7 && edge > 0.5 * near {
        let (ab, bc, ca) = ((a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0);
        return triangle_integral(a, ab, ca, x, f, depth + 1)
            + triangle_integral(ab, b, bc, x, f, depth + 1)
            + triangle_integral(ca, bc, c, x, f, depth + 1)
            + triangle_integral(ab, bc, ca, x, f, depth + 1);
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

/// The part of polygon `poly` above the plane through `x` with normal `n` (Sutherland-Hodgman).
fn clip_above(x: Vec3, n: Vec3, poly: &[Vec3]) -> Vec<Vec3> {
    let h = |p: Vec3| n.as_dvec3().dot((p - x).as_dvec3());
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (ha, hb) = (h(a), h(b));
        if ha > 0.0 {
            out.push(a);
        }
        if (ha > 0.0) != (hb > 0.0) && ha != hb {
            let t = (ha / (ha - hb)) as f32;
            out.push(a + (b - a) * t);
        }
    }
    out
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
        weight.is_finite().then_some(LightSample { wi: d / dist, dist, point: self.position, weight })
    }
}

/// Irradiance at `x` with normal `n` from a uniform one-sided polygon of radiance 1 with no
/// occluders: Lambert's closed form E = 1/2 sum_i theta_i (n . gamma_i), where theta_i is the
/// angle edge i subtends at x and gamma_i the unit normal of the plane through x and edge i
/// (e.g. Arvo 1995, "Applications of Irradiance Tensors"). Valid when the whole polygon is
/// above x's horizon. The analytic oracle for the direct-lighting tests.
pub fn polygon_irradiance(x: Vec3, n: Vec3, vertices: &[Vec3]) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..vertices.len() {
        let a = (vertices[i] - x).as_dvec3().normalize();
        let b = (vertices[(i + 1) % vertices.len()] - x).as_dvec3().normalize();
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        // A repeated vertex (a corner on the clipping plane is emitted twice) is an empty edge.
        let gamma = a.cross(b).normalize_or_zero();
        sum += theta * n.as_dvec3().dot(gamma);
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

    #[test]
    fn far_field_rule_matches_a_brute_force_quadrature() {
        // Receivers from one to fifty light diagonals away, tilted, seeing the whole light.
        let l =
            RectLight::new(Vec3::new(-0.5, 1.0, -0.7), Vec3::X, Vec3::Z * 1.4, Vec3::ONE, EmissionProfile::Gaussian);
        let diagonal = (l.edge_u + l.edge_v).length();
        let mut used = 0;
        for k in 0..400 {
            let h = diagonal * (1.0 + 49.0 * ((k % 20) as f32 / 19.0).powi(3));
            let off = Vec3::new(((k * 7) % 11) as f32 - 5.0, 0.0, ((k * 3) % 13) as f32 - 6.0) * 0.2 * h;
            let x = l.center() - Vec3::Y * h + off;
            let n = (Vec3::Y + Vec3::new(0.3 * ((k % 5) as f32 - 2.0), 0.0, 0.2)).normalize();
            let Some(far) = l.far_gaussian_irradiance(x, n, n) else { continue };
            used += 1;
            let exact = brute_force_gaussian_irradiance(&l, x, n);
            let adaptive = l.adaptive_gaussian_irradiance(x, n, n);
            assert!((far - exact).abs() <= 1e-6 * exact, "at {x} (h = {h}): {far} vs {exact} (adaptive {adaptive})");
            assert_eq!(l.unshadowed_irradiance(x, n, n), far);
        }
        assert!(used > 300, "{used}");
        // Nearer than one diagonal, or with the light across the horizon: the adaptive rule.
        assert!(l.far_gaussian_irradiance(l.center() - Vec3::Y * 0.9 * diagonal, Vec3::Y, Vec3::Y).is_none());
        assert!(l.far_gaussian_irradiance(l.center() - Vec3::Y * 3.0, Vec3::X, Vec3::X).is_none());
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
        assert!((l.profile_weight(l.center()) - 1.0).abs() < 1e-7);
        let y = l.center() + Vec3::X;
        assert!((l.profile_weight(y) - (-0.5f32).exp()).abs() < 1e-6);
    }

    #[test]
    fn point_light_is_inverse_square() {
        let p = PointLight { position: Vec3::new(0.0, 0.0, 2.0), intensity: Vec3::splat(8.0) };
        let s = p.sample(Vec3::ZERO).unwrap();
        assert_eq!(s.weight, Vec3::splat(2.0));
        assert_eq!(s.dist, 2.0);
    }
}

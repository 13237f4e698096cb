//! The unshadowed irradiance of a rect light at a receiver, without sampling noise: Lambert's
//! closed form on the light's polygon clipped to the receiver's horizon (uniform lights), and
//! quadrature for the Gaussian profile (a far-field rule and an adaptive one).
use super::{EmissionProfile, RectLight};
use glam::Vec3;

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
    pub(super) fn weighted_diagonal(&self) -> f64 {
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
    pub(super) fn far_gaussian_irradiance(&self, x: Vec3, n: Vec3, ng: Vec3) -> Option<f64> {
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
pub(super) fn gaussian_rule(c: glam::DVec3, u: glam::DVec3, v: glam::DVec3, sigma: f64) -> Vec<(glam::DVec3, f64)> {
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
pub(super) fn truncated_normal_variance(a: f64) -> f64 {
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
pub(super) fn truncated_gaussian_rule(a: f64) -> [(f64, f64); 8] {
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
pub(super) struct ClippedPolygon {
    vertices: [Vec3; MAX_CLIPPED],
    pub(super) len: usize,
}

const MAX_CLIPPED: usize = 8;

impl ClippedPolygon {
    pub(super) fn new(poly: &[Vec3]) -> Self {
        let mut out = ClippedPolygon { vertices: [Vec3::ZERO; MAX_CLIPPED], len: poly.len() };
        out.vertices[..poly.len()].copy_from_slice(poly);
        out
    }

    pub(super) fn as_slice(&self) -> &[Vec3] {
        &self.vertices[..self.len]
    }

    /// The part above the plane through `x` with normal `n` (Sutherland-Hodgman).
    pub(super) fn clip_above(&self, x: Vec3, n: Vec3) -> Self {
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
pub(super) fn clip_above_both(x: Vec3, n: Vec3, ng: Vec3, poly: &[Vec3; 4]) -> ClippedPolygon {
    // Most receivers see the whole light: then the clips would copy it unchanged (the same
    // signed distances decide, so the result is the same bit for bit).
    let above = |n: Vec3| poly.iter().all(|&p| height_above(x, n, p) > 0.0);
    if above(n) && above(ng) {
        return ClippedPolygon::new(poly);
    }
    ClippedPolygon::new(poly).clip_above(x, n).clip_above(x, ng)
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
            sum += crate::render::fast_math::atan2_nonneg(s, a.dot(b)) / s * n.dot(c);
        }
        a = b;
    }
    0.5 * sum.abs()
}

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
        RectLight { corner, edge_u, edge_v, normal: c.normalize_or_zero(), area: c.length(), radiance, profile }
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
        let gamma = a.cross(b).normalize();
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

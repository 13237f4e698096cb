//! Orthonormal bases and hemisphere sampling.
use glam::Vec3;
use std::f32::consts::PI;

/// An orthonormal basis around unit vector `n` (Duff et al. 2017, "Building an Orthonormal
/// Basis, Revisited": branchless and continuous except at n.z = -1 where it stays valid).
#[inline]
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// Local (x, y, z) around `n` to world.
#[inline]
pub fn to_world(n: Vec3, local: Vec3) -> Vec3 {
    let (t, b) = basis(n);
    t * local.x + b * local.y + n * local.z
}

/// Cosine-weighted direction about +z from a uniform point; pdf = cos(theta)/pi.
#[inline]
pub fn cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let r = u[0].sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u[0]).max(0.0).sqrt())
}

/// Direction about +z with density (m+1)/(2 pi) cos^m(theta) (a normalised power-cosine lobe).
#[inline]
pub fn power_cosine(u: [f32; 2], m: f32) -> Vec3 {
    let cos_t = u[0].powf(1.0 / (m + 1.0));
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

/// Density of `power_cosine` at cos(theta) = `c`.
#[inline]
pub fn power_cosine_pdf(c: f32, m: f32) -> f32 {
    if c <= 0.0 {
        0.0
    } else {
        (m + 1.0) / (2.0 * PI) * c.powf(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal_for_many_normals() {
        for i in 0..500 {
            let a = i as f32 * 0.7;
            let b = i as f32 * 0.31;
            let n = Vec3::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos()).normalize();
            let (t, s) = basis(n);
            for (x, y) in [(t, s), (t, n), (s, n)] {
                assert!(x.dot(y).abs() < 1e-5);
            }
            assert!((t.length() - 1.0).abs() < 1e-5 && (s.length() - 1.0).abs() < 1e-5);
        }
        let (t, s) = basis(Vec3::NEG_Z);
        assert!(t.is_finite() && s.is_finite());
    }

    #[test]
    fn power_cosine_pdf_integrates_to_one() {
        // Integrate over the hemisphere in (cos theta, phi): dω = d(cos) dphi.
        for m in [0.0f32, 1.0, 10.0, 100.0] {
            let n = 20000;
            let sum: f64 = (0..n)
                .map(|i| {
                    let c = (i as f32 + 0.5) / n as f32;
                    power_cosine_pdf(c, m) as f64 * 2.0 * std::f64::consts::PI / n as f64
                })
                .sum();
            assert!((sum - 1.0).abs() < 1e-3, "m={m}: {sum}");
        }
    }
}

//! The curvature `c` of the shear `C_c` (Bagher et al. 2012, Sec. 2.1) from the G-buffer: how
//! fast the shading normal turns per unit length across the surface, from the pixel's
//! neighbours on the same object (the paper's G-buffer stores a curvature; wedge's tessellated
//! shapes have none, so it is measured where they are seen). The largest rate over the four
//! neighbours is kept: conservative, like every other bandwidth the method combines.
use glam::Vec3;

/// One pixel of what the estimate reads; `None` where the camera ray missed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub position: Vec3,
    pub normal: Vec3,
    pub object: u32,
}

/// Curvature (per unit length) at each pixel of a `width` x `height` grid: 0 where the pixel
/// has no surface or no neighbour on the same object.
pub fn curvature(points: &[Option<SurfacePoint>], width: usize, height: usize) -> Vec<f64> {
    assert_eq!(points.len(), width * height);
    let mut out = vec![0.0; points.len()];
    for y in 0..height {
        for x in 0..width {
            let Some(p) = points[y * width + x] else { continue };
            let mut c = 0.0f64;
            let neighbours = [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)];
            for (nx, ny) in neighbours {
                if nx >= width || ny >= height {
                    continue;
                }
                let Some(q) = points[ny * width + nx] else { continue };
                if q.object != p.object {
                    continue;
                }
                let dist = (q.position - p.position).length() as f64;
                // The angle between the normals, over the distance between the points.
                let angle = p.normal.dot(q.normal).clamp(-1.0, 1.0).acos() as f64;
                if dist > 0.0 && angle.is_finite() {
                    c = c.max(angle / dist);
                }
            }
            out[y * width + x] = c;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The points of a sphere of radius `r` seen from far away on +z, on a grid of spacing
    /// `h` over its front.
    fn sphere(r: f32, n: usize, h: f32) -> Vec<Option<SurfacePoint>> {
        let mut points = Vec::new();
        for y in 0..n {
            for x in 0..n {
                let (px, py) = ((x as f32 - n as f32 / 2.0) * h, (y as f32 - n as f32 / 2.0) * h);
                let z2 = r * r - px * px - py * py;
                points.push((z2 > 0.0).then(|| {
                    let p = Vec3::new(px, py, z2.sqrt());
                    SurfacePoint { position: p, normal: p / r, object: 1 }
                }));
            }
        }
        points
    }

    #[test]
    fn a_sphere_curves_as_one_over_its_radius_and_a_plane_not_at_all() {
        for r in [0.5f32, 2.0] {
            let c = curvature(&sphere(r, 21, r / 40.0), 21, 21);
            // At the centre of the front the normal turns by 1/r per unit length.
            let k = c[10 * 21 + 10];
            assert!((k * r as f64 - 1.0).abs() < 0.01, "r {r}: {k}");
        }
        let plane: Vec<Option<SurfacePoint>> = (0..9)
            .map(|i| {
                Some(SurfacePoint {
                    position: Vec3::new((i % 3) as f32, (i / 3) as f32, 0.0),
                    normal: Vec3::Z,
                    object: 0,
                })
            })
            .collect();
        assert!(curvature(&plane, 3, 3).iter().all(|&c| c == 0.0));
    }

    #[test]
    fn edges_between_objects_and_misses_do_not_count() {
        let a = SurfacePoint { position: Vec3::ZERO, normal: Vec3::Z, object: 0 };
        let b = SurfacePoint { position: Vec3::X * 1e-3, normal: Vec3::X, object: 1 };
        let c = curvature(&[Some(a), Some(b), None], 3, 1);
        assert_eq!(c, vec![0.0, 0.0, 0.0]);
        // Two points at one place with different normals (a crease seen edge-on): no NaN.
        let d = SurfacePoint { normal: Vec3::Y, ..a };
        assert!(curvature(&[Some(a), Some(d)], 2, 1).iter().all(|c| c.is_finite()));
    }
}

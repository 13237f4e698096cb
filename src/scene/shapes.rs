//! Tessellation of the analytic shapes and the shape transform.
use super::fields::{direction, err, finite, opt_vec3, vec3, FieldResult};
use crate::proto;
use glam::{Mat3, Mat4, Vec2, Vec3};
use std::f32::consts::PI;

/// Triangles of one shape in its local space.
#[derive(Default, Clone, Debug)]
pub struct TriMesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
}

impl TriMesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }
}

/// Default sphere tessellation: latitude bands (longitude segments are twice this).
pub const DEFAULT_SPHERE_BANDS: u32 = 24;
pub const MAX_SPHERE_BANDS: u32 = 2048;

pub fn sphere_triangles(bands: u32) -> u64 {
    // 2 per quad of the grid, but one per quad in the two rows that touch a pole.
    4 * bands as u64 * bands as u64 - 4 * bands as u64
}

pub fn quad(path: &str, q: &proto::Quad) -> FieldResult<TriMesh> {
    let c = vec3(&format!("{path}.corner"), &q.corner)?;
    let u = direction(&format!("{path}.edge_u"), &q.edge_u)?;
    let v = direction(&format!("{path}.edge_v"), &q.edge_v)?;
    if !(u.cross(v).length_squared() > 0.0) {
        return err(format!("{path}.edge_v"), "must not be parallel to edge_u");
    }
    Ok(TriMesh {
        positions: vec![c, c + u, c + u + v, c + v],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: None,
        uvs: Some(vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)]),
    })
}

pub fn cuboid(path: &str, b: &proto::Box) -> FieldResult<TriMesh> {
    let lo = vec3(&format!("{path}.min"), &b.min)?;
    let hi = vec3(&format!("{path}.max"), &b.max)?;
    if !(lo.cmplt(hi).all()) {
        return err(format!("{path}.max"), format!("must exceed min on every axis (min {lo}, max {hi})"));
    }
    let mut m = TriMesh::default();
    let mut uvs = Vec::new();
    let s = hi - lo;
    let (ex, ey, ez) = (Vec3::new(s.x, 0.0, 0.0), Vec3::new(0.0, s.y, 0.0), Vec3::new(0.0, 0.0, s.z));
    // Each face: a corner and two edges (-x, +x, -y, +y, -z, +z).
    let faces = [(lo, ey, ez), (lo + ex, ey, ez), (lo, ex, ez), (lo + ey, ex, ez), (lo, ex, ey), (lo + ez, ex, ey)];
    let centre = (lo + hi) * 0.5;
    for (c, u, v) in faces {
        // Wind every face so that its normal points out of the box.
        let (u, v) = if u.cross(v).dot(c + 0.5 * (u + v) - centre) < 0.0 { (v, u) } else { (u, v) };
        let k = m.positions.len() as u32;
        m.positions.extend([c, c + u, c + u + v, c + v]);
        uvs.extend([Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]);
        m.indices.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]]);
    }
    m.uvs = Some(uvs);
    Ok(m)
}

pub fn sphere(path: &str, s: &proto::Sphere) -> FieldResult<TriMesh> {
    let c = vec3(&format!("{path}.center"), &s.center)?;
    let r = finite(&format!("{path}.radius"), s.radius)?;
    if r <= 0.0 {
        return err(format!("{path}.radius"), format!("must be > 0, got {r}"));
    }
    let bands = if s.subdivisions == 0 { DEFAULT_SPHERE_BANDS } else { s.subdivisions };
    if !(2..=MAX_SPHERE_BANDS).contains(&bands) {
        return err(format!("{path}.subdivisions"), format!("must be in [2, {MAX_SPHERE_BANDS}], got {bands}"));
    }
    let segs = 2 * bands;
    let mut m = TriMesh::default();
    let (mut normals, mut uvs) = (Vec::new(), Vec::new());
    for i in 0..=bands {
        // Exact poles (sin(pi) is not 0 in f32): their zero-area triangles are then dropped,
        // rather than kept as slivers of random orientation.
        let (st, ct) = match i {
            0 => (0.0, 1.0),
            _ if i == bands => (0.0, -1.0),
            _ => (PI * i as f32 / bands as f32).sin_cos(),
        };
        for j in 0..=segs {
            let phi = 2.0 * PI * j as f32 / segs as f32;
            let n = Vec3::new(st * phi.cos(), ct, st * phi.sin());
            m.positions.push(c + r * n);
            normals.push(n);
            uvs.push(Vec2::new(j as f32 / segs as f32, i as f32 / bands as f32));
        }
    }
    (m.normals, m.uvs) = (Some(normals), Some(uvs));
    let row = segs + 1;
    for i in 0..bands {
        for j in 0..segs {
            let (a, b) = (i * row + j, (i + 1) * row + j);
            // Outward winding. The rows touching a pole have one triangle per quad: the other
            // would have two vertices on the pole and no area.
            if i > 0 {
                m.indices.push([a, a + 1, b]);
            }
            if i + 1 < bands {
                m.indices.push([a + 1, b + 1, b]);
            }
        }
    }
    Ok(m)
}

/// The shape transform as a matrix: scale, then rotate, then translate; or the given matrix.
pub fn transform(path: &str, t: &Option<proto::Transform>) -> FieldResult<Mat4> {
    let Some(t) = t else { return Ok(Mat4::IDENTITY) };
    if !t.matrix.is_empty() {
        if t.matrix.len() != 16 {
            return err(format!("{path}.matrix"), format!("must have 16 numbers, got {}", t.matrix.len()));
        }
        if t.translate.is_some() || t.scale.is_some() || t.rotate_axis.is_some() || t.rotate_deg != 0.0 {
            return err(format!("{path}.matrix"), "cannot be combined with translate, scale or rotate");
        }
        for (i, v) in t.matrix.iter().enumerate() {
            finite(&format!("{path}.matrix[{i}]"), *v)?;
        }
        let m = Mat4::from_cols_array(&t.matrix.clone().try_into().unwrap_or([0.0; 16])).transpose();
        if m.row(3) != glam::Vec4::W {
            return err(format!("{path}.matrix"), "last row must be 0 0 0 1 (affine transforms only)");
        }
        return invertible(path, m);
    }
    let translate = t.translate.as_ref().map(|v| opt_vec3(&format!("{path}.translate"), v)).transpose()?;
    let scale = t.scale.as_ref().map(|v| opt_vec3(&format!("{path}.scale"), v)).transpose()?;
    let angle = finite(&format!("{path}.rotate_deg"), t.rotate_deg)?;
    let rotation = if angle != 0.0 {
        let axis = direction(&format!("{path}.rotate_axis"), &t.rotate_axis)?;
        glam::Quat::from_axis_angle(axis.normalize(), angle.to_radians())
    } else {
        glam::Quat::IDENTITY
    };
    let m =
        Mat4::from_scale_rotation_translation(scale.unwrap_or(Vec3::ONE), rotation, translate.unwrap_or(Vec3::ZERO));
    invertible(path, m)
}

fn invertible(path: &str, m: Mat4) -> FieldResult<Mat4> {
    let det = Mat3::from_mat4(m).determinant();
    if !(det.abs() > 1e-30) || !det.is_finite() {
        return err(path, "must be invertible (no zero scale)");
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pv(x: f32, y: f32, z: f32) -> Option<proto::Vec3> {
        Some(proto::Vec3 { x, y, z })
    }

    #[test]
    fn box_faces_point_outwards_and_cover_the_surface_area() {
        let m = cuboid("b", &proto::Box { min: pv(0.0, 0.0, 0.0), max: pv(1.0, 2.0, 3.0) }).unwrap();
        let centre = Vec3::new(0.5, 1.0, 1.5);
        let mut area = 0.0;
        for t in &m.indices {
            let p = t.map(|i| m.positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            area += n.length() / 2.0;
            assert!(n.dot((p[0] + p[1] + p[2]) / 3.0 - centre) > 0.0);
        }
        assert!((area - 2.0 * (2.0 + 3.0 + 6.0)).abs() < 1e-5);
    }

    #[test]
    fn sphere_vertices_lie_on_the_sphere_and_area_converges() {
        let s = proto::Sphere { center: pv(1.0, 2.0, 3.0), radius: 2.0, subdivisions: 64 };
        let m = sphere("s", &s).unwrap();
        assert_eq!(m.triangle_count() as u64, sphere_triangles(64));
        let mut area = 0.0;
        for t in &m.indices {
            let p = t.map(|i| m.positions[i as usize]);
            area += (p[1] - p[0]).cross(p[2] - p[0]).length() / 2.0;
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            if n.length() > 1e-9 {
                assert!(n.dot(p[0] - Vec3::new(1.0, 2.0, 3.0)) > 0.0, "inward triangle");
            }
        }
        assert!((area / (4.0 * PI * 4.0) - 1.0).abs() < 2e-3, "{area}");
    }

    #[test]
    fn transform_orders_scale_rotate_translate_and_rejects_bad_input() {
        let t = proto::Transform {
            translate: pv(1.0, 0.0, 0.0),
            scale: pv(2.0, 2.0, 2.0),
            rotate_axis: pv(0.0, 0.0, 1.0),
            rotate_deg: 90.0,
            matrix: vec![],
        };
        let m = transform("t", &Some(t)).unwrap();
        let p = m.transform_point3(Vec3::X);
        assert!((p - Vec3::new(1.0, 2.0, 0.0)).length() < 1e-5, "{p}");
        let zero = proto::Transform { scale: pv(0.0, 1.0, 1.0), ..Default::default() };
        assert_eq!(transform("t", &Some(zero)).unwrap_err().field, "t");
        let nan = proto::Transform { translate: pv(f32::NAN, 0.0, 0.0), ..Default::default() };
        assert_eq!(transform("t", &Some(nan)).unwrap_err().field, "t.translate.x");
        let short = proto::Transform { matrix: vec![1.0; 4], ..Default::default() };
        assert_eq!(transform("t", &Some(short)).unwrap_err().field, "t.matrix");
    }
}

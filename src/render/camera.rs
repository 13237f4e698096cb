//! Pinhole camera: primary rays and the projected pixel size.
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct Camera {
    pub position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// tan(vertical fov / 2).
    tan_half_fov: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// `up` need not be orthogonal to the view direction, only not parallel to it; callers
    /// validate that (the scene validator does).
    pub fn new(position: Vec3, look_at: Vec3, up: Vec3, vertical_fov_deg: f32, width: u32, height: u32) -> Self {
        let forward = (look_at - position).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        Camera {
            position,
            forward,
            right,
            up,
            tan_half_fov: (vertical_fov_deg.to_radians() * 0.5).tan(),
            width,
            height,
        }
    }

    /// Unit direction through image position (`x`, `y`) in pixels, (0, 0) the top-left corner.
    pub fn direction(&self, x: f32, y: f32) -> Vec3 {
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * x / self.width as f32 - 1.0) * self.tan_half_fov * aspect;
        let sy = (1.0 - 2.0 * y / self.height as f32) * self.tan_half_fov;
        (self.forward + sx * self.right + sy * self.up).normalize()
    }

    /// World-space length one pixel covers at distance `t` along a primary ray, perpendicular
    /// to the ray (methods.md §0.1: `d = t * 2 tan(fovy/2) / H`, no foreshortening term, which
    /// the AAF methods apply themselves where they want it).
    pub fn projected_pixel_size(&self, t: f32) -> f32 {
        t * 2.0 * self.tan_half_fov / self.height as f32
    }

    /// The horizontal and vertical fields of view, in radians.
    pub fn fields_of_view(&self) -> (f64, f64) {
        let t = self.tan_half_fov as f64;
        let aspect = self.width as f64 / self.height as f64;
        (2.0 * (t * aspect).atan(), 2.0 * t.atan())
    }

    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// The image's x axis in the world (towards increasing pixel x).
    pub fn right(&self) -> Vec3 {
        self.right
    }

    /// The image's upward axis in the world (towards decreasing pixel y).
    pub fn up(&self) -> Vec3 {
        self.up
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera::new(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), Vec3::Y, 90.0, 200, 100)
    }

    #[test]
    fn centre_ray_is_forward_and_corners_match_fov() {
        let c = cam();
        assert!((c.direction(100.0, 50.0) - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        // Top edge centre: 45 degrees up for a 90-degree vertical fov.
        let top = c.direction(100.0, 0.0);
        assert!((top.y / -top.z - 1.0).abs() < 1e-5);
        // Left edge: tan = aspect (2) at 90 degrees.
        let left = c.direction(0.0, 50.0);
        assert!((left.x / left.z - 2.0).abs() < 1e-5);
    }

    #[test]
    fn projected_pixel_size_tiles_the_view() {
        let c = cam();
        // At distance 1, the image plane is 2 units tall over 100 pixels.
        assert!((c.projected_pixel_size(1.0) - 0.02).abs() < 1e-7);
        assert!((c.projected_pixel_size(10.0) - 0.2).abs() < 1e-6);
    }
}

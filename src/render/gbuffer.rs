//! The G-buffer: what one primary ray through each pixel centre sees. The AAF methods read
//! positions, normals, depth, object ids, the BRDF parameters (textures stay out of the
//! filtered quantities) and the projected pixel size `d` (methods.md §0.1). Built only by the
//! methods that need it: the uniform baseline never allocates one.
use super::camera::Camera;
use super::geometry::NONE;
use super::huge_pages::filled;
use super::material::Material;
use super::scene::Scene;
use super::wide_bvh::MAX_PACKET;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// One pixel's primary hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GSample {
    /// Hit point (internal units, see `render::scene`).
    pub position: Vec3,
    /// Shading normal, facing the camera.
    pub normal: Vec3,
    /// Distance along the primary ray; infinite for background pixels.
    pub depth: f32,
    /// Object (shape) id, or `NONE` for background.
    pub object: u32,
    pub material: u32,
    /// Texture coordinates at the hit (textures' bandwidth reads them).
    pub uv: Vec2,
    /// Diffuse albedo kd, specular ks and exponent m of the BRDF at the hit.
    pub kd: Vec3,
    pub ks: Vec3,
    pub exponent: f32,
    /// True when the hit is an area light's own surface.
    pub emitter: bool,
    /// World length one pixel covers at the hit, perpendicular to the ray (methods.md §0.1).
    pub pixel_size: f32,
}

impl GSample {
    pub const BACKGROUND: GSample = GSample {
        position: Vec3::ZERO,
        normal: Vec3::ZERO,
        depth: f32::INFINITY,
        object: NONE,
        material: NONE,
        uv: Vec2::ZERO,
        kd: Vec3::ZERO,
        ks: Vec3::ZERO,
        exponent: 0.0,
        emitter: false,
        pixel_size: 0.0,
    };

    pub fn is_valid(&self) -> bool {
        self.object != NONE
    }

    /// The projected pixel size d (0 for background), divided by max(|n . view|, 0.1) when
    /// `foreshortening` (methods.md §0.1: the AAF papers say d "accounts for foreshortening";
    /// the authors' code leaves it out).
    pub fn projected_size(&self, camera: Vec3, foreshortening: bool) -> f64 {
        if !self.is_valid() {
            return 0.0;
        }
        let d = self.pixel_size as f64;
        if foreshortening {
            let view = (camera - self.position).normalize_or_zero();
            d / (self.normal.dot(view).abs() as f64).max(0.1)
        } else {
            d
        }
    }
}

pub struct GBuffer {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<GSample>,
}

impl GBuffer {
    /// Traces one ray through every pixel centre of `cam`'s view (rays: width x height).
    pub fn build(scene: &Scene, cam: &Camera) -> GBuffer {
        GBuffer::build_until(scene, cam, &|| false).expect("a build that never stops completes")
    }

    /// `build`, asking `stop` before each row: None once it says stop (a render cancelled, or a
    /// session's view replaced, while its G-buffer is built stops within a row of work).
    pub fn build_until(scene: &Scene, cam: &Camera, stop: &(dyn Fn() -> bool + Sync)) -> Option<GBuffer> {
        let (w, h) = (cam.width as usize, cam.height as usize);
        let mut pixels = filled(w * h, GSample::BACKGROUND);
        let stopped = std::sync::atomic::AtomicBool::new(false);
        pixels.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            if stopped.load(std::sync::atomic::Ordering::Relaxed) || stop() {
                stopped.store(true, std::sync::atomic::Ordering::Relaxed);
                return;
            }
            // Neighbouring pixels' centre rays go to the BVH together, a packet at a time.
            let mut dirs = [Vec3::Z; MAX_PACKET];
            let mut hits = [None; MAX_PACKET];
            for (i, px) in row.iter_mut().enumerate() {
                let (x, lane) = (i, i % MAX_PACKET);
                if lane == 0 {
                    let n = (w - x).min(MAX_PACKET);
                    for (k, d) in dirs[..n].iter_mut().enumerate() {
                        *d = cam.direction((x + k) as f32 + 0.5, y as f32 + 0.5);
                    }
                    scene.intersect_many(cam.position, &dirs[..n], 0.0, &mut hits[..n]);
                }
                let Some(s) = hits[lane] else { continue };
                let material = &scene.materials[s.material as usize];
                let brdf = material.brdf(s.uv);
                *px = GSample {
                    position: s.p,
                    normal: s.ns,
                    depth: s.t,
                    object: s.object,
                    material: s.material,
                    uv: s.uv,
                    kd: brdf.kd,
                    ks: brdf.ks,
                    exponent: brdf.exponent,
                    emitter: matches!(material, Material::Emitter { .. }),
                    pixel_size: cam.projected_pixel_size(s.t),
                };
            }
        });
        (!stopped.into_inner()).then_some(GBuffer { width: w as u32, height: h as u32, pixels })
    }

    /// Every pixel's `GSample::projected_size`.
    pub fn pixel_sizes(&self, camera: Vec3, foreshortening: bool) -> Vec<f64> {
        self.pixels.par_iter().map(|p| p.projected_size(camera, foreshortening)).collect()
    }

    pub fn at(&self, x: u32, y: u32) -> &GSample {
        &self.pixels[(y * self.width + x) as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::scene::{CameraDesc, SceneBuilder};
    use crate::render::texture::Texture;

    /// A 2 x 2 plane at distance 3 in front of the camera, facing it; half the view is empty.
    fn scene() -> Scene {
        let mut b = SceneBuilder::new(CameraDesc {
            position: Vec3::new(0.0, 0.0, 3.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vertical_fov_deg: 60.0,
            width: 32,
            height: 24,
        });
        let m = b.add_material(Material::Lambertian {
            albedo: Texture::Checker { even: Vec3::splat(0.2), odd: Vec3::splat(0.8), scale: 2.0 },
        });
        let o = b.new_object();
        let (c, u, v) = (Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0));
        b.geometry.push([c, c + u, c + u + v], None, None, m, o);
        b.geometry.push([c, c + u + v, c + v], None, None, m, o);
        b.build()
    }

    #[test]
    fn depth_normals_ids_and_pixel_size_match_the_geometry() {
        let s = scene();
        let cam = s.default_view();
        let g = GBuffer::build(&s, &cam);
        let k = s.world_scale;
        // A pixel left of centre sees the plane (x in [-1, 0]); the right half is background.
        let p = g.at(12, 12);
        assert!(p.is_valid() && !p.emitter);
        let dir = cam.direction(12.5, 12.5);
        let expected_t = 3.0 * k / dir.dot(cam.forward());
        assert!((p.depth - expected_t).abs() < 1e-4 * expected_t, "{} vs {expected_t}", p.depth);
        assert!((p.normal - Vec3::Z).length() < 1e-6);
        assert!((p.pixel_size - cam.projected_pixel_size(p.depth)).abs() < 1e-9);
        assert!(p.kd == Vec3::splat(0.2) || p.kd == Vec3::splat(0.8));
        assert_eq!(p.object, 0);
        let bg = g.at(28, 12);
        assert!(!bg.is_valid() && bg.depth.is_infinite());
        // The checker texture shows in kd across the plane.
        let kds: std::collections::HashSet<_> =
            g.pixels.iter().filter(|p| p.is_valid()).map(|p| (p.kd.x * 10.0) as i32).collect();
        assert_eq!(kds.len(), 2);
        // Centre rays go a packet of neighbours at a time; each pixel holds its own ray's hit.
        for y in 0..cam.height {
            for x in 0..cam.width {
                let alone = s.intersect(cam.position, cam.direction(x as f32 + 0.5, y as f32 + 0.5), 0.0);
                let p = g.at(x, y);
                assert_eq!(alone.map(|h| h.t.to_bits()), p.is_valid().then_some(p.depth.to_bits()), "pixel {x} {y}");
            }
        }
    }

    #[test]
    fn a_build_stops_within_a_row_once_asked() {
        let s = scene();
        let cam = s.default_view();
        let whole = GBuffer::build(&s, &cam);
        let same = GBuffer::build_until(&s, &cam, &|| false).unwrap();
        assert!(whole.pixels.iter().zip(&same.pixels).all(|(a, b)| a.depth.to_bits() == b.depth.to_bits()));
        assert!(GBuffer::build_until(&s, &cam, &|| true).is_none());
        // Asked once per row: a stop after three rows ends the build there.
        let asked = std::sync::atomic::AtomicUsize::new(0);
        let stop = || asked.fetch_add(1, std::sync::atomic::Ordering::Relaxed) >= 3;
        assert!(GBuffer::build_until(&s, &cam, &stop).is_none());
        let rows = asked.load(std::sync::atomic::Ordering::Relaxed);
        assert!((4..cam.height as usize).contains(&rows), "asked {rows} times of {} rows", cam.height);
    }
}

//! A pixel's camera samples, up to a packet of them at a time: each sample's sampler (after the
//! pair that jitters it in the pixel), its ray's direction and what the ray hits. The rays of a
//! pixel leave one point in nearly one direction, so they go to the BVH together
//! (`Scene::intersect_many`); the hits are the ones each ray would find alone.
use super::camera::Camera;
use super::sampler::PixelSampler;
use super::scene::{Scene, Surface};
use super::wide_bvh::MAX_PACKET;
use glam::Vec3;

pub struct CameraSamples {
    pub samplers: [PixelSampler; MAX_PACKET],
    pub dirs: [Vec3; MAX_PACKET],
    pub hits: [Option<Surface>; MAX_PACKET],
    pub len: usize,
    /// Dimension pairs each sample's path draws after its camera pair, drawn ahead for all the
    /// samples together once `trace` has found their hits (`PixelSampler::draw_ahead`; 0:
    /// none). Any count gives the same numbers; the right one spares the most work
    /// (`integrator::path_pairs`).
    pub pairs_ahead: usize,
}

impl Default for CameraSamples {
    fn default() -> Self {
        CameraSamples {
            samplers: [PixelSampler::new(0, 0, 0); MAX_PACKET],
            dirs: [Vec3::Z; MAX_PACKET],
            hits: [None; MAX_PACKET],
            len: 0,
            pairs_ahead: 0,
        }
    }
}

impl CameraSamples {
    /// Samples `first .. first + len` (`len` at most `MAX_PACKET`) of pixel (x, y), whose index
    /// in the image is `pixel`: each sampler has drawn its jitter pair, which places the ray in
    /// the pixel when `jitter` (else every ray goes through the pixel's centre). Not yet
    /// traced. Fills `self` in place (a caller keeps one for many pixels: it is large).
    #[allow(clippy::too_many_arguments)]
    pub fn set(
        &mut self,
        cam: &Camera,
        seed: u64,
        (x, y): (usize, usize),
        pixel: u32,
        first: u32,
        len: usize,
        jitter: bool,
    ) {
        assert!(len <= MAX_PACKET, "at most a packet of samples");
        self.len = len;
        let key = PixelSampler::pixel_key(seed, pixel);
        let mut jitters = [[0.5; 2]; MAX_PACKET];
        PixelSampler::first_points(key, first, &mut self.samplers[..len], &mut jitters[..len]);
        for (dir, j) in self.dirs.iter_mut().zip(jitters).take(len) {
            let j = if jitter { j } else { [0.5, 0.5] };
            *dir = cam.direction(x as f32 + j[0], y as f32 + j[1]);
        }
    }

    /// Traces the rays from the camera at `origin` into `hits`, and draws the samples' next
    /// `pairs_ahead` pairs ahead where most rays hit something (a ray that leaves the scene
    /// draws nothing more: in the sky ahead is waste); returns the rays traced.
    pub fn trace(&mut self, scene: &Scene, origin: Vec3) -> u64 {
        let n = self.len;
        scene.intersect_many(origin, &self.dirs[..n], 0.0, &mut self.hits[..n]);
        if 2 * self.hits[..n].iter().filter(|h| h.is_some()).count() > n {
            PixelSampler::draw_ahead(&mut self.samplers[..n], self.pairs_ahead);
        }
        n as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::material::Material;
    use crate::render::scene::{CameraDesc, SceneBuilder};
    use crate::render::texture::Texture;

    /// A floor and a wall meeting in an edge the camera looks at.
    fn corner() -> Scene {
        let mut b = SceneBuilder::new(CameraDesc {
            position: Vec3::new(0.3, 1.0, 3.0),
            look_at: Vec3::new(0.0, 0.0, 0.0),
            up: Vec3::Y,
            vertical_fov_deg: 40.0,
            width: 32,
            height: 24,
        });
        let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.5)) });
        let o = b.new_object();
        let quad = |b: &mut SceneBuilder, c: Vec3, u: Vec3, v: Vec3| {
            b.geometry.push([c, c + u, c + u + v], None, None, m, o);
            b.geometry.push([c, c + u + v, c + v], None, None, m, o);
        };
        quad(&mut b, Vec3::new(-4.0, 0.0, -4.0), Vec3::new(0.0, 0.0, 8.0), Vec3::new(8.0, 0.0, 0.0));
        quad(&mut b, Vec3::new(-4.0, 0.0, -0.5), Vec3::new(8.0, 0.0, 0.0), Vec3::new(0.0, 4.0, 0.0));
        b.build()
    }

    /// Each sample's sampler, direction and hit are what tracing it alone gives: the jitter pair
    /// drawn from its own sampler, the ray through the jittered point, the closest surface.
    #[test]
    fn samples_equal_those_traced_one_at_a_time() {
        let scene = corner();
        let cam = scene.default_view();
        let (x, y) = (cam.width as usize / 2 + 3, cam.height as usize / 3);
        let pixel = (y * cam.width as usize + x) as u32;
        for (first, len, jitter) in [(0, 16, true), (5, 7, true), (40, 1, true), (3, 16, false)] {
            let mut c = CameraSamples { pairs_ahead: first as usize % 5, ..CameraSamples::default() };
            c.set(&cam, 11, (x, y), pixel, first, len, jitter);
            assert_eq!(c.trace(&scene, cam.position), len as u64);
            for i in 0..len {
                let mut alone = PixelSampler::new(11, pixel, first + i as u32);
                let j = alone.next_2d();
                let j = if jitter { j } else { [0.5, 0.5] };
                let dir = cam.direction(x as f32 + j[0], y as f32 + j[1]);
                assert_eq!(c.dirs[i], dir);
                assert_eq!(c.samplers[i].next_2d(), alone.next_2d(), "sample {i}: the next pair");
                let hit = scene.intersect(cam.position, dir, 0.0).expect("the camera sees the corner");
                let got = c.hits[i].expect("the packet sees the corner");
                assert_eq!((got.t, got.p, got.material), (hit.t, hit.p, hit.material), "sample {i}");
            }
        }
    }
}

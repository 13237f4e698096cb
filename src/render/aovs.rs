//! Denoiser inputs ("AOVs"): what the camera sees first at each pixel, free of lighting noise,
//! so that a user can run Intel OIDN or any other denoiser guided by albedo and normals on
//! wedge's images.
//!
//! Each pixel averages the first hits of `samples` camera rays spread over the pixel as the
//! render's own samples are (the first points of the pixel's sample stream, a stratified
//! pattern), so that edges are antialiased like the colour they guide: OIDN expects auxiliary
//! images that match the beauty image's pixel filter. With pixel centres every ray goes
//! through the centre and one is enough.
use super::camera::Camera;
use super::material::Material;
use super::sampler::PixelSampler;
use super::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// Albedo, normal and depth per pixel, row-major.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Aovs {
    /// Reflectance of the first hit, kd + ks (the directional albedo of the energy-normalised
    /// lobes at normal incidence is at most that); 1 on an emitter's surface (a denoiser must
    /// keep a light's own pixels as they are), 0 where the ray leaves the scene.
    pub albedo: Vec<[f32; 3]>,
    /// Shading normal of the first hit in world space, facing the camera; 0 where nothing is
    /// hit. An average over the pixel, so not unit length at silhouettes.
    pub normal: Vec<[f32; 3]>,
    /// Distance from the camera along the ray, in scene units; the mean over the rays that hit
    /// something, infinite where none did.
    pub depth: Vec<f32>,
}

impl Aovs {
    /// Camera rays per pixel `trace` spends for `samples` asked: one through the centre with
    /// pixel centres (every ray would be the same), else `samples` (at least 1).
    pub fn rays_per_pixel(samples: u32, pixel_centers: bool) -> u32 {
        if pixel_centers {
            1
        } else {
            samples.max(1)
        }
    }

    /// The AOVs of `view` (internal frame) of `scene`, each pixel the mean of `samples` camera
    /// rays (at least 1) placed by the sample stream of `seed`, or through the pixel centres.
    pub fn trace(scene: &Scene, view: &Camera, samples: u32, seed: u64, pixel_centers: bool) -> Aovs {
        Self::trace_until(scene, view, samples, seed, pixel_centers, &|| false).expect("a trace that never stops ends")
    }

    /// `trace`, asking `stop` before each row: None once it says stop (a render cancelled while
    /// its denoiser inputs are traced stops within a row of work).
    pub fn trace_until(
        scene: &Scene,
        view: &Camera,
        samples: u32,
        seed: u64,
        pixel_centers: bool,
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Option<Aovs> {
        let (w, h) = (view.width as usize, view.height as usize);
        let samples = Self::rays_per_pixel(samples, pixel_centers);
        let rows: Vec<Vec<PixelAovs>> = (0..h)
            .into_par_iter()
            .map(|y| {
                (!stop()).then(|| (0..w).map(|x| pixel(scene, view, x, y, samples, seed, pixel_centers)).collect())
            })
            .collect::<Option<_>>()?;
        let mut aovs = Aovs::default();
        for (a, n, d) in rows.into_iter().flatten() {
            aovs.albedo.push(a);
            aovs.normal.push(n);
            aovs.depth.push(d);
        }
        Some(aovs)
    }
}

/// A pixel's albedo, normal and depth.
type PixelAovs = ([f32; 3], [f32; 3], f32);

fn pixel(scene: &Scene, view: &Camera, x: usize, y: usize, samples: u32, seed: u64, centre: bool) -> PixelAovs {
    let (mut albedo, mut normal, mut depth, mut hits) = (Vec3::ZERO, Vec3::ZERO, 0.0f64, 0u32);
    for i in 0..samples {
        let j = if centre {
            [0.5, 0.5]
        } else {
            PixelSampler::new(seed, (y * view.width as usize + x) as u32, i).next_2d()
        };
        let dir = view.direction(x as f32 + j[0], y as f32 + j[1]);
        let Some(s) = scene.intersect(view.position, dir, 0.0) else { continue };
        let material = &scene.materials[s.material as usize];
        albedo += match material {
            Material::Emitter { .. } => Vec3::ONE,
            m => {
                let b = m.brdf(s.uv);
                b.kd + b.ks
            }
        };
        normal += s.ns;
        depth += s.t as f64;
        hits += 1;
    }
    let k = 1.0 / samples as f32;
    let depth = if hits == 0 { f32::INFINITY } else { (depth / hits as f64) as f32 / scene.world_scale };
    ((albedo * k).to_array(), (normal * k).to_array(), depth)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::scene::{CameraDesc, SceneBuilder};
    use crate::render::texture::Texture;

    /// A floor of albedo (0.2, 0.4, 0.6) at y = 0, 6 units wide, under a camera at height 2
    /// looking straight down; a 1 x 1 red-ish glossy tile raised to y = 0.5 at its centre.
    fn scene(width: u32) -> Scene {
        let mut b = SceneBuilder::new(CameraDesc {
            position: Vec3::new(0.0, 2.0, 0.0),
            look_at: Vec3::ZERO,
            up: Vec3::Z,
            vertical_fov_deg: 60.0,
            width,
            height: width,
        });
        let floor = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::new(0.2, 0.4, 0.6)) });
        let tile = b.add_material(Material::Glossy {
            diffuse: Texture::Constant(Vec3::new(0.5, 0.1, 0.1)),
            specular: Texture::Constant(Vec3::splat(0.25)),
            exponent: Texture::Constant(50.0),
            model: crate::render::material::GlossyModel::BlinnPhong,
        });
        let o = b.new_object();
        let quad = |b: &mut SceneBuilder, h: f32, y: f32, m: u32| {
            let p = |x: f32, z: f32| Vec3::new(x, y, z);
            b.geometry.push([p(-h, -h), p(h, -h), p(h, h)], None, None, m, o);
            b.geometry.push([p(-h, -h), p(h, h), p(-h, h)], None, None, m, o);
        };
        quad(&mut b, 3.0, 0.0, floor);
        quad(&mut b, 0.5, 0.5, tile);
        b.build()
    }

    #[test]
    fn albedo_normal_and_depth_of_a_known_floor_and_tile() {
        let s = scene(16);
        let a = Aovs::trace(&s, &s.default_view(), 4, 1, false);
        assert_eq!((a.albedo.len(), a.normal.len(), a.depth.len()), (256, 256, 256));
        // A corner pixel sees only the floor, a centre pixel only the tile.
        let (corner, centre) = (0, 8 * 16 + 8);
        for (i, c) in a.albedo[corner].iter().zip([0.2, 0.4, 0.6]) {
            assert!((i - c).abs() < 1e-6, "{:?}", a.albedo[corner]);
        }
        for (i, c) in a.albedo[centre].iter().zip([0.75, 0.35, 0.35]) {
            assert!((i - c).abs() < 1e-6, "{:?}", a.albedo[centre]);
        }
        for p in [corner, centre] {
            let n = a.normal[p];
            assert!(n[0].abs() < 1e-6 && (n[1] - 1.0).abs() < 1e-6 && n[2].abs() < 1e-6, "{n:?}");
        }
        // Depth in scene units, along the ray: 1.5 down to the tile (the centre pixel's rays
        // lean up to about 6 degrees off the axis, 0.8% longer); to the floor at the corner
        // pixel, 2 / cos of its ray's angle to the axis.
        assert!((1.5..1.5 * 1.008).contains(&a.depth[centre]), "{}", a.depth[centre]);
        let v = s.default_view();
        let d = v.direction(0.5, 0.5);
        let cos = d.dot(v.forward()) / d.length();
        assert!((a.depth[corner] - 2.0 / cos).abs() < 0.05 * 2.0 / cos, "{} vs {}", a.depth[corner], 2.0 / cos);
    }

    #[test]
    fn edges_average_their_samples_and_misses_are_empty() {
        let s = scene(9);
        let a = Aovs::trace(&s, &s.default_view(), 64, 2, false);
        // Some pixel straddles the tile's edge: its albedo lies strictly between floor and tile.
        let mixed = a.albedo.iter().any(|c| c[0] > 0.25 && c[0] < 0.7);
        assert!(mixed, "no antialiased edge pixel");
        // Pixel centres: one ray, values exactly those of the hit surface.
        let c = Aovs::trace(&s, &s.default_view(), 64, 2, true);
        assert!(c.albedo.iter().all(|p| *p == [0.2, 0.4, 0.6] || *p == [0.75, 0.35, 0.35]));
        // A camera looking away from everything: zero albedo and normal, infinite depth.
        let mut v = s.default_view();
        v = Camera::new(v.position, v.position + Vec3::Y, Vec3::Z, 40.0, 4, 4);
        let e = Aovs::trace(&s, &v, 4, 2, false);
        assert!(e.albedo.iter().chain(&e.normal).all(|p| *p == [0.0; 3]));
        assert!(e.depth.iter().all(|d| d.is_infinite()));
    }

    #[test]
    fn a_trace_asked_to_stop_gives_up() {
        let s = scene(8);
        let v = s.default_view();
        let whole = Aovs::trace(&s, &v, 4, 1, false);
        let same = Aovs::trace_until(&s, &v, 4, 1, false, &|| false).unwrap();
        assert_eq!((whole.albedo, whole.normal), (same.albedo, same.normal));
        assert!(Aovs::trace_until(&s, &v, 4, 1, false, &|| true).is_none());
    }
}

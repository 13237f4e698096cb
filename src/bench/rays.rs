//! Ray throughput: primary, shadow and diffuse-bounce rays against the scene BVH, on 1 and 2
//! threads. The same rays can be written out so that bench/embree_compare.py traces them with
//! Embree on the same machine.
use crate::render::frame_basis::{cosine_hemisphere, to_world};
use crate::render::geometry::BvhQuality;
use crate::render::light::Light;
use crate::render::material::Material;
use crate::render::sampler::PixelSampler;
use crate::render::scene::{CameraDesc, Scene, SceneBuilder};
use crate::render::texture::Texture;
use glam::Vec3;
use rayon::prelude::*;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// Camera rays, closest hit.
    Primary,
    /// From primary hits to a light point, any hit.
    Shadow,
    /// Cosine-distributed from primary hits, closest hit.
    Bounce,
}

impl RayKind {
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Shadow => "shadow",
            RayKind::Bounce => "bounce",
        }
    }
}

pub struct RaySet {
    pub kind: RayKind,
    pub origins: Vec<Vec3>,
    pub dirs: Vec<Vec3>,
    pub tmax: Vec<f32>,
}

/// Rays like the renderer's: `spp` jittered camera rays per pixel, and from each primary hit
/// one shadow ray to the first light and one cosine-distributed bounce ray.
pub fn make_rays(scene: &Scene, spp: u32) -> [RaySet; 3] {
    let cam = scene.default_view();
    let (w, h) = (cam.width, cam.height);
    let mut sets = [RayKind::Primary, RayKind::Shadow, RayKind::Bounce].map(|kind| RaySet {
        kind,
        origins: Vec::new(),
        dirs: Vec::new(),
        tmax: Vec::new(),
    });
    for y in 0..h {
        for x in 0..w {
            for i in 0..spp {
                let mut s = PixelSampler::new(99, y * w + x, i);
                let j = s.next_2d();
                let dir = cam.direction(x as f32 + j[0], y as f32 + j[1]);
                sets[0].origins.push(cam.position);
                sets[0].dirs.push(dir);
                sets[0].tmax.push(f32::INFINITY);
                let Some(hit) = scene.intersect(cam.position, dir, 0.0) else { continue };
                if matches!(scene.materials[hit.material as usize], Material::Emitter { .. }) {
                    continue;
                }
                let o = hit.spawn_origin();
                let target = match scene.lights.first() {
                    Some(Light::Rect(r)) => r.point(s.next_2d()),
                    Some(Light::Point(p)) => p.position,
                    Some(Light::Environment(_)) | None => hit.p + hit.ng,
                };
                if let Some((o, dir, tmax)) = hit.ray_to(target) {
                    sets[1].origins.push(o);
                    sets[1].dirs.push(dir);
                    sets[1].tmax.push(tmax);
                }
                sets[2].origins.push(o);
                sets[2].dirs.push(to_world(hit.ns, cosine_hemisphere(s.next_2d())));
                sets[2].tmax.push(f32::INFINITY);
            }
        }
    }
    sets
}

/// Traces every ray of `set` `repeats` times on `threads` threads; returns the median rays
/// per second and the number of rays that hit.
pub fn measure(scene: &Scene, set: &RaySet, threads: usize, repeats: usize) -> anyhow::Result<(f64, usize)> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
    let g = &scene.geometry;
    let n = set.origins.len();
    let mut rates = Vec::new();
    let mut hits = 0;
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        hits = pool.install(|| {
            (0..n)
                .into_par_iter()
                .with_min_len(1024)
                .filter(|&i| match set.kind {
                    RayKind::Shadow => g.occluded(set.origins[i], set.dirs[i], 0.0, set.tmax[i]),
                    _ => g.intersect(set.origins[i], set.dirs[i], 0.0, set.tmax[i]).is_some(),
                })
                .count()
        });
        rates.push(n as f64 / start.elapsed().as_secs_f64());
    }
    Ok((super::median(rates), hits))
}

/// As `measure`, but the rays go to the BVH in runs of `MAX_PACKET`, in the order `make_rays`
/// made them (a pixel's samples, then the next pixel's), which it traces as packets where the
/// CPU can (`WideBvh::intersect_many`). Falls back to `measure` for other layouts.
pub fn measure_packets(scene: &Scene, set: &RaySet, threads: usize, repeats: usize) -> anyhow::Result<(f64, usize)> {
    use crate::render::wide_bvh::MAX_PACKET;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
    let g = &scene.geometry;
    let rays: Vec<(Vec3, Vec3)> = set.origins.iter().copied().zip(set.dirs.iter().copied()).collect();
    let n = rays.len();
    let mut rates = Vec::new();
    let mut hits = 0;
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        hits = pool.install(|| {
            rays.par_chunks(MAX_PACKET)
                .zip(set.tmax.par_chunks(MAX_PACKET))
                .with_min_len(64)
                .map(|(chunk, ends)| match set.kind {
                    RayKind::Shadow => {
                        let mut out = [false; MAX_PACKET];
                        g.occluded_many(chunk, 0.0, ends, &mut out[..chunk.len()]);
                        out.iter().filter(|&&b| b).count()
                    }
                    _ => {
                        let mut out = [None; MAX_PACKET];
                        g.intersect_many(chunk, 0.0, f32::INFINITY, &mut out[..chunk.len()]);
                        out.iter().filter(|h| h.is_some()).count()
                    }
                })
                .sum()
        });
        rates.push(n as f64 / start.elapsed().as_secs_f64());
    }
    Ok((super::median(rates), hits))
}

/// A procedural terrain of about `triangles` triangles (a height field of summed sines) under a
/// square light: a stand-in for large meshes that needs no asset files.
pub fn terrain_scene(triangles: usize, width: u32, height: u32, quality: BvhQuality) -> Scene {
    let mut b = terrain_builder(triangles, width, height);
    b.bvh_quality = quality;
    b.build()
}

/// The terrain before its BVH is built.
pub fn terrain_builder(triangles: usize, width: u32, height: u32) -> SceneBuilder {
    let mut b = SceneBuilder::new(CameraDesc {
        position: Vec3::new(0.0, 6.0, 9.0),
        look_at: Vec3::new(0.0, 0.0, 0.0),
        up: Vec3::Y,
        vertical_fov_deg: 50.0,
        width,
        height,
    });
    let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.7)) });
    let o = b.new_object();
    let n = ((triangles / 2) as f64).sqrt().ceil() as usize;
    let size = 10.0f32;
    let p = |i: usize, j: usize| {
        let (x, z) = (i as f32 / n as f32 * size - size / 2.0, j as f32 / n as f32 * size - size / 2.0);
        let y = 0.6 * (1.3 * x).sin() * (0.9 * z).cos()
            + 0.25 * (4.1 * x + 2.3 * z).sin()
            + 0.08 * (17.0 * x).sin() * (13.0 * z).cos();
        Vec3::new(x, y, z)
    };
    for i in 0..n {
        for j in 0..n {
            let (a, b2, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            b.geometry.push([a, c, b2], None, None, m, o);
            b.geometry.push([a, d, c], None, None, m, o);
        }
    }
    b.add_rect_light(crate::render::light::RectLight::new(
        Vec3::new(-1.0, 5.0, -1.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::splat(10.0),
        crate::render::light::EmissionProfile::Uniform,
    ));
    b
}

/// Writes the scene's triangles and the ray sets as little-endian f32 files plus meta.json,
/// for bench/embree_compare.py. Coordinates are the tracer's internal frame.
pub fn dump(dir: &Path, scene: &Scene, sets: &[RaySet], results: &serde_json::Value) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut tris = Vec::with_capacity(scene.geometry.tris.len() * 9);
    for slot in 0..scene.geometry.tris.len() {
        for v in scene.geometry.vertices(slot as u32) {
            tris.extend_from_slice(&v.to_array());
        }
    }
    write_f32(&dir.join("triangles.f32"), &tris)?;
    for s in sets {
        let mut rays = Vec::with_capacity(s.origins.len() * 7);
        for i in 0..s.origins.len() {
            rays.extend_from_slice(&s.origins[i].to_array());
            rays.extend_from_slice(&s.dirs[i].to_array());
            rays.push(s.tmax[i].min(1e30));
        }
        write_f32(&dir.join(format!("rays_{}.f32", s.kind.name())), &rays)?;
    }
    std::fs::write(dir.join("meta.json"), serde_json::to_string_pretty(results)?)?;
    Ok(())
}

fn write_f32(path: &Path, v: &[f32]) -> anyhow::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    for x in v {
        f.write_all(&x.to_le_bytes())?;
    }
    f.flush()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terrain_has_the_requested_size_and_rays_hit_it() {
        let s = terrain_scene(20_000, 16, 12, BvhQuality::Medium);
        assert!((20_000..21_000).contains(&(s.triangle_count() - 2)), "{}", s.triangle_count());
        let sets = make_rays(&s, 1);
        assert_eq!(sets[0].origins.len(), 16 * 12);
        let (rate, hits) = measure(&s, &sets[0], 1, 1).unwrap();
        assert!(rate > 0.0);
        // Every primary hit off the light gets a shadow and a bounce ray.
        assert!(hits >= sets[1].origins.len() && sets[1].origins.len() > 16 * 12 / 2, "{hits}");
        assert_eq!(sets[1].origins.len(), sets[2].origins.len());
    }
}

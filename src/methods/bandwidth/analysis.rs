//! The per-pixel analysis of the `bandwidth` method (Bagher et al. 2012, Sec. 2 and 3.1), run
//! once per render on the shared G-buffer: for every pixel, the bandwidth of the light it
//! reflects from the environment (Eq. 3 along `n_b` light directions, averaged by Eq. 4), its
//! image-space bandwidth (Eq. 5), the level to shade it at (Eq. 9) and its variance bound
//! (Eq. 8).
//!
//! The inputs the equations need and the G-buffer does not hold are measured on it: the
//! curvature (`curvature`) and the texture's rate per unit length (its uv step over its
//! position step between neighbours). Pixels whose footprint holds an edge (a neighbour on
//! another object, the background, or of another albedo) are not band-limited at all: they
//! are shaded at level 0 at least, whatever Eq. 9 says of their centre.
use super::brdf::BrdfBandwidth;
use super::curvature::{curvature, SurfacePoint};
use super::illumination::{EnvironmentBandwidth, WaveletOptions};
use super::levels::{image_bandwidth, pixel_bandwidth, shading_level, DirectionBand};
use super::options::BandwidthOptions;
use super::texture::TextureBandwidth;
use super::vector::{one_bounce, Reflection};
use crate::render::camera::Camera;
use crate::render::environment::EnvironmentSample;
use crate::render::gbuffer::{GBuffer, GSample};
use crate::render::material::{Brdf, Material};
use crate::render::sampler::PixelSampler;
use crate::render::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Arc;

/// What the analysis decided for each pixel (row-major).
#[derive(Clone, Debug, PartialEq)]
pub struct Analysis {
    /// Eq. 5's `b_p`, cycles per pixel (0 where nothing is seen; infinite where not
    /// band-limited).
    pub bandwidth: Vec<f32>,
    /// Eq. 9's level, before the passes lower it: spacing exponents, 0 every pixel, -1 and -2
    /// the antialiasing levels (`levels`).
    pub level: Vec<i32>,
    /// Eq. 8's variance bound.
    pub variance: Vec<f64>,
}

/// The finest level a render may use.
pub fn finest_level(opts: &BandwidthOptions) -> i32 {
    if opts.antialiasing {
        -2
    } else {
        0
    }
}

/// The coarsest level of a `width` x `height` image (Eq. 9's `min(log2 W, log2 H)`).
pub fn coarsest_level(width: u32, height: u32) -> i32 {
    (width.min(height).max(1) as f64).log2().floor() as i32
}

fn luminance(c: Vec3) -> f64 {
    (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z) as f64
}

/// A BRDF's identity for the table cache: its parameters' bits.
fn brdf_key(b: &Brdf) -> [u32; 8] {
    [
        b.kd.x.to_bits(),
        b.kd.y.to_bits(),
        b.kd.z.to_bits(),
        b.ks.x.to_bits(),
        b.ks.y.to_bits(),
        b.ks.z.to_bits(),
        b.exponent.to_bits(),
        b.model as u32,
    ]
}

/// The textures of a material whose bandwidth matters (checkers of its colours and exponent).
fn texture_bandwidths(material: &Material, opts: &BandwidthOptions) -> Vec<TextureBandwidth> {
    let (o, t) = (&opts.texture_wavelets, opts.texels_per_square as usize);
    let list = match material {
        Material::Lambertian { albedo } => vec![TextureBandwidth::new(albedo, luminance, o, t)],
        Material::Glossy { diffuse, specular, exponent, .. } => vec![
            TextureBandwidth::new(diffuse, luminance, o, t),
            TextureBandwidth::new(specular, luminance, o, t),
            TextureBandwidth::new(exponent, |m: f32| m as f64, o, t),
        ],
        Material::Emitter { .. } => Vec::new(),
    };
    list.into_iter().filter(|t| *t != TextureBandwidth::Flat).collect()
}

/// Whether the footprint of pixel (x, y) holds an edge: a 4-neighbour on another object, on
/// nothing, or of another albedo (a texture's edge).
fn footprint_edge(g: &GBuffer, x: u32, y: u32) -> bool {
    let p = g.at(x, y);
    let neighbours = [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)];
    neighbours.into_iter().filter(|&(nx, ny)| nx < g.width && ny < g.height).any(|(nx, ny)| {
        let q = g.at(nx, ny);
        q.object != p.object || q.kd != p.kd || q.ks != p.ks || q.exponent != p.exponent
    })
}

/// The largest uv step per unit length between the pixel and its same-object neighbours.
fn uv_rate(g: &GBuffer, x: u32, y: u32) -> f64 {
    let p = g.at(x, y);
    let mut rate = 0.0f64;
    for (nx, ny) in [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)] {
        if nx >= g.width || ny >= g.height {
            continue;
        }
        let q = g.at(nx, ny);
        if q.object != p.object {
            continue;
        }
        let dist = (q.position - p.position).length() as f64;
        let duv = (q.uv - p.uv).length() as f64;
        if dist > 0.0 && duv.is_finite() {
            rate = rate.max(duv / dist);
        }
    }
    rate
}

/// BRDF tables built so far in this process, by BRDF and wavelet options: a table depends on
/// nothing else, and a server renders the same materials again and again (a new view of a
/// scene, the next request of an editor).
type TableCache = HashMap<([u32; 8], String), Arc<BrdfBandwidth>>;
static TABLES: std::sync::Mutex<Option<TableCache>> = std::sync::Mutex::new(None);
/// Tables kept at most (a table is 16 KiB); the cache is emptied when it would hold more.
pub const MAX_CACHED_TABLES: usize = 256;

/// The table of `brdf` (whose key is `key`), from the cache or built.
fn brdf_table(key: [u32; 8], brdf: &Brdf, opts: &WaveletOptions) -> Arc<BrdfBandwidth> {
    let id = (key, format!("{opts:?}"));
    if let Some(t) = TABLES.lock().ok().and_then(|c| c.as_ref().and_then(|c| c.get(&id).cloned())) {
        return t;
    }
    let table = Arc::new(BrdfBandwidth::new(brdf, opts));
    if let Ok(mut cache) = TABLES.lock() {
        let cache = cache.get_or_insert_with(HashMap::new);
        if cache.len() >= MAX_CACHED_TABLES {
            cache.clear();
        }
        cache.insert(id, table.clone());
    }
    table
}

/// Seed of the analysis' light directions (apart from every sample stream).
const STREAM: u64 = 0x6261_6e64_7769_6474;

/// Runs the analysis of `scene` seen through `view` on its G-buffer `g`.
pub fn analyse(scene: &Scene, view: &Camera, g: &GBuffer, opts: &BandwidthOptions, seed: u64) -> Analysis {
    let (w, h) = (g.width, g.height);
    let n = (w * h) as usize;
    let coarsest = coarsest_level(w, h);
    let finest = finest_level(opts);
    let Some(env) = scene.environment() else {
        // No environment light: nothing for the method to shade; every pixel is the plain
        // estimate's, at the coarsest level.
        return Analysis { bandwidth: vec![0.0; n], level: vec![coarsest; n], variance: vec![0.0; n] };
    };
    let start = std::time::Instant::now();
    let env_band = EnvironmentBandwidth::new(env, &opts.wavelets);

    // The BRDF tables of every BRDF seen (a checker albedo gives two), built in parallel.
    let mut brdfs: HashMap<[u32; 8], Brdf> = HashMap::new();
    for p in g.pixels.iter().filter(|p| p.is_valid() && !p.emitter) {
        let b = scene.materials[p.material as usize].brdf(p.uv);
        if b.ks != Vec3::ZERO {
            brdfs.entry(brdf_key(&b)).or_insert(b);
        }
    }
    let tables: HashMap<[u32; 8], Arc<BrdfBandwidth>> =
        brdfs.into_par_iter().map(|(k, b)| (k, brdf_table(k, &b, &opts.wavelets))).collect();
    let textures: Vec<Vec<TextureBandwidth>> = scene.materials.iter().map(|m| texture_bandwidths(m, opts)).collect();

    let points: Vec<Option<SurfacePoint>> = g
        .pixels
        .iter()
        .map(|p| p.is_valid().then_some(SurfacePoint { position: p.position, normal: p.normal, object: p.object }))
        .collect();
    let curv = curvature(&points, w as usize, h as usize);
    let tables_done = start.elapsed().as_secs_f64();
    let (fov_x, fov_y) = view.fields_of_view();
    let stream = crate::render::sampler::hash_words(&[seed, STREAM]);

    // Eq. 4's light directions: each pixel's own, or one set per tile of `light_tile` pixels
    // (`BandwidthOptions::light_tile`), drawn once with their bandwidths.
    let tile = opts.light_tile.max(1);
    let draw = |stream_index: u32| -> Vec<(EnvironmentSample, f64)> {
        let mut sampler = PixelSampler::new(stream, stream_index, 0);
        (0..opts.light_samples.max(1))
            .filter_map(|_| env.sample(sampler.next_2d()))
            .map(|es| (es, env_band.at(es.wi)))
            .collect()
    };
    let (tiles_x, tiles_y) = (w.div_ceil(tile), h.div_ceil(tile));
    let tiles: Vec<Vec<(EnvironmentSample, f64)>> =
        if tile > 1 { (0..tiles_x * tiles_y).into_par_iter().map(draw).collect() } else { Vec::new() };
    let analyse_pixel = |i: usize| -> (f32, i32, f64) {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let p: &GSample = &g.pixels[i];
        if !p.is_valid() || p.emitter {
            let level = if footprint_edge(g, x, y) { 0.max(finest) } else { coarsest };
            return (0.0, level, 0.0);
        }
        let brdf = scene.materials[p.material as usize].brdf(p.uv);
        let table = tables.get(&brdf_key(&brdf));
        let wo = (view.position - p.position).normalize_or_zero();
        let cos_x = p.normal.dot(wo) as f64;
        let rate = uv_rate(g, x, y);
        let texture = textures[p.material as usize].iter().map(|t| t.at(p.uv)).fold(0.0f64, f64::max) * rate;
        let own;
        let samples = if tile > 1 {
            &tiles[((y / tile) * tiles_x + x / tile) as usize]
        } else {
            own = draw(i as u32);
            &own
        };
        let mut directions = Vec::with_capacity(samples.len());
        for &(es, light_a) in samples {
            let cos_i = p.normal.dot(es.wi) as f64;
            let f = if cos_i > 0.0 { brdf.eval(wo, es.wi, p.normal) } else { Vec3::ZERO };
            let brdf_a = table.map_or(0.0, |t| t.at(es.wi, wo, p.normal));
            let r = Reflection {
                cos_i: cos_i.max(0.0),
                cos_x,
                curvature: curv[i],
                texture,
                brdf: brdf_a,
                clip: opts.brdf_clip,
            };
            directions.push(DirectionBand {
                nu: one_bounce(light_a, &r, p.depth as f64, opts.propagation),
                light_a,
                brdf_a,
                radiance: luminance(es.radiance),
                chi: luminance(es.radiance * f),
                cos: cos_i,
                inv_pdf: 1.0 / es.pdf as f64,
            });
        }
        let (nu, variance) = pixel_bandwidth(&directions, opts.normalised);
        // Eq. 5 in radians per pixel (the wavelets' unit), and in cycles per pixel.
        let b_rad = image_bandwidth(nu.a, fov_x, fov_y, w, h);
        let b_p = b_rad / (2.0 * std::f64::consts::PI);
        let mut level = shading_level(if opts.nyquist { 2.0 * b_p } else { b_rad }, w, h, finest);
        if footprint_edge(g, x, y) {
            level = level.min(0);
        }
        (b_p as f32, level, if variance.is_finite() { variance } else { f64::MAX })
    };
    let per_pixel: Vec<(f32, i32, f64)> = if opts.coarse_analysis {
        coarse_then_fine(g, analyse_pixel)
    } else {
        (0..n).into_par_iter().map(analyse_pixel).collect()
    };
    tracing::debug!(
        tables_and_curvature = tables_done,
        pixels = start.elapsed().as_secs_f64() - tables_done,
        "bandwidth: analysis seconds"
    );
    Analysis {
        bandwidth: per_pixel.iter().map(|t| t.0).collect(),
        level: per_pixel.iter().map(|t| t.1).collect(),
        variance: per_pixel.iter().map(|t| t.2).collect(),
    }
}

/// Pixels whose every neighbour on grid 1 asks for a spacing of at least this many levels take
/// their neighbours' results instead of analysing their own (`coarse_analysis`).
const COARSE_MIN_LEVEL: i32 = 3;

/// The analysis of `coarse_analysis`: first the pixels of grid 1 (x and y even), then every
/// other pixel from its (up to four) diagonal, horizontal or vertical neighbours on that grid:
/// it is analysed itself when its footprint holds an edge, when a neighbour is missing, lies on
/// another surface or in the background, or asks for a level below `COARSE_MIN_LEVEL`;
/// otherwise it takes their largest bandwidth, finest level and largest variance (the
/// conservative choice each quantity's use asks for).
fn coarse_then_fine(g: &GBuffer, analyse_pixel: impl Fn(usize) -> (f32, i32, f64) + Sync) -> Vec<(f32, i32, f64)> {
    let (w, h) = (g.width as usize, g.height as usize);
    let on_grid = |i: usize| (i % w).is_multiple_of(2) && (i / w).is_multiple_of(2);
    let first: Vec<Option<(f32, i32, f64)>> =
        (0..w * h).into_par_iter().map(|i| on_grid(i).then(|| analyse_pixel(i))).collect();
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            if let Some(r) = first[i] {
                return r;
            }
            let (x, y) = (i % w, i / w);
            let p = &g.pixels[i];
            let xs: &[usize] = if x % 2 == 0 { &[x] } else { &[x - 1, x + 1] };
            let ys: &[usize] = if y % 2 == 0 { &[y] } else { &[y - 1, y + 1] };
            let mut merged = (0.0f32, i32::MAX, 0.0f64);
            for &ny in ys {
                for &nx in xs {
                    if nx >= w || ny >= h || !p.is_valid() || p.emitter {
                        return analyse_pixel(i);
                    }
                    let j = ny * w + nx;
                    let q = &g.pixels[j];
                    let same = q.object == p.object && q.kd == p.kd && q.ks == p.ks && q.exponent == p.exponent;
                    let Some(r) = first[j].filter(|r| same && r.1 >= COARSE_MIN_LEVEL) else {
                        return analyse_pixel(i);
                    };
                    merged = (merged.0.max(r.0), merged.1.min(r.1), merged.2.max(r.2));
                }
            }
            if footprint_edge(g, x as u32, y as u32) {
                return analyse_pixel(i);
            }
            merged
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A `w` x `h` G-buffer of one flat surface, object 1 left of `split_x` and 2 from it on.
    fn two_surfaces(w: u32, h: u32, split_x: u32) -> GBuffer {
        let pixels = (0..w * h)
            .map(|i| GSample {
                object: if i % w < split_x { 1 } else { 2 },
                material: 0,
                depth: 1.0,
                normal: Vec3::Z,
                ..GSample::BACKGROUND
            })
            .collect();
        GBuffer { width: w, height: h, pixels }
    }

    #[test]
    fn the_coarse_analysis_skips_smooth_pixels_only() {
        let (w, h) = (32u32, 24u32);
        let g = two_surfaces(w, h, 20);
        // Level 5 everywhere but a fine patch (level 0) around (8, 8); the bandwidth and the
        // variance say where they came from.
        let level_at = |x: u32, y: u32| if x.abs_diff(8) <= 1 && y.abs_diff(8) <= 1 { 0 } else { 5 };
        let calls = AtomicUsize::new(0);
        let analyse_pixel = |i: usize| {
            calls.fetch_add(1, Ordering::Relaxed);
            let (x, y) = (i as u32 % w, i as u32 / w);
            (x as f32, level_at(x, y), y as f64)
        };
        let got = coarse_then_fine(&g, analyse_pixel);
        let calls = calls.into_inner();
        let own = |i: usize| ((i as u32 % w) as f32, level_at(i as u32 % w, i as u32 / w), (i as u32 / w) as f64);
        for (i, r) in got.iter().enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let on_grid = x % 2 == 0 && y % 2 == 0;
            // Pixels with a grid-1 neighbour in the patch: the patch itself.
            let near_patch = x.abs_diff(8) <= 1 && y.abs_diff(8) <= 1;
            // Either side of the objects' edge, and the last column and row (a neighbour
            // missing).
            let near_edge = x == 19 || x == 20 || x + 1 >= w || y + 1 >= h;
            if on_grid || near_patch || near_edge {
                // Analysed itself: its own result.
                assert_eq!(*r, own(i), "({x}, {y})");
            } else {
                // From its grid-1 neighbours: largest bandwidth, finest level, largest variance.
                let nx = if x % 2 == 0 { x } else { x + 1 };
                let ny = if y % 2 == 0 { y } else { y + 1 };
                assert_eq!(*r, (nx as f32, 5, ny as f64), "({x}, {y})");
            }
        }
        // The fine patch is never missed: every pixel inside it has level 0.
        for y in 7..=9u32 {
            for x in 7..=9u32 {
                assert_eq!(got[(y * w + x) as usize].1, 0);
            }
        }
        // A quarter of the pixels, the edge's and the image border's columns and rows, and the
        // patch's surroundings: well under half the pixels.
        assert!(calls < (w * h) as usize / 2, "{calls} of {}", w * h);
    }
}

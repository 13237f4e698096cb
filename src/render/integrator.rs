//! Radiance along camera rays: next-event estimation from every light plus importance-sampled
//! bounces. Emitters hit by bounce rays add nothing (their light arrives by next-event
//! estimation), so no light path is counted twice. The environment's direct light is estimated
//! with two strategies (a direction drawn from the light and one drawn from the BRDF, combined
//! by multiple importance sampling, `environment_direct`), and so is the glossy part of a rect
//! light's in scenes with glossy materials (`rect_direct`, `mis`): both draw their own
//! BRDF-sampled direction. Bounce rays that escape add nothing either, for the same reason.
use super::environment::{EnvironmentLight, EnvironmentSample};
use super::frame_basis::{cosine_hemisphere, to_world};
use super::light::{Light, LightSample, RectLight};
use super::material::{Brdf, BrdfSample, Material};
use super::mis::{light_terms, power_heuristic, shadowed_lobe_term};
use super::sampler::PixelSampler;
use super::scene::{Scene, Surface};
use glam::Vec3;

/// A path's contribution and the rays it traced.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathResult {
    pub radiance: Vec3,
    pub rays: u32,
}

/// Which lights a direct-light estimate covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DirectLights {
    All,
    /// Leave out rectangular area lights (their direct light is estimated elsewhere, e.g. by
    /// AAF); their sample dimensions are still drawn, so the other numbers do not move.
    SkipRect,
    /// Leave out the environment light (estimated elsewhere, e.g. by the bandwidth method's
    /// shading); its dimensions are still drawn.
    SkipEnvironment,
}

/// The sample numbers one light's direct-light estimate uses: a pair for the light; for the
/// environment also a lobe choice and a pair for its BRDF-sampled direction; for a rect light in
/// a scene with glossy materials (`Scene::glossy`) a pair for its lobe-sampled direction
/// (`mis`). Drawn for every light at every vertex, used or not, so that the streams of the other
/// dimensions do not move.
#[derive(Clone, Copy, Debug)]
pub struct LightDims {
    pub light: [f32; 2],
    pub brdf: Option<(f32, [f32; 2])>,
    pub lobe: Option<[f32; 2]>,
}

impl LightDims {
    #[inline]
    pub fn draw(light: &Light, glossy: bool, sampler: &mut PixelSampler) -> Self {
        let u = sampler.next_2d();
        let brdf = matches!(light, Light::Environment(_)).then(|| (sampler.next_1d(), sampler.next_2d()));
        let lobe = (glossy && matches!(light, Light::Rect(_))).then(|| sampler.next_2d());
        LightDims { light: u, brdf, lobe }
    }

    /// The pairs `draw` takes for `light` (a 1-D value takes a pair).
    pub fn pairs(light: &Light, glossy: bool) -> usize {
        match light {
            Light::Environment(_) => 3,
            Light::Rect(_) if glossy => 2,
            Light::Rect(_) | Light::Point(_) => 1,
        }
    }
}

/// The dimension pairs one sample of `integrand` draws after its camera pair when its path
/// runs all `bounces`: each vertex draws `LightDims` for every light, and each bounce a lobe
/// choice and a direction (`radiance_from`); occlusion draws one direction. A packet of a
/// pixel's samples draws these ahead together (`CameraSamples::pairs_ahead`).
pub fn path_pairs(scene: &Scene, integrand: Integrand, bounces: u32) -> usize {
    match integrand {
        Integrand::AmbientOcclusion { .. } => 1,
        Integrand::Radiance => {
            let per_vertex: usize = scene.lights.iter().map(|l| LightDims::pairs(l, scene.glossy)).sum();
            per_vertex * (bounces as usize + 1) + 2 * bounces as usize
        }
    }
}

/// The dimension pairs of a sample split at its first hit as `aaf_indirect` and `auto` split
/// it: every light's `LightDims` there, then a diffuse and a glossy direction, then the path
/// on from the diffuse direction's hit with the bounces left (`path_pairs`).
pub fn split_path_pairs(scene: &Scene, bounces: u32) -> usize {
    let first = path_pairs(scene, Integrand::Radiance, 0);
    match bounces {
        0 => first,
        b => first + 2 + path_pairs(scene, Integrand::Radiance, b - 1),
    }
}

/// Direct light at `s` towards `wo`: one sample of every light, each with its own stratified
/// dimension pair. Returns the radiance and the number of shadow rays.
pub fn direct_light(scene: &Scene, s: &Surface, wo: Vec3, sampler: &mut PixelSampler) -> (Vec3, u32) {
    direct_light_of(scene, s, wo, sampler, DirectLights::All)
}

pub fn direct_light_of(
    scene: &Scene,
    s: &Surface,
    wo: Vec3,
    sampler: &mut PixelSampler,
    which: DirectLights,
) -> (Vec3, u32) {
    let brdf = scene.materials[s.material as usize].brdf(s.uv);
    let mut sum = Vec3::ZERO;
    let mut rays = 0;
    for light in &scene.lights {
        let dims = LightDims::draw(light, scene.glossy, sampler);
        let skipped = match which {
            DirectLights::All => false,
            DirectLights::SkipRect => matches!(light, Light::Rect(_)),
            DirectLights::SkipEnvironment => matches!(light, Light::Environment(_)),
        };
        if brdf.is_black() || skipped {
            continue;
        }
        let (l, r) = light_radiance(scene, s, wo, &brdf, light, &dims);
        sum += l;
        rays += r;
    }
    (sum, rays)
}

/// One light's direct light at `s` towards `wo` with the numbers `dims`: the radiance and the
/// shadow rays traced.
#[inline]
pub fn light_radiance(
    scene: &Scene,
    s: &Surface,
    wo: Vec3,
    brdf: &Brdf,
    light: &Light,
    dims: &LightDims,
) -> (Vec3, u32) {
    let sample = match light {
        Light::Rect(r) => return rect_direct(scene, s, wo, brdf, r, dims.light, dims.lobe),
        Light::Point(p) => p.sample(s.p),
        Light::Environment(e) => {
            let (u_lobe, u_brdf) = dims.brdf.unwrap_or((0.5, [0.5, 0.5]));
            return environment_direct(scene, s, wo, brdf, e, dims.light, u_lobe, u_brdf);
        }
    };
    match sample {
        Some(ls) => light_sample_radiance(scene, s, wo, brdf, &ls),
        None => (Vec3::ZERO, 0),
    }
}

/// A rect light's direct light at `s` towards `wo` from the light sample `u_light` and, when
/// `u_lobe` is given, the lobe sample (its glossy part then weighed against the light sample's):
/// the radiance and the shadow rays traced. Without `u_lobe` it is light sampling alone.
pub fn rect_direct(
    scene: &Scene,
    s: &Surface,
    wo: Vec3,
    brdf: &Brdf,
    rect: &RectLight,
    u_light: [f32; 2],
    u_lobe: Option<[f32; 2]>,
) -> (Vec3, u32) {
    let lobe = u_lobe.map_or((Vec3::ZERO, 0), |u| shadowed_lobe_term(scene, s, wo, brdf, rect, u, 1));
    let (mut sum, mut rays) = lobe;
    let Some(ls) = rect.sample(s.p, u_light) else { return (sum, rays) };
    if let Some((u, g)) = light_terms(brdf, s, wo, &ls, u_lobe.is_some(), 1) {
        rays += 1;
        if !scene.occluded(s, ls.point) {
            sum += u + g;
        }
    }
    (sum, rays)
}

/// The environment's direct light at `s` towards `wo`: one direction drawn from the light
/// (`u_light`) and one from the BRDF (`u_lobe`, `u_brdf`), each weighted by the power
/// heuristic against the other strategy's density, each with a ray to the sky. Light sampling
/// wins on a small bright sun over a diffuse surface, BRDF sampling on a sharp glossy lobe
/// under a smooth sky; together neither case is noisy. Returns the radiance and rays traced.
#[allow(clippy::too_many_arguments)]
pub fn environment_direct(
    scene: &Scene,
    s: &Surface,
    wo: Vec3,
    brdf: &Brdf,
    env: &EnvironmentLight,
    u_light: [f32; 2],
    u_lobe: f32,
    u_brdf: [f32; 2],
) -> (Vec3, u32) {
    let (mut sum, mut rays) = (Vec3::ZERO, 0);
    for (value, wi) in environment_terms(s, wo, brdf, env, u_light, u_lobe, u_brdf).into_iter().flatten() {
        rays += 1;
        if scene.escapes(s, wi) {
            sum += value;
        }
    }
    if sum.is_finite() {
        (sum, rays)
    } else {
        (Vec3::ZERO, rays)
    }
}

/// The two terms of `environment_direct` before visibility: for the light's and the BRDF's
/// direction, the MIS-weighted `f L cos / pdf` and the direction, `None` where the term is
/// zero whatever the visibility (below the horizon, black BRDF or sky). Their sum is an
/// unbiased estimate of the unshadowed environment light; each term needs a ray to be shadowed.
pub fn environment_terms(
    s: &Surface,
    wo: Vec3,
    brdf: &Brdf,
    env: &EnvironmentLight,
    u_light: [f32; 2],
    u_lobe: f32,
    u_brdf: [f32; 2],
) -> [Option<(Vec3, Vec3)>; 2] {
    let light = light_term(s, wo, brdf, env.sample(u_light));
    let drawn = brdf_direction(s, wo, brdf, u_lobe, u_brdf);
    [light, drawn.and_then(|(b, cos)| brdf_term(&b, cos, env.radiance_and_pdf(b.wi)))]
}

/// `environment_terms` of several lookups at one point: the same terms, the environment's
/// memory reads of all of them issued together (`EnvironmentLight::sample_many`,
/// `radiance_and_pdf_many`), since on a large map each is a cache miss.
#[allow(clippy::too_many_arguments)]
pub fn environment_terms_many<const N: usize>(
    s: &Surface,
    wo: Vec3,
    brdf: &Brdf,
    env: &EnvironmentLight,
    u_light: &[[f32; 2]; N],
    u_lobe: &[f32; N],
    u_brdf: &[[f32; 2]; N],
) -> [[Option<(Vec3, Vec3)>; 2]; N] {
    let lights = env.sample_many(u_light);
    let drawn: [_; N] = std::array::from_fn(|i| brdf_direction(s, wo, brdf, u_lobe[i], u_brdf[i]));
    let lit = env.radiance_and_pdf_many(&drawn.map(|d| d.map(|(b, _)| b.wi)));
    std::array::from_fn(|i| {
        let light = light_term(s, wo, brdf, lights[i]);
        [light, drawn[i].and_then(|(b, cos)| brdf_term(&b, cos, lit[i]))]
    })
}

/// The light-sampled term of `environment_terms`, from the light's sample (None: nothing drawn).
#[inline]
fn light_term(s: &Surface, wo: Vec3, brdf: &Brdf, sample: Option<EnvironmentSample>) -> Option<(Vec3, Vec3)> {
    let es = sample?;
    let cos = s.ns.dot(es.wi);
    if !(cos > 0.0 && s.ng.dot(es.wi) > 0.0) {
        return None;
    }
    let (f, brdf_pdf) = brdf.eval_and_pdf(wo, es.wi, s.ns);
    if f == Vec3::ZERO || es.radiance == Vec3::ZERO {
        return None;
    }
    let w = power_heuristic(es.pdf, brdf_pdf);
    Some((f * es.radiance * (cos * w / es.pdf), es.wi))
}

/// The BRDF's direction for the BRDF-sampled term of `environment_terms` and its cosine; None
/// where the term is zero whatever the light (below either horizon, or f = 0).
#[inline]
fn brdf_direction(s: &Surface, wo: Vec3, brdf: &Brdf, u_lobe: f32, u_brdf: [f32; 2]) -> Option<(BrdfSample, f32)> {
    let b = brdf.sample(wo, s.ns, u_lobe, u_brdf)?;
    let cos = s.ns.dot(b.wi);
    (cos > 0.0 && s.ng.dot(b.wi) > 0.0 && b.f != Vec3::ZERO).then_some((b, cos))
}

/// The BRDF-sampled term from its direction, cosine and the light's `(radiance, pdf)` there.
#[inline]
fn brdf_term(b: &BrdfSample, cos: f32, (radiance, env_pdf): (Vec3, f32)) -> Option<(Vec3, Vec3)> {
    if radiance == Vec3::ZERO {
        return None;
    }
    let w = power_heuristic(b.pdf, env_pdf);
    Some((b.f * radiance * (cos * w / b.pdf), b.wi))
}

/// The light of one light sample `ls` reflected at `s` towards `wo` (f cos weight, 0 where
/// occluded) and the shadow rays traced (0 or 1).
pub fn light_sample_radiance(scene: &Scene, s: &Surface, wo: Vec3, brdf: &Brdf, ls: &LightSample) -> (Vec3, u32) {
    // Light below the geometric horizon cannot arrive without crossing the surface.
    let cos = s.ns.dot(ls.wi);
    if cos <= 0.0 || s.ng.dot(ls.wi) <= 0.0 {
        return (Vec3::ZERO, 0);
    }
    let f = brdf.eval(wo, ls.wi, s.ns);
    if f == Vec3::ZERO {
        return (Vec3::ZERO, 0);
    }
    if scene.occluded(s, ls.point) {
        (Vec3::ZERO, 1)
    } else {
        (f * ls.weight * cos, 1)
    }
}

/// What a render estimates at each pixel.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Integrand {
    /// Light arriving at the camera.
    #[default]
    Radiance,
    /// Ambient occlusion: the fraction of the cosine-weighted hemisphere above the visible
    /// point that no geometry nearer than `max_distance` (internal units; infinite for no
    /// limit) covers. The AAF indirect paper's extension (Sec. 6) with reflector radiance 1.
    AmbientOcclusion { max_distance: f32 },
}

/// Emission seen directly by a camera ray at `s`.
pub fn emitted(scene: &Scene, s: &Surface, wo: Vec3) -> Vec3 {
    match scene.materials[s.material as usize] {
        Material::Emitter { light } => match &scene.lights[light as usize] {
            Light::Rect(r) => r.emitted(s.p, wo),
            Light::Point(_) | Light::Environment(_) => Vec3::ZERO,
        },
        _ => Vec3::ZERO,
    }
}

/// Traces one camera path with up to `bounces` indirect bounces.
pub fn trace_path(scene: &Scene, origin: Vec3, dir: Vec3, bounces: u32, sampler: &mut PixelSampler) -> PathResult {
    let Some(s) = scene.intersect(origin, dir, 0.0) else {
        return PathResult { radiance: scene.background(dir), rays: 1 };
    };
    let mut r = radiance_from(scene, s, -dir, bounces, sampler, DirectLights::All);
    r.rays += 1;
    r
}

/// One sample of `integrand` for a camera ray (towards -`wo`) that found `hit` (None: it left
/// the scene and sees the background; occlusion counts that as 0, no surface). The rays
/// counted exclude the camera ray.
pub fn sample_from(
    scene: &Scene,
    hit: Option<Surface>,
    wo: Vec3,
    integrand: Integrand,
    bounces: u32,
    sampler: &mut PixelSampler,
) -> PathResult {
    let Some(s) = hit else {
        let background = if integrand == Integrand::Radiance { scene.background(-wo) } else { Vec3::ZERO };
        return PathResult { radiance: background, rays: 0 };
    };
    match integrand {
        Integrand::Radiance => radiance_from(scene, s, wo, bounces, sampler, DirectLights::All),
        // The open fraction: 1 when a cosine-distributed ray escapes.
        Integrand::AmbientOcclusion { max_distance } => {
            let (z, rays) = occlusion_ray(scene, &s, sampler.next_2d(), max_distance);
            PathResult { radiance: Vec3::splat(if z.is_some() { 0.0 } else { 1.0 }), rays }
        }
    }
}

/// Traces the cosine-distributed ray of `u` about the shading normal of `s`: the hit distance
/// within `max_distance` (None: the ray escapes) and the rays traced. A direction below the
/// geometric surface (possible where shading and geometric normals differ) counts as a hit at
/// distance 0: it cannot leave the surface.
pub fn occlusion_ray(scene: &Scene, s: &Surface, u: [f32; 2], max_distance: f32) -> (Option<f32>, u32) {
    let wi = to_world(s.ns, cosine_hemisphere(u));
    if s.ng.dot(wi) <= 0.0 {
        return (Some(0.0), 0);
    }
    (scene.geometry.intersect(s.spawn_origin(), wi, 0.0, max_distance).map(|h| h.t), 1)
}

/// Radiance leaving the first hit `first` towards `wo` (emission, direct light of the lights
/// `first_direct` selects, then up to `bounces` indirect bounces with all lights). Rays counted
/// exclude the camera ray that found `first`.
pub fn radiance_from(
    scene: &Scene,
    first: Surface,
    wo: Vec3,
    bounces: u32,
    sampler: &mut PixelSampler,
    first_direct: DirectLights,
) -> PathResult {
    let (direct, rays) = direct_light_of(scene, &first, wo, sampler, first_direct);
    let mut path = path_on(scene, first, wo, bounces, sampler, emitted(scene, &first, wo) + direct);
    path.rays += rays;
    path
}

/// A camera sample's light with its path split at the first hit (splitting, as in branched path
/// tracing): the emission and direct light of `first` once, drawn from `sampler`, which is
/// returned; and the `bounces` on from `first` once per sampler of `splits`, each path's light
/// and rays into the same entry of `paths`. The sample's estimate is the first part plus the
/// paths' mean. Each path draws what `radiance_from` draws after the first hit's lights.
pub fn radiance_split(
    scene: &Scene,
    first: Surface,
    wo: Vec3,
    bounces: u32,
    sampler: &mut PixelSampler,
    splits: &mut [PixelSampler],
    paths: &mut [PathResult],
) -> PathResult {
    let (direct, rays) = direct_light_of(scene, &first, wo, sampler, DirectLights::All);
    for (split, path) in splits.iter_mut().zip(paths) {
        *path = path_on(scene, first, wo, bounces, split, Vec3::ZERO);
    }
    PathResult { radiance: emitted(scene, &first, wo) + direct, rays }
}

/// The light the path from `s` (seen from `wo`) gathers in `bounces` bounces: each bounce's
/// BRDF-sampled direction, then the direct light of the vertex it finds, added to `radiance` in
/// path order. Rays counted: the bounces' and their vertices' shadow rays.
pub fn path_on(
    scene: &Scene,
    s: Surface,
    wo: Vec3,
    bounces: u32,
    sampler: &mut PixelSampler,
    radiance: Vec3,
) -> PathResult {
    let (mut s, mut wo, mut radiance) = (s, wo, radiance);
    let mut rays = 0;
    let mut throughput = Vec3::ONE;
    for _ in 0..bounces {
        let brdf = scene.materials[s.material as usize].brdf(s.uv);
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(b) = brdf.sample(wo, s.ns, u_lobe, u) else { break };
        if s.ng.dot(b.wi) <= 0.0 {
            break;
        }
        throughput *= b.f * (s.ns.dot(b.wi) / b.pdf);
        if throughput == Vec3::ZERO || !throughput.is_finite() {
            break;
        }
        rays += 1;
        let Some(next) = scene.intersect(s.spawn_origin(), b.wi, 0.0) else { break };
        if matches!(scene.materials[next.material as usize], Material::Emitter { .. }) {
            break;
        }
        wo = -b.wi;
        s = next;
        let (direct, shadow_rays) = direct_light_of(scene, &s, wo, sampler, DirectLights::All);
        rays += shadow_rays;
        radiance += throughput * direct;
    }
    PathResult { radiance, rays }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::camera::Camera;
    use crate::render::environment::EnvironmentRadiance;
    use crate::render::light::{polygon_irradiance, EmissionProfile, PointLight, RectLight};
    use crate::render::scene::{CameraDesc, SceneBuilder};
    use crate::render::test_rng::mean_se;
    use crate::render::texture::Texture;

    /// A white Lambertian floor (albedo a) under a square light; the camera looks straight
    /// down at a floor point beside the light's footprint.
    fn floor_scene(albedo: f32, light_height: f32) -> Scene {
        let mut b = SceneBuilder::new(CameraDesc {
            position: Vec3::new(1.2, 3.0, 0.9),
            look_at: Vec3::new(1.2, 0.0, 0.9),
            up: Vec3::Z,
            vertical_fov_deg: 30.0,
            width: 9,
            height: 9,
        });
        let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(albedo)) });
        let o = b.new_object();
        let (c, u, v) = (Vec3::new(-2.0, 0.0, -2.0), Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 4.0));
        b.geometry.push([c, c + u, c + u + v], None, None, m, o);
        b.geometry.push([c, c + u + v, c + v], None, None, m, o);
        b.add_rect_light(down_light(light_height));
        b.build()
    }

    /// A 1 x 1 uniform light at height `y` over the origin, emitting downwards
    /// (edge_u x edge_v = -y).
    fn down_light(y: f32) -> RectLight {
        RectLight::new(
            Vec3::new(-0.5, y, -0.5),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::splat(2.0),
            EmissionProfile::Uniform,
        )
    }

    /// The mean red radiance of `n` paths with `bounces` through the centre pixel of the
    /// scene's own view; every path finite and non-negative.
    fn centre_radiance(scene: &Scene, bounces: u32, n: u32) -> f64 {
        let c = scene.default_view();
        let mut sum = 0.0;
        for i in 0..n {
            let mut sampler = PixelSampler::new(9, 1, i);
            let r = trace_path(scene, c.position, c.direction(4.5, 4.5), bounces, &mut sampler);
            assert!(r.radiance.is_finite() && r.radiance.min_element() >= 0.0);
            sum += r.radiance.x as f64;
        }
        sum / n as f64
    }

    #[test]
    fn direct_light_on_a_plane_matches_the_closed_form() {
        let scene = floor_scene(0.5, 1.0);
        let c = &scene.default_view();
        let dir = c.direction(4.5, 4.5);
        let s = scene.intersect(c.position, dir, 0.0).unwrap();
        let Light::Rect(r) = &scene.lights[0] else { unreachable!() };
        let quad = [r.corner, r.corner + r.edge_u, r.corner + r.edge_u + r.edge_v, r.corner + r.edge_v];
        // Outgoing radiance of a Lambertian receiver: albedo/pi * L * E(unit radiance).
        let exact = 0.5 / std::f64::consts::PI * 2.0 * polygon_irradiance(s.p, s.ns, &quad);
        let n = 4096u32;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let mut sampler = PixelSampler::new(42, 0, i);
            let (l, rays) = direct_light(&scene, &s, -dir, &mut sampler);
            assert_eq!(rays, 1);
            sum += l.x as f64;
            sum2 += (l.x as f64).powi(2);
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - exact).abs() < 4.0 * se + 1e-7, "mean {mean} exact {exact} se {se}");
        assert!(exact > 0.02);
    }

    #[test]
    fn occluder_blocks_direct_light_and_point_light_is_exact() {
        let mut b = SceneBuilder::new(CameraDesc {
            position: Vec3::new(0.3, 3.0, 0.1),
            look_at: Vec3::new(0.3, 0.0, 0.1),
            up: Vec3::Z,
            vertical_fov_deg: 20.0,
            width: 3,
            height: 3,
        });
        let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::ONE) });
        let (c, u, v) = (Vec3::new(-2.0, 0.0, -2.0), Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 4.0));
        b.geometry.push([c, c + u, c + u + v], None, None, m, 0);
        b.geometry.push([c, c + u + v, c + v], None, None, m, 0);
        // An occluder at height 1 over x in [-0.85, -0.3]: it shadows the floor point
        // (-1.5, 0, 0.1) from the light at (0.3, 2, 0.1) (the shadow ray crosses y = 1 at
        // x = -0.6), while the camera ray to that point passes it (at x = -0.9).
        let (c, u, v) = (Vec3::new(-0.85, 1.0, -0.5), Vec3::new(0.55, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.2));
        b.geometry.push([c, c + u, c + u + v], None, None, m, 1);
        b.geometry.push([c, c + u + v, c + v], None, None, m, 1);
        b.lights.push(Light::Point(PointLight { position: Vec3::new(0.3, 2.0, 0.1), intensity: Vec3::splat(4.0) }));
        let scene = b.build();
        let c = &scene.default_view();
        let dir = c.direction(1.5, 1.5);
        let s = scene.intersect(c.position, dir, 0.0).unwrap();
        let (l, _) = direct_light(&scene, &s, -dir, &mut PixelSampler::new(0, 0, 0));
        // E = I / r^2 = 4 / 4 = 1 at normal incidence; L = albedo/pi * E.
        assert!((l.x - 1.0 / std::f32::consts::PI).abs() < 1e-5, "{l}");
        // The shadowed point: on the floor, and no light at all.
        let k = scene.world_scale;
        let target = (Vec3::new(-1.5, 0.0, 0.1) - scene.origin) * k;
        let dir = (target - c.position).normalize();
        let s = scene.intersect(c.position, dir, 0.0).unwrap();
        assert!((s.p - target).length() < 1e-4 * k, "the camera ray hit {} not the floor", s.p);
        let (l, _) = direct_light(&scene, &s, -dir, &mut PixelSampler::new(0, 0, 0));
        assert_eq!(l, Vec3::ZERO);
        // A lit point off-centre, (-0.1, 0, 0.1): its shadow ray crosses y = 1 at x = 0.1 and
        // its camera ray at x = 0.03, both beside the occluder. The exact inverse-square light:
        // L = albedo / pi * I cos / r^2, r^2 = 0.4^2 + 2^2, cos = 2 / r.
        let target = (Vec3::new(-0.1, 0.0, 0.1) - scene.origin) * k;
        let dir = (target - c.position).normalize();
        let s = scene.intersect(c.position, dir, 0.0).unwrap();
        assert!((s.p - target).length() < 1e-4 * k);
        let (l, _) = direct_light(&scene, &s, -dir, &mut PixelSampler::new(0, 0, 0));
        let r2 = 0.4f32 * 0.4 + 2.0 * 2.0;
        let expected = 4.0 * (2.0 / r2.sqrt()) / r2 / std::f32::consts::PI;
        assert!((l.x - expected).abs() < 1e-4, "{l} vs {expected}");
    }

    /// A closed cube of albedo `albedo`, 4 units wide (y from 0 to 4), and a small square light
    /// at height `light_y` facing down (under the ceiling: inside); the camera inside looks
    /// down at the floor.
    fn closed_box(albedo: f32, light_y: f32) -> Scene {
        let mut b = SceneBuilder::new(CameraDesc {
            // Off the floor's diagonal: a ray through the edge two triangles share can miss
            // both (the triangle test is not watertight).
            position: Vec3::new(0.5, 3.0, 0.3),
            look_at: Vec3::new(0.5, 0.0, 0.3),
            up: Vec3::Z,
            vertical_fov_deg: 30.0,
            width: 9,
            height: 9,
        });
        let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(albedo)) });
        let o = b.new_object();
        let quad = |b: &mut SceneBuilder, c: Vec3, u: Vec3, v: Vec3| {
            b.geometry.push([c, c + u, c + u + v], None, None, m, o);
            b.geometry.push([c, c + u + v, c + v], None, None, m, o);
        };
        let (x, y, z) = (Vec3::X * 4.0, Vec3::Y * 4.0, Vec3::Z * 4.0);
        let lo = Vec3::new(-2.0, 0.0, -2.0);
        let hi = lo + x + y + z;
        quad(&mut b, lo, x, z);
        quad(&mut b, lo, y, x);
        quad(&mut b, lo, z, y);
        quad(&mut b, hi, -z, -x);
        quad(&mut b, hi, -x, -y);
        quad(&mut b, hi, -y, -z);
        b.add_rect_light(down_light(light_y));
        b.build()
    }

    #[test]
    fn no_light_leaks_into_a_closed_box_through_its_edges_and_corners() {
        // The box of `closed_box` with its light outside, above the ceiling: every path from a
        // camera inside must stay black, whatever the bounces, including at the inside edges
        // and the corner it looks into, where shadow and bounce rays start next to a second
        // wall.
        let scene = closed_box(0.8, 4.5);
        let k = scene.world_scale;
        let at = |p: Vec3| (p - scene.origin) * k;
        let cam = Camera::new(at(Vec3::new(0.3, 2.1, 0.2)), at(Vec3::new(-2.0, 0.0, -2.0)), Vec3::Y, 60.0, 16, 16);
        for y in 0..16 {
            for x in 0..16 {
                for i in 0..64 {
                    let mut sampler = PixelSampler::new(5, (y * 16 + x) as u32, i);
                    let j = sampler.next_2d();
                    let dir = cam.direction(x as f32 + j[0], y as f32 + j[1]);
                    let r = trace_path(&scene, cam.position, dir, 3, &mut sampler);
                    assert_eq!(r.radiance, Vec3::ZERO, "light leaked in at pixel ({x}, {y}), sample {i}");
                }
            }
        }
    }

    #[test]
    fn bounces_add_the_light_a_closed_box_reflects() {
        // Each bounce adds light reflected off the walls; in a closed box of albedo a the
        // added light shrinks geometrically (each order is about a times the one before), and
        // all orders together stay below the direct light's 1/(1-a) times.
        let a = 0.5f32;
        let scene = closed_box(a, 3.9);
        let lit = [0, 1, 2, 3].map(|bounces| centre_radiance(&scene, bounces, 4096));
        let added: Vec<f64> = lit.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(added[0] > 0.2 * a as f64 * lit[0], "one bounce adds too little: {lit:?}");
        assert!(added[1] > 0.0 && added[1] < 0.9 * added[0], "{lit:?}");
        assert!(added[2] > 0.0 && added[2] < 0.9 * added[1], "{lit:?}");
        assert!(lit[3] < lit[0] / (1.0 - a as f64), "{lit:?}");
    }

    /// Splitting at the first hit estimates what one path does: in the closed box the mean of
    /// samples of k paths each (the first part plus the paths' mean) agrees with unsplit paths'
    /// within the noise at 1 and 2 bounces, more paths per sample give less noise, and the
    /// first part alone is the bounceless estimate bit for bit.
    #[test]
    fn split_paths_estimate_what_one_path_does() {
        let scene = closed_box(0.5, 3.9);
        let c = scene.default_view();
        let dir = c.direction(4.5, 4.5);
        let hit = scene.intersect(c.position, dir, 0.0).expect("the camera sees the floor");
        let split_key = PixelSampler::split_key(PixelSampler::pixel_key(9, 1));
        let n = 2048;
        for bounces in [1, 2] {
            let one = mean_se(n, |i| {
                trace_path(&scene, c.position, dir, bounces, &mut PixelSampler::new(9, 1, i)).radiance.x as f64
            });
            let mut errors = Vec::new();
            for k in [1usize, 4] {
                let split = mean_se(n, |i| {
                    let mut sampler = PixelSampler::new(9, 1, i);
                    let mut splits = [PixelSampler::new(0, 0, 0); 4];
                    let mut paths = [PathResult::default(); 4];
                    PixelSampler::consecutive(split_key, i * k as u32, &mut splits[..k]);
                    let first =
                        radiance_split(&scene, hit, -dir, bounces, &mut sampler, &mut splits[..k], &mut paths[..k]);
                    let alone = trace_path(&scene, c.position, dir, 0, &mut PixelSampler::new(9, 1, i));
                    assert_eq!(first.radiance, alone.radiance, "sample {i}: the first part");
                    let rest: f32 = paths[..k].iter().map(|p| p.radiance.x).sum();
                    (first.radiance.x + rest / k as f32) as f64
                });
                let se = (one.1 * one.1 + split.1 * split.1).sqrt();
                assert!((split.0 - one.0).abs() < 4.0 * se, "bounces {bounces}, k {k}: {split:?} vs {one:?}");
                errors.push(split.1);
            }
            assert!(errors[1] < 0.8 * errors[0], "bounces {bounces}: standard errors {errors:?}");
        }
    }

    /// A 4 x 4 floor of `material` under the environment light alone, seen from above.
    fn floor_under(env: EnvironmentLight, material: Material) -> Scene {
        let mut b = SceneBuilder::new(CameraDesc {
            position: Vec3::new(0.2, 3.0, 0.1),
            look_at: Vec3::new(0.2, 0.0, 0.1),
            up: Vec3::Z,
            vertical_fov_deg: 30.0,
            width: 9,
            height: 9,
        });
        let m = b.add_material(material);
        let (c, u, v) = (Vec3::new(-2.0, 0.0, -2.0), Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 4.0));
        b.geometry.push([c, c + u + v, c + u], None, None, m, 0);
        b.geometry.push([c, c + v, c + u + v], None, None, m, 0);
        b.lights.push(Light::Environment(env));
        b.build()
    }

    fn constant_sky(l: f32) -> EnvironmentLight {
        EnvironmentLight::new(EnvironmentRadiance::Constant(Vec3::splat(l)), 1.0, Vec3::Y, 0.0)
    }

    #[test]
    fn a_white_furnace_reflects_its_albedo_at_any_bounce_count() {
        // A plane under a constant sky sees the whole upper hemisphere: a Lambertian surface of
        // albedo a sends back a L, and its bounce rays all escape, adding nothing more.
        let (a, l) = (0.8f32, 0.7f32);
        let scene = floor_under(constant_sky(l), Material::Lambertian { albedo: Texture::Constant(Vec3::splat(a)) });
        for bounces in [0, 2] {
            let (mean, se) = mean_se(4096, |i| {
                let c = scene.default_view();
                let mut sampler = PixelSampler::new(3, 40, i);
                trace_path(&scene, c.position, c.direction(4.5, 4.5), bounces, &mut sampler).radiance.x as f64
            });
            let exact = (a * l) as f64;
            assert!((mean - exact).abs() < 4.0 * se + 1e-6, "bounces {bounces}: {mean} +- {se} vs {exact}");
        }
        // A camera ray that leaves the scene sees the sky itself.
        let c = scene.default_view();
        let up = trace_path(&scene, c.position, Vec3::Y, 1, &mut PixelSampler::new(3, 0, 0));
        assert_eq!(up.radiance, Vec3::splat(l));
    }

    #[test]
    fn light_and_brdf_sampling_combine_without_bias() {
        // environment_direct against each strategy alone, with many samples, on a glossy floor
        // under a smooth map and under a one-texel sun: the three means agree. A weight that
        // does not sum to one over the two strategies would move the combined mean.
        use crate::render::environment::LatLongMap;
        use std::sync::Arc;
        let (w, h) = (32, 16);
        let smooth: Vec<Vec3> = (0..w * h).map(|i| Vec3::new(0.5 + (i % w) as f32 / w as f32, 1.0, 0.8)).collect();
        let mut sun = vec![Vec3::splat(0.01); w * h];
        sun[4 * w + 9] = Vec3::splat(500.0);
        let glossy = Material::Glossy {
            diffuse: Texture::Constant(Vec3::splat(0.2)),
            specular: Texture::Constant(Vec3::splat(0.6)),
            exponent: Texture::Constant(60.0),
            model: crate::render::material::GlossyModel::Phong,
        };
        for texels in [smooth, sun] {
            let map = EnvironmentRadiance::Map(Arc::new(LatLongMap::new(w, h, texels)));
            let env = EnvironmentLight::new(map, 1.0, Vec3::Y, 20.0);
            let scene = floor_under(env.clone(), glossy.clone());
            let c = scene.default_view();
            let dir = c.direction(4.5, 4.5);
            let s = scene.intersect(c.position, dir, 0.0).unwrap();
            let brdf = scene.materials[s.material as usize].brdf(s.uv);
            let wo = -dir;
            let n = 40_000;
            let combined = mean_se(n, |i| {
                let mut p = PixelSampler::new(11, 0, i);
                let (ul, ul2, ub) = (p.next_2d(), p.next_1d(), p.next_2d());
                environment_direct(&scene, &s, wo, &brdf, &env, ul, ul2, ub).0.x as f64
            });
            let by_light = mean_se(n, |i| {
                let mut p = PixelSampler::new(12, 0, i);
                let Some(e) = env.sample(p.next_2d()) else { return 0.0 };
                let cos = s.ns.dot(e.wi).max(0.0);
                (brdf.eval(wo, e.wi, s.ns).x * e.radiance.x * cos / e.pdf) as f64
            });
            let by_brdf = mean_se(n, |i| {
                let mut p = PixelSampler::new(13, 0, i);
                let (ul, u) = (p.next_1d(), p.next_2d());
                let Some(b) = brdf.sample(wo, s.ns, ul, u) else { return 0.0 };
                (b.f.x * env.radiance(b.wi).x * s.ns.dot(b.wi) / b.pdf) as f64
            });
            for (name, other) in [("light", by_light), ("brdf", by_brdf)] {
                let tol = 4.0 * (combined.1.powi(2) + other.1.powi(2)).sqrt();
                assert!((combined.0 - other.0).abs() < tol, "{name}: {combined:?} vs {other:?}");
            }
            // And the combination is never far from the better strategy (on the sun it is
            // far better than BRDF sampling alone).
            assert!(combined.1 <= by_light.1.min(by_brdf.1) * 2.0, "{combined:?} {by_light:?} {by_brdf:?}");
        }
    }

    #[test]
    fn no_sky_leaks_into_a_closed_box() {
        let mut scene = closed_box(0.8, 4.5);
        scene.lights.push(Light::Environment(constant_sky(5.0)));
        let c = scene.default_view();
        for i in 0..256 {
            let mut sampler = PixelSampler::new(5, 7, i);
            let r = trace_path(&scene, c.position, c.direction(4.5, 4.5), 3, &mut sampler);
            assert_eq!(r.radiance, Vec3::ZERO, "sample {i}");
        }
    }

    /// `path_pairs` counts the pairs a path that runs all its bounces draws: in a closed box no
    /// path leaves early but the few whose bounce finds the light, under a rect light, a sky
    /// and with the lobe pairs of a glossy scene.
    #[test]
    fn path_pairs_counts_the_pairs_a_whole_path_draws() {
        let mut scene = closed_box(0.8, 3.9);
        for (with_sky, glossy, bounces, expected) in [
            (false, false, 0, 1),
            (false, false, 1, 4),
            (false, true, 3, 14),
            (true, false, 2, 16),
            (true, true, 1, 12),
        ] {
            scene.lights.truncate(1);
            if with_sky {
                scene.lights.push(Light::Environment(constant_sky(1.0)));
            }
            scene.glossy = glossy;
            assert_eq!(path_pairs(&scene, Integrand::Radiance, bounces), expected);
            let c = scene.default_view();
            let drawn: Vec<u32> = (0..64)
                .map(|i| {
                    let mut sampler = PixelSampler::new(8, 3, i);
                    trace_path(&scene, c.position, c.direction(4.5, 4.5), bounces, &mut sampler);
                    sampler.pairs_drawn()
                })
                .collect();
            assert!(drawn.iter().all(|&d| d <= expected as u32), "{drawn:?}");
            assert!(drawn.iter().filter(|&&d| d == expected as u32).count() > 48, "{drawn:?}");
        }
        assert_eq!(path_pairs(&scene, Integrand::AmbientOcclusion { max_distance: 1.0 }, 3), 1);
    }

    #[test]
    fn bounces_add_nothing_on_an_open_floor_and_never_go_non_finite() {
        let scene = floor_scene(0.8, 0.05);
        let lit = [0, 1, 3].map(|bounces| centre_radiance(&scene, bounces, 256));
        // An open floor has nothing to bounce light back: bounces change nothing here.
        assert!((lit[0] - lit[1]).abs() < 1e-9 * lit[0].max(1.0), "{lit:?}");
    }
}

use super::*;
use crate::render::integrator::rect_direct;
use crate::render::light::{EmissionProfile, Light};
use crate::render::material::{GlossyModel, Material};
use crate::render::sampler::PixelSampler;
use crate::render::scene::{CameraDesc, Scene, SceneBuilder};
use crate::render::test_rng::mean_se;
use crate::render::texture::Texture;

#[test]
fn the_power_heuristic_weights_sum_to_one_at_any_densities() {
    let mut densities: Vec<f32> = (-30..=30).map(|e| 10f32.powi(e)).collect();
    densities.extend([f32::MIN_POSITIVE, f32::MAX, f32::INFINITY, 0.7, 1.3]);
    for &a in &densities {
        for &b in &densities {
            let (wa, wb) = (power_heuristic(a, b), power_heuristic(b, a));
            assert!((0.0..=1.0).contains(&wa) && (0.0..=1.0).contains(&wb), "{a} {b}: {wa} {wb}");
            assert!((wa + wb - 1.0).abs() < 1e-6, "{a} {b}: {wa} + {wb}");
        }
        // A strategy that cannot draw the sample gives it all to the one that did; a sample
        // with density 0 was not drawn at all.
        assert_eq!(power_heuristic(a, 0.0), 1.0);
        assert_eq!(power_heuristic(0.0, a), 0.0);
    }
    assert!((power_heuristic(1.0, 2.0) - 0.2).abs() < 1e-7);
}

/// A rectangle of side `size` at height 1 over (-1, 1, 0), facing down.
fn light_over(size: f32, profile: Option<f32>) -> RectLight {
    let (corner, u, v) = (Vec3::new(-1.0 - size / 2.0, 1.0, -size / 2.0), Vec3::X * size, Vec3::Z * size);
    match profile {
        None => RectLight::new(corner, u, v, Vec3::splat(3.0), EmissionProfile::Uniform),
        Some(sigma) => RectLight::gaussian(corner, u, v, Vec3::splat(3.0), sigma),
    }
}

#[test]
fn a_ray_finds_the_point_and_density_light_sampling_gave() {
    let x = Vec3::new(-0.6, 0.0, 0.2);
    let skewed = RectLight::new(
        Vec3::new(-1.5, 1.0, -0.3),
        Vec3::new(0.8, 0.0, 0.0),
        Vec3::new(0.3, 0.0, 0.6),
        Vec3::ONE,
        EmissionProfile::Uniform,
    );
    for light in [light_over(0.5, None), light_over(0.6, Some(0.1)), light_over(0.6, Some(2.0)), skewed] {
        let size = light.edge_u.length();
        for i in 0..512 {
            let u = PixelSampler::new(3, 0, i).next_2d();
            let ls = light.sample(x, u).unwrap();
            let h = light.hit(x, ls.wi).expect("a sampled direction meets its light");
            assert!((h.point - ls.point).length() < 1e-5 * size, "{} vs {}", h.point, ls.point);
            assert!((h.pdf / ls.pdf - 1.0).abs() < 0.02, "pdf {} vs {}", h.pdf, ls.pdf);
            let expected = light.radiance * light.profile_weight(ls.point);
            assert!((h.radiance - expected).abs().max_element() < 1e-4 * expected.x, "{} vs {expected}", h.radiance);
        }
        // Beside the light, away from it, and from behind it: nothing.
        assert!(light.hit(x, Vec3::new(1.0, 1.0, 0.0).normalize()).is_none());
        assert!(light.hit(x, -Vec3::Y).is_none());
        assert!(light.hit(Vec3::new(-1.0, 2.0, 0.0), -Vec3::Y).is_none());
    }
}

#[test]
fn the_density_a_ray_finds_integrates_to_one_over_the_sphere() {
    // Directions uniform on the sphere: the mean of pdf / (1 / 4 pi) is the integral of the
    // density over the directions that meet the light, which is 1 when all of it is in front.
    for profile in [None, Some(0.3)] {
        let light = light_over(2.0, profile);
        let x = Vec3::new(-1.0, 0.5, 0.0);
        let n = 200_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let u = PixelSampler::new(9, 1, i).next_2d();
            let z = 1.0 - 2.0 * u[0];
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * u[1];
            let w = Vec3::new(r * phi.cos(), z, r * phi.sin());
            let v = light.hit(x, w).map_or(0.0, |h| h.pdf as f64 * 4.0 * std::f64::consts::PI);
            sum += v;
            sum2 += v * v;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - 1.0).abs() < 4.0 * se + 1e-3, "{profile:?}: {mean} +- {se}");
    }
}

/// A floor of `material` (y = 0) seen from (1.5, 1.5, 0) at the origin, whose mirror direction
/// leads to the centre of `light` (`light_over`); with `blocker`, a strip at height 0.5 that
/// hides part of the light from the origin. Returns the scene, the floor point at the origin and
/// the direction towards the camera.
fn mirror_scene(material: Material, light: RectLight, blocker: bool) -> (Scene, Surface, Vec3) {
    let mut b = SceneBuilder::new(CameraDesc {
        position: Vec3::new(1.5, 1.5, 0.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vertical_fov_deg: 20.0,
        width: 9,
        height: 9,
    });
    let m = b.add_material(material);
    let o = b.new_object();
    let (c, u, v) = (Vec3::new(-3.0, 0.0, -3.0), Vec3::new(6.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 6.0));
    b.geometry.push([c, c + u + v, c + u], None, None, m, o);
    b.geometry.push([c, c + v, c + u + v], None, None, m, o);
    if blocker {
        let (c, u, v) = (Vec3::new(-0.5, 0.5, -1.0), Vec3::new(0.15, 0.0, 0.0), Vec3::new(0.0, 0.0, 2.0));
        let o = b.new_object();
        b.geometry.push([c, c + u + v, c + u], None, None, m, o);
        b.geometry.push([c, c + v, c + u + v], None, None, m, o);
    }
    b.add_rect_light(light);
    let scene = b.build();
    let view = scene.default_view();
    let dir = view.direction(4.5, 4.5);
    let s = scene.intersect(view.position, dir, 0.0).expect("the camera sees the floor");
    (scene, s, -dir)
}

fn glossy(kd: f32, ks: f32, exponent: f32, model: GlossyModel) -> Material {
    Material::Glossy {
        diffuse: Texture::Constant(Vec3::splat(kd)),
        specular: Texture::Constant(Vec3::splat(ks)),
        exponent: Texture::Constant(exponent),
        model,
    }
}

/// The three estimators of the light's direct light on the floor point of `mirror_scene`:
/// both strategies combined, light sampling alone, the lobe alone (the glossy part only).
fn three_estimates(material: Material, light: RectLight, blocker: bool, n: u32) -> [(f64, f64); 3] {
    let (scene, s, wo) = mirror_scene(material, light, blocker);
    assert!(scene.glossy);
    let Light::Rect(rect) = &scene.lights[0] else { unreachable!() };
    let brdf = scene.materials[s.material as usize].brdf(s.uv);
    let combined = mean_se(n, |i| {
        let mut p = PixelSampler::new(21, 0, i);
        let (ul, ub) = (p.next_2d(), p.next_2d());
        rect_direct(&scene, &s, wo, &brdf, rect, ul, Some(ub)).0.x as f64
    });
    let by_light = mean_se(n, |i| {
        let mut p = PixelSampler::new(22, 0, i);
        rect_direct(&scene, &s, wo, &brdf, rect, p.next_2d(), None).0.x as f64
    });
    let by_lobe = mean_se(n, |i| {
        let mut p = PixelSampler::new(23, 0, i);
        let Some(wi) = brdf.sample_lobe_direction(wo, s.ns, p.next_2d()) else { return 0.0 };
        let Some(h) = rect.hit(s.p, wi) else { return 0.0 };
        if scene.occluded(&s, h.point) {
            return 0.0;
        }
        let (f, pdf) = brdf.specular_and_pdf(wo, wi, s.ns);
        (f.x * h.radiance.x * s.ns.dot(wi) / pdf) as f64
    });
    [combined, by_light, by_lobe]
}

fn agree(a: (f64, f64), b: (f64, f64)) -> bool {
    (a.0 - b.0).abs() < 4.0 * (a.1.powi(2) + b.1.powi(2)).sqrt()
}

#[test]
fn a_near_mirror_reflecting_a_light_is_found_by_its_lobe() {
    // A Phong lobe of exponent 10,000 is about 0.01 rad wide; the light spans 0.25 rad. Light
    // samples rarely land in the lobe; lobe samples nearly always find the light.
    for model in [GlossyModel::Phong, GlossyModel::BlinnPhong] {
        let [combined, by_light, by_lobe] =
            three_estimates(glossy(0.0, 0.8, 1e4, model), light_over(0.5, None), false, 8192);
        assert!(combined.0 > 0.1, "{model:?}: {combined:?}");
        assert!(
            agree(combined, by_light) && agree(combined, by_lobe),
            "{model:?}: {combined:?} {by_light:?} {by_lobe:?}"
        );
        assert!(combined.1 < 0.1 * by_light.1, "{model:?}: {combined:?} vs light sampling {by_light:?}");
        // Lobe sampling alone is nearly exact here (every sample finds the light at almost the
        // same weight); the combination keeps a little of the light samples' noise where the
        // lobe's tail is thinner than the light's density, and stays within 0.5% of the mean.
        assert!(combined.1 < 0.005 * combined.0, "{model:?}: {combined:?} vs lobe sampling {by_lobe:?}");
    }
}

#[test]
fn a_broad_lobe_under_a_small_light_keeps_light_sampling() {
    let [combined, by_light, by_lobe] =
        three_estimates(glossy(0.0, 0.8, 2.0, GlossyModel::Phong), light_over(0.1, None), false, 8192);
    assert!(agree(combined, by_light) && agree(combined, by_lobe), "{combined:?} {by_light:?} {by_lobe:?}");
    assert!(combined.1 < 1.5 * by_light.1, "{combined:?} vs light sampling {by_light:?}");
    assert!(combined.1 < 0.2 * by_lobe.1, "{combined:?} vs lobe sampling {by_lobe:?}");
}

#[test]
fn the_combination_is_unbiased_with_shadows_profiles_and_a_diffuse_part() {
    // A strip hides part of a Gaussian light; the BRDF adds a diffuse part, which light
    // sampling estimates alone. The combined mean must equal light sampling's.
    for (kd, exponent) in [(0.3, 100.0), (0.1, 3000.0)] {
        for model in [GlossyModel::Phong, GlossyModel::BlinnPhong] {
            let m = glossy(kd, 0.5, exponent, model);
            let [combined, by_light, _] = three_estimates(m, light_over(0.6, Some(0.15)), true, 16384);
            assert!(agree(combined, by_light), "{kd} {exponent} {model:?}: {combined:?} {by_light:?}");
            assert!(combined.1 <= 1.2 * by_light.1, "{kd} {exponent} {model:?}: {combined:?} {by_light:?}");
        }
    }
}

#[test]
fn several_light_samples_share_one_lobe_sample_without_bias() {
    // `auto` draws k light samples in a penumbra, each weighing 1/k, and one lobe sample; the
    // weights count k (Veach's multi-sample heuristic). The mean must stay light sampling's.
    let (scene, s, wo) = mirror_scene(glossy(0.1, 0.6, 300.0, GlossyModel::BlinnPhong), light_over(0.5, None), true);
    let Light::Rect(rect) = &scene.lights[0] else { unreachable!() };
    let brdf = scene.materials[s.material as usize].brdf(s.uv);
    let n = 16384;
    let by_light = mean_se(n, |i| {
        let mut p = PixelSampler::new(31, 0, i);
        rect_direct(&scene, &s, wo, &brdf, rect, p.next_2d(), None).0.x as f64
    });
    for k in [2u32, 4, 16] {
        let combined = mean_se(n, |i| {
            let mut p = PixelSampler::new(32, 0, i);
            let (ul, ub) = (p.next_2d(), p.next_2d());
            let mut sum = shadowed_lobe_term(&scene, &s, wo, &brdf, rect, ub, k).0.x as f64;
            for r in 0..k {
                // Independent points on the light, one per light sample.
                let u = PixelSampler::new(33 + r as u64, 0, i).next_2d();
                let u = if r == 0 { ul } else { u };
                let Some(ls) = rect.sample(s.p, u) else { continue };
                let Some((d, g)) = light_terms(&brdf, &s, wo, &ls, true, k) else { continue };
                if !scene.occluded(&s, ls.point) {
                    sum += (d.x + g.x) as f64 / k as f64;
                }
            }
            sum
        });
        assert!(agree(combined, by_light), "k {k}: {combined:?} vs {by_light:?}");
    }
}

#[test]
fn extreme_lobes_and_grazing_views_stay_finite() {
    for (exponent, model) in
        [0.0, 1.0, 1e3, 1e6].into_iter().flat_map(|m| [(m, GlossyModel::Phong), (m, GlossyModel::BlinnPhong)])
    {
        let (scene, s, _) = mirror_scene(glossy(0.2, 0.7, exponent, model), light_over(0.5, None), true);
        let Light::Rect(rect) = &scene.lights[0] else { unreachable!() };
        let brdf = scene.materials[s.material as usize].brdf(s.uv);
        // Views from the mirror direction's exact opposite down to a grazing one.
        for wo in [Vec3::new(1.0, 1.0, 0.0).normalize(), Vec3::new(1.0, 1e-4, 0.0).normalize(), Vec3::X] {
            for i in 0..256 {
                let mut p = PixelSampler::new(5, 0, i);
                let (ul, ub) = (p.next_2d(), p.next_2d());
                let (l, rays) = rect_direct(&scene, &s, wo, &brdf, rect, ul, Some(ub));
                assert!(l.is_finite() && l.min_element() >= 0.0, "{model:?} m {exponent} wo {wo}: {l}");
                assert!(rays <= 2);
            }
        }
    }
}

#[test]
fn only_scenes_with_a_glossy_lobe_draw_the_lobe_sample() {
    use crate::render::integrator::LightDims;
    let lambert = Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.5)) };
    let black_lobe = glossy(0.5, 0.0, 10.0, GlossyModel::Phong);
    for (material, lobe) in [(lambert, false), (black_lobe, false), (glossy(0.5, 0.2, 10.0, GlossyModel::Phong), true)]
    {
        let (scene, _, _) = mirror_scene(material, light_over(0.5, None), false);
        assert_eq!(scene.glossy, lobe);
        // The rect light's numbers: a pair for the light, and a pair for the lobe only when the
        // scene has one; the stream after them moves by exactly that.
        let mut a = PixelSampler::new(1, 2, 3);
        let dims = LightDims::draw(&scene.lights[0], scene.glossy, &mut a);
        assert_eq!(dims.lobe.is_some(), lobe);
        let mut b = PixelSampler::new(1, 2, 3);
        for _ in 0..1 + u32::from(lobe) {
            b.next_2d();
        }
        assert_eq!(a.next_2d(), b.next_2d());
    }
}

//! Multiple importance sampling (Veach 1997, Ch. 9): the power heuristic, and the direct light of
//! a rectangular light by two strategies.
//!
//! A rect light's direct light is estimated by light sampling (`RectLight::sample`), which suits
//! a diffuse surface. A glossy lobe narrower than the light as seen from the surface (a
//! near-mirror reflecting a light) is another matter: light samples rarely fall inside the lobe,
//! and those that do carry huge weights, so the pixel stays noisy for thousands of samples. The
//! glossy part of the BRDF (ks times the lobe) therefore has a second strategy: a direction drawn
//! from the lobe (`Brdf::sample_lobe_direction`) that finds the light by a ray-rectangle test
//! (`RectLight::hit`) and is then shadow-tested (`shadowed_lobe_term`). The power heuristic
//! combines the two (`light_terms`, `shadowed_lobe_term`), so each direction is counted mostly by the
//! strategy that draws it more densely.
//!
//! The diffuse part keeps light sampling alone, with weight 1: the weights of each integrand sum
//! to one over its own strategies, and the diffuse integrand has one. Light sampling is the
//! better strategy for a cosine lobe under a light, and the AAF filters are defined on its
//! samples (Mehta et al. 2012, Eq. 10).
//!
//! Only scenes with a glossy lobe draw the lobe sample's numbers (`Scene::glossy`), so a diffuse
//! scene keeps its sample streams, its images and its speed. Where a camera sample draws several
//! light samples (`auto`'s penumbrae) they share one lobe sample, and the weights count them.
use super::light::{LightSample, RectLight};
use super::material::Brdf;
use super::scene::{Scene, Surface};
use glam::Vec3;

/// The power heuristic (beta = 2, Veach 1997 Sec. 9.2.4) for a sample drawn with density `a`
/// that the other strategy would draw with density `b` (each already multiplied by its
/// strategy's sample count), in a ratio form that neither overflows nor divides 0 by 0
/// (a > 0 for any drawn sample; an infinite `b` gives 0, an infinite `a` 1).
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    if !(a > 0.0) {
        return 0.0;
    }
    let r = b / a;
    if r.is_nan() {
        // Both infinite: neither strategy is preferred.
        return 0.5;
    }
    1.0 / (1.0 + r * r)
}

/// The diffuse integrand u = kd/pi Le G / pdf of light sample `ls` at `s` seen from `wo` (AAF's
/// visibility weight, Mehta et al. 2012 Eq. 10) and its glossy one, before visibility. With
/// `lobe_strategy` the glossy one is weighed against one lobe sample and `n_light` light
/// samples (Veach's multi-sample power heuristic, counts included); the diffuse one has light
/// sampling alone. None where the sample is below the surface's horizon, carries nothing, or is
/// not finite (then it needs no shadow ray).
#[inline]
pub fn light_terms(
    brdf: &Brdf,
    s: &Surface,
    wo: Vec3,
    ls: &LightSample,
    lobe_strategy: bool,
    n_light: u32,
) -> Option<(Vec3, Vec3)> {
    let cos = s.ns.dot(ls.wi);
    if cos <= 0.0 || s.ng.dot(ls.wi) <= 0.0 {
        return None;
    }
    // kd/pi where the BRDF is defined: nothing where the shading normal faces away from the viewer.
    let diffuse = if s.ns.dot(wo) > 0.0 { brdf.kd * (1.0 / std::f32::consts::PI) } else { Vec3::ZERO };
    let u = diffuse * ls.weight * cos;
    let (f_s, p_lobe) = brdf.specular_and_pdf(wo, ls.wi, s.ns);
    let w = if lobe_strategy { power_heuristic(n_light as f32 * ls.pdf, p_lobe) } else { 1.0 };
    let g = f_s * ls.weight * (cos * w);
    (u.is_finite() && g.is_finite() && (u != Vec3::ZERO || g != Vec3::ZERO)).then_some((u, g))
}

/// The lobe strategy's term for `rect` at `s` towards `wo` with the pair `u`: ks lobe Le cos / p,
/// weighted against `n_light` light samples, zero where its direction misses the light, leaves
/// below the surface or is occluded; and the shadow rays traced (1 where the direction meets the
/// light).
#[inline]
pub fn shadowed_lobe_term(
    scene: &Scene,
    s: &Surface,
    wo: Vec3,
    brdf: &Brdf,
    rect: &RectLight,
    u: [f32; 2],
    n_light: u32,
) -> (Vec3, u32) {
    const NOTHING: (Vec3, u32) = (Vec3::ZERO, 0);
    // Most directions miss the light: the lobe is evaluated only for those that meet it.
    let Some(wi) = brdf.sample_lobe_direction(wo, s.ns, u) else { return NOTHING };
    if s.ng.dot(wi) <= 0.0 {
        return NOTHING;
    }
    let Some(hit) = rect.hit(s.p, wi) else { return NOTHING };
    let (f, pdf) = brdf.specular_and_pdf(wo, wi, s.ns);
    if !(pdf > 0.0) {
        return NOTHING;
    }
    let w = power_heuristic(pdf, n_light as f32 * hit.pdf);
    let value = f * hit.radiance * (s.ns.dot(wi) * w / pdf);
    if value == Vec3::ZERO || !value.is_finite() {
        return NOTHING;
    }
    if scene.occluded(s, hit.point) {
        (Vec3::ZERO, 1)
    } else {
        (value, 1)
    }
}

#[cfg(test)]
mod tests;

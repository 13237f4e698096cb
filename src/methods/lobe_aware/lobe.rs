//! Per-pixel lobes (Tokuyoshi 2015, Sec. 4.1 and supplemental App. B and D): the SG that stands
//! for a pixel's reflection lobe `rho_i(w) max(n.w, 0)`, built from the G-buffer alone
//! (normal, view direction, BRDF model and exponent).
use super::asg::Asg;
use super::options::LobeOptions;
use super::sg::{Sg, LAMBDA_C};
use crate::render::material::GlossyModel;
use glam::DVec3;

/// The diffuse lobe `max(n.w, 0)` as an SG about the normal with sharpness `2 lambda_c`: its
/// normalised self-similarity through Eq. 12 is then `G(n_i, n_j, lambda_c)` at kappa = inf,
/// the fit of App. D, and with kappa it gives App. D's `sigma_n^2` exactly (methods.md §3.2).
pub fn diffuse(normal: DVec3) -> Sg {
    Sg::new(normal, 2.0 * LAMBDA_C)
}

/// The specular lobe of a glossy pixel with shading normal `n` seen from direction `psi`
/// (unit, from the surface towards the camera).
///
/// Blinn-Phong: the NDF `(m+1)/(2 pi) (n.h)^m` is the SG `G(h, n, m)` in half-vector space,
/// moved to the reflected direction by the spherical warp (App. B): axis `2 (n.psi) n - psi`,
/// sharpness `m / (4 n.psi)`. Phong's lobe `cos^m` of the angle to the mirror direction is
/// already the SG `G(w, reflect, m)`, so it needs no warp.
///
/// At grazing views `n.psi -> 0` the warped sharpness diverges: the divisor's `n.psi` is
/// clamped below at `opts.min_cos_view` (the axis stays the true mirror direction) and the
/// sharpness capped at `opts.max_sharpness` (methods.md §3.5; a huge sharpness only makes the
/// weight reject every neighbour, the centre keeps weight 1). A back-facing shading normal
/// (`n.psi < 0`) divides by `|n.psi|`, as VSGL does.
pub fn specular(model: GlossyModel, exponent: f64, n: DVec3, psi: DVec3, opts: &LobeOptions) -> Sg {
    let cos = n.dot(psi);
    let axis = 2.0 * cos * n - psi;
    let axis = if axis.length_squared() > 0.0 { axis } else { n };
    let m = exponent.max(0.0);
    let sharpness = match model {
        GlossyModel::BlinnPhong => m / (4.0 * cos.abs().max(opts.min_cos_view)),
        GlossyModel::Phong => m,
    };
    Sg::new(axis, sharpness.min(opts.max_sharpness))
}

/// The specular lobe of a glossy pixel with shading normal `n` seen from `psi` (unit, towards
/// the camera), as an ASG: App. B's spherical warp without averaging its two stretches.
///
/// Blinn-Phong's NDF is the SG `G(h, n, m)` in half-vector space, `exp(-(m/2) theta_h^2)` near
/// `n`. Reflection about `h` moves the reflected direction by `2 delta` for a tilt `delta` of
/// `h` in the plane of incidence and by `2 (n.psi) epsilon` for a tilt `epsilon` across it, so
/// the warped lobe about the mirror direction is the ASG of sharpness `m / 8` in the plane
/// (`y`) and `m / (8 (n.psi)^2)` across it (`x`), as BakingLab's `WarpDistributionASG`; their
/// geometric mean `m / (8 n.psi)` is half App. B's SG sharpness `m / (4 n.psi)`. Phong's lobe
/// is already about the mirror direction: the isotropic ASG of sharpness `m / 2`. The grazing
/// clamp and the cap are `specular`'s (the cap halved to ASG units).
pub fn specular_asg(model: GlossyModel, exponent: f64, n: DVec3, psi: DVec3, opts: &LobeOptions) -> Asg {
    let cos = n.dot(psi);
    let z = 2.0 * cos * n - psi;
    let z = if z.length_squared() > 0.0 { z } else { n };
    // Across the plane of incidence; any direction at normal incidence, where the lobe is round.
    let across = n.cross(z);
    let m = exponent.max(0.0);
    let cap = 0.5 * opts.max_sharpness;
    let (lx, ly) = match model {
        GlossyModel::BlinnPhong => {
            let c = cos.abs().max(opts.min_cos_view);
            (m / (8.0 * c * c), m / 8.0)
        }
        GlossyModel::Phong => (0.5 * m, 0.5 * m),
    };
    Asg::new(z, across, lx.min(cap), ly.min(cap))
}

//! The 2-D bandwidth of a local light field and how transport and reflection change it
//! (Bagher et al. 2012, Sec. 2.1, Fig. 4; after Durand et al. 2005).
//!
//! `Nu { s, a }` bounds the spectrum of the light field about a ray: the box with corners
//! (-s, -a) and (s, a) holds 95% of its power (`QUANTILE_95`). Spatial frequencies are per
//! unit length (the scene's internal units), angular ones per radian.
//!
//! The paper applies its 2 x 2 operators to the corner (s, a) itself (`M nu`). A shear of a
//! box is not a box, and with signed entries the extents can cancel: `T_d` maps (s, a) to
//! (s, a - d s), which shrinks the angular extent although a spatially varying light field
//! gains angular variation along the way. The bounding box of the image of the centred box
//! is `|M| nu` (entry-wise absolute values), under which the mirror `S` is the identity.
//! `Propagation::BoundingBox` (the default) does that; `Propagation::Signed` is the paper's
//! literal form, whose result is read as a box by taking absolute values at the end.

/// sqrt(2) erfinv(0.9): the half-width holding 95% of a unit normal spectrum's power (two
/// tails of 2.5%), the paper's quantile (Sec. 2).
pub const QUANTILE_95: f64 = 1.644_853_626_951_472_2;

/// Smallest cosine the reparameterisations divide by: at grazing angles `P_x`'s 1 / cos
/// grows without bound (methods.md §4.1), and the image-space bandwidth is clamped later.
pub const MIN_COS: f64 = 1e-3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nu {
    /// Spatial bandwidth (per unit length).
    pub s: f64,
    /// Angular bandwidth (per radian).
    pub a: f64,
}

impl Nu {
    pub const ZERO: Nu = Nu { s: 0.0, a: 0.0 };

    /// Distant light: no spatial variation, angular bandwidth `a` (Sec. 2.1).
    pub fn distant(a: f64) -> Nu {
        Nu { s: 0.0, a }
    }
}

/// How a linear operator acts on a bandwidth (see the module's comment).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Propagation {
    /// `|M| nu`: the bounding box of the transformed spectrum box.
    #[default]
    BoundingBox,
    /// `M nu`, the paper's form.
    Signed,
}

/// How the BRDF band-limits the light field at a reflection (`B_rho`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BrdfClip {
    /// Shorten the spectrum, both extents by the same factor, until its angular extent is
    /// `rho` (a departure). The spectrum of distant light is a line through the origin, and
    /// the curvature shear before the BRDF keeps it one: (c a, a). Band-limiting the angle of a
    /// line to `rho` cuts it at (c rho, rho), so its spatial extent falls with it; clipping the
    /// angle alone would leave a curved surface's spatial extent at `c a`, as sharp as the
    /// light however blurry the BRDF (a sun on a rough sphere would need every pixel shaded).
    #[default]
    Spectrum,
    /// `min(rho, a)` on the angle only, the paper's `B_{t,rho}` as printed.
    Angle,
}

/// A 2 x 2 operator on (s, a).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Op(pub [[f64; 2]; 2]);

impl Op {
    pub const IDENTITY: Op = Op([[1.0, 0.0], [0.0, 1.0]]);

    /// `T_d`: transport through free space over distance `d`.
    pub fn transport(d: f64) -> Op {
        Op([[1.0, 0.0], [-d, 1.0]])
    }

    /// `P_i`: the incident light field reparameterised onto the surface (cosine `cos_i`).
    pub fn incident(cos_i: f64) -> Op {
        Op([[cos_i.max(MIN_COS), 0.0], [0.0, 1.0]])
    }

    /// `P_x`: the reflected field reparameterised along the outgoing direction (`cos_x`).
    pub fn outgoing(cos_x: f64) -> Op {
        Op([[1.0 / cos_x.max(MIN_COS), 0.0], [0.0, 1.0]])
    }

    /// `S`: the mirror reparameterisation.
    pub fn mirror() -> Op {
        Op([[1.0, 0.0], [0.0, -1.0]])
    }

    /// `C_c`: the curvature shear (`c` per unit length).
    pub fn curvature(c: f64) -> Op {
        Op([[1.0, c], [0.0, 1.0]])
    }

    /// This operator after `first` (`self * first`).
    pub fn after(&self, first: &Op) -> Op {
        let (a, b) = (&self.0, &first.0);
        let mut m = [[0.0; 2]; 2];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = a[i][0] * b[0][j] + a[i][1] * b[1][j];
            }
        }
        Op(m)
    }

    pub fn apply(&self, nu: Nu, mode: Propagation) -> Nu {
        // A zero entry contributes nothing even from an infinite (not band-limited) input.
        let term = |m: f64, v: f64| if m == 0.0 { 0.0 } else { m * v };
        let m = match mode {
            Propagation::BoundingBox => self.0.map(|row| row.map(f64::abs)),
            Propagation::Signed => self.0,
        };
        Nu { s: term(m[0][0], nu.s) + term(m[0][1], nu.a), a: term(m[1][0], nu.s) + term(m[1][1], nu.a) }
    }
}

/// `B_{t,rho}`: the texture adds its spatial bandwidth `t`, the BRDF band-limits the angular
/// one to `rho` (its product with the light field's spectrum), as `clip` says.
pub fn texture_and_brdf(nu: Nu, t: f64, rho: f64, clip: BrdfClip) -> Nu {
    match clip {
        BrdfClip::Angle => Nu { s: nu.s + t, a: rho.min(nu.a) },
        BrdfClip::Spectrum if nu.a > rho => {
            // rho / a in [0, 1); an infinite spatial extent stays infinite unless rho is 0.
            let k = rho / nu.a;
            let s = if k == 0.0 { 0.0 } else { nu.s * k };
            Nu { s: s + t, a: rho }
        }
        BrdfClip::Spectrum => Nu { s: nu.s + t, a: nu.a },
    }
}

/// What reflection at a shading point depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reflection {
    /// Cosines of the incident and the outgoing (view) direction with the normal.
    pub cos_i: f64,
    pub cos_x: f64,
    /// Curvature (per unit length).
    pub curvature: f64,
    /// Spatial bandwidth of the texture at the point (per unit length).
    pub texture: f64,
    /// Angular bandwidth of the BRDF for this pair of directions (per radian).
    pub brdf: f64,
    pub clip: BrdfClip,
}

/// `R = P_x C_{-c} S B_{t,rho} C_c P_i` applied to an incident bandwidth (Sec. 2.1). The
/// incident cosine's convolution is neglected, as in the paper. The non-linear `B` is applied
/// in its place in that order.
pub fn reflect(nu: Nu, r: &Reflection, mode: Propagation) -> Nu {
    let before = Op::curvature(r.curvature).after(&Op::incident(r.cos_i));
    let nu = texture_and_brdf(before.apply(nu, mode), r.texture, r.brdf, r.clip);
    let after = Op::outgoing(r.cos_x).after(&Op::curvature(-r.curvature)).after(&Op::mirror());
    after.apply(nu, mode)
}

/// Eq. 3 for distant light: the bandwidth arriving at the eye after one reflection, `d_eye`
/// away, of light of angular bandwidth `light_a` (`T_d` from a distant light changes
/// nothing: its spatial bandwidth is zero). Components are non-negative whatever the mode.
pub fn one_bounce(light_a: f64, r: &Reflection, d_eye: f64, mode: Propagation) -> Nu {
    let nu = Op::transport(d_eye).apply(reflect(Nu::distant(light_a), r, mode), mode);
    Nu { s: nu.s.abs(), a: nu.a.abs() }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Op, b: &Op) -> bool {
        (0..2).all(|i| (0..2).all(|j| (a.0[i][j] - b.0[i][j]).abs() < 1e-12))
    }

    #[test]
    fn the_95_percent_quantile_of_a_unit_normal_spectrum() {
        // P(|X| <= q) = erf(q / sqrt 2) = 0.9 for the two-sided 95% box of the paper.
        assert!((libm::erf(QUANTILE_95 / std::f64::consts::SQRT_2) - 0.9).abs() < 1e-12);
    }

    #[test]
    fn the_operators_compose_as_the_paper_says() {
        // T_a T_b = T_{a+b}, C_c C_{-c} = I, S^2 = I, P_x P_i = I at the same angle.
        assert!(close(&Op::transport(0.7).after(&Op::transport(1.9)), &Op::transport(2.6)));
        assert!(close(&Op::curvature(3.0).after(&Op::curvature(-3.0)), &Op::IDENTITY));
        assert!(close(&Op::mirror().after(&Op::mirror()), &Op::IDENTITY));
        assert!(close(&Op::outgoing(0.3).after(&Op::incident(0.3)), &Op::IDENTITY));
    }

    #[test]
    fn a_flat_surface_at_normal_incidence_keeps_the_band_limited_angle() {
        // c = t = 0, normal incidence and view: R gives [0, min(rho, a)] in both modes.
        for mode in [Propagation::BoundingBox, Propagation::Signed] {
            for (a, rho) in [(5.0, 20.0), (40.0, 20.0)] {
                let r = Reflection {
                    cos_i: 1.0,
                    cos_x: 1.0,
                    curvature: 0.0,
                    texture: 0.0,
                    brdf: rho,
                    clip: BrdfClip::Angle,
                };
                let nu = reflect(Nu::distant(a), &r, mode);
                assert!(nu.s.abs() < 1e-12 && (nu.a.abs() - f64::min(a, rho)).abs() < 1e-12, "{mode:?}: {nu:?}");
            }
        }
    }

    #[test]
    fn the_two_modes_agree_where_no_entry_is_negative_and_the_box_never_shrinks() {
        // Without transport, curvature or mirror the signed form has no negative entry.
        let r = Reflection { cos_i: 0.6, cos_x: 0.8, curvature: 0.0, texture: 2.0, brdf: 9.0, clip: BrdfClip::Angle };
        let (b, s) = (
            reflect(Nu::distant(4.0), &r, Propagation::BoundingBox),
            reflect(Nu::distant(4.0), &r, Propagation::Signed),
        );
        assert!((b.s - s.s.abs()).abs() < 1e-12 && (b.a - s.a.abs()).abs() < 1e-12);
        // With them, the bounding box bounds the signed corner, component by component.
        for (c, t, d) in [(0.5, 3.0, 2.0), (-1.5, 0.0, 7.0), (2.0, 10.0, 0.1)] {
            let r = Reflection { curvature: c, texture: t, ..r };
            let b = one_bounce(4.0, &r, d, Propagation::BoundingBox);
            let s = one_bounce(4.0, &r, d, Propagation::Signed);
            assert!(b.s >= s.s - 1e-12 && b.a >= s.a - 1e-12, "{b:?} vs {s:?}");
        }
        // A textured surface seen from afar: the texture's spatial detail becomes angular
        // detail at the eye (d' t), which the signed form can cancel and the box keeps.
        let r = Reflection { cos_i: 1.0, cos_x: 1.0, curvature: 0.0, texture: 10.0, brdf: 1e9, clip: BrdfClip::Angle };
        let b = one_bounce(0.0, &r, 3.0, Propagation::BoundingBox);
        assert!((b.a - 30.0).abs() < 1e-9 && (b.s - 10.0).abs() < 1e-9, "{b:?}");
    }

    #[test]
    fn grazing_views_stay_finite() {
        let r =
            Reflection { cos_i: 0.0, cos_x: -0.2, curvature: 1.0, texture: 1.0, brdf: 50.0, clip: BrdfClip::Spectrum };
        let nu = one_bounce(10.0, &r, 5.0, Propagation::BoundingBox);
        assert!(nu.s.is_finite() && nu.a.is_finite() && nu.s > 0.0 && nu.a > 0.0, "{nu:?}");
        // Non-band-limited inputs stay "large", never NaN.
        let r = Reflection { brdf: f64::INFINITY, ..r };
        let nu = one_bounce(f64::INFINITY, &r, 5.0, Propagation::BoundingBox);
        assert!(!nu.a.is_nan() && nu.a == f64::INFINITY);
    }

    #[test]
    fn clipping_the_spectrum_shortens_a_curved_surfaces_spatial_extent() {
        // A sharp light (a = 100) on a curved surface (c = 2) and a blurry BRDF (rho = 5): the
        // sheared line (200, 100) is cut at (10, 5); the angle-only clip keeps s = 200.
        let r =
            Reflection { cos_i: 1.0, cos_x: 1.0, curvature: 2.0, texture: 0.0, brdf: 5.0, clip: BrdfClip::Spectrum };
        let nu = texture_and_brdf(Nu { s: 200.0, a: 100.0 }, 0.0, 5.0, BrdfClip::Spectrum);
        assert!((nu.s - 10.0).abs() < 1e-12 && nu.a == 5.0, "{nu:?}");
        let angle = texture_and_brdf(Nu { s: 200.0, a: 100.0 }, 0.0, 5.0, BrdfClip::Angle);
        assert!(angle.s == 200.0 && angle.a == 5.0, "{angle:?}");
        // A band-limited light under a sharper BRDF is left alone; the texture adds either way.
        assert_eq!(texture_and_brdf(Nu { s: 3.0, a: 4.0 }, 1.0, 9.0, BrdfClip::Spectrum), Nu { s: 4.0, a: 4.0 });
        // A constant BRDF (rho = 0) removes all of the light's variation, infinite or not.
        assert_eq!(texture_and_brdf(Nu { s: f64::INFINITY, a: f64::INFINITY }, 0.0, 0.0, BrdfClip::Spectrum), Nu::ZERO);
        // Through the whole reflection the spectrum clip is never wider than the angle clip.
        for c in [0.0, 0.5, 3.0] {
            let r = Reflection { curvature: c, ..r };
            let (s, a) = (
                one_bounce(100.0, &r, 2.0, Propagation::BoundingBox),
                one_bounce(100.0, &Reflection { clip: BrdfClip::Angle, ..r }, 2.0, Propagation::BoundingBox),
            );
            assert!(s.s <= a.s + 1e-12 && s.a <= a.a + 1e-12, "c = {c}: {s:?} vs {a:?}");
        }
    }
}

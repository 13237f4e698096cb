//! Branch-free f32 exponential and logarithm for the filters' inner loops: written so that the
//! compiler vectorises a loop that calls them (no libm call, no saturating float-to-int
//! conversion, which it would do lane by lane). And an f64 arctangent for the exact irradiance
//! of a polygonal light, computed at every sample of `auto`'s soft shadows, where libm's
//! `atan2` (correctly rounded, with every special case) was a large part of a sample's time.

/// Past this, e^-x is clamped (e^-87 is still a normal f32; 2^-n below stays one).
pub const EXP_NEG_MAX: f32 = 87.0;

/// e^-x for x >= 0: e^-x = 2^-n e^-r with n = round(x / ln 2) and |r| <= ln 2 / 2, e^-r by its
/// Taylor series to r^6 (truncation error 0.35^7 / 7! = 1.2e-7, an ulp). x is clamped to
/// [0, `EXP_NEG_MAX`] first, NaN to the top (a weight that is all but 0), so the result is
/// always a positive normal number at most 1.
#[inline(always)]
pub fn exp_neg(x: f32) -> f32 {
    // Adding 1.5 * 2^23 rounds to an integer held in the low mantissa bits (no SSE4.1 round).
    const SHIFT: f32 = 12_582_912.0;
    // ln 2 split so that n * LN2_HI is exact for every n that occurs (n <= 126: 15 + 7 bits).
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;
    // `min` first, so that NaN becomes the maximum (min and max return the other operand;
    // `clamp` would keep the NaN).
    #[allow(clippy::manual_clamp)]
    let x = x.min(EXP_NEG_MAX).max(0.0);
    let t = x * std::f32::consts::LOG2_E + SHIFT;
    let n = t - SHIFT;
    let r = (x - n * LN2_HI) - n * LN2_LO;
    let p = 1.0 - r * (1.0 - r * (0.5 - r * (1.0 / 6.0 - r * (1.0 / 24.0 - r * (1.0 / 120.0 - r * (1.0 / 720.0))))));
    let n_bits = t.to_bits().wrapping_sub(SHIFT.to_bits());
    p * f32::from_bits((127u32.wrapping_sub(n_bits)) << 23)
}

/// ln x for positive normal x (absolute error below 1e-6): the exponent from the float's bits,
/// the mantissa m in [1, 2) through ln m = 2 atanh((m - 1) / (m + 1)), a series in its square.
#[inline(always)]
pub fn ln_pos(x: f32) -> f32 {
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let z = (m - 1.0) / (m + 1.0);
    let z2 = z * z;
    let series = 2.0 * z * (1.0 + z2 * (1.0 / 3.0 + z2 * (1.0 / 5.0 + z2 * (1.0 / 7.0 + z2 * (1.0 / 9.0)))));
    e as f32 * std::f32::consts::LN_2 + series
}

/// atan2(y, x) for y >= 0 (the angle in [0, pi] of a vector in the upper half-plane), to
/// within 1e-13 absolute: the quotient of the smaller over the larger of |x| and y, then
/// atan t = c + atan((t - tan c) / (1 + t tan c)) for the nearest c of 0, pi/8 and pi/4, which
/// leaves |u| <= tan(pi/16) = 0.199 for the odd Taylor series to u^15 (its remainder below
/// u^17 / 17 = 7e-14). NaN in, NaN out; (0, 0) gives 0.
#[inline]
pub fn atan2_nonneg(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    let ax = x.abs();
    if y <= ax {
        // 0 <= y / |x| <= 1 (0 / 0 is taken as 0).
        let a = if ax > 0.0 { atan_unit(y / ax) } else { 0.0 };
        if x < 0.0 {
            PI - a
        } else {
            a
        }
    } else {
        // |x| < y: pi/2 - atan(x / y), x / y in (-1, 1).
        let t = x / y;
        let a = atan_unit(t.abs());
        FRAC_PI_2 - a.copysign(t)
    }
}

/// atan t for t in [0, 1] (see `atan2_nonneg`).
#[inline(always)]
fn atan_unit(t: f64) -> f64 {
    const TAN_PI_8: f64 = 0.414_213_562_373_095_03;
    // Boundaries halfway in angle: tan(pi/16) and tan(3 pi/16).
    const TAN_PI_16: f64 = 0.198_912_367_379_658_02;
    const TAN_3PI_16: f64 = 0.668_178_637_919_298_9;
    let (c, tan_c) = if t <= TAN_PI_16 {
        (0.0, 0.0)
    } else if t <= TAN_3PI_16 {
        (std::f64::consts::FRAC_PI_8, TAN_PI_8)
    } else {
        (std::f64::consts::FRAC_PI_4, 1.0)
    };
    let u = (t - tan_c) / (1.0 + t * tan_c);
    let u2 = u * u;
    let series = 1.0
        - u2 * (1.0 / 3.0
            - u2 * (1.0 / 5.0
                - u2 * (1.0 / 7.0 - u2 * (1.0 / 9.0 - u2 * (1.0 / 11.0 - u2 * (1.0 / 13.0 - u2 * (1.0 / 15.0)))))));
    c + u * series
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_nonneg_matches_libm_over_the_upper_half_plane() {
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let angle = std::f64::consts::PI * i as f64 / 200_000.0;
            for r in [1e-12, 1e-3, 1.0, 7.5, 1e9] {
                let (y, x) = (r * angle.sin(), r * angle.cos());
                let y = y.max(0.0);
                worst = worst.max((atan2_nonneg(y, x) - y.atan2(x)).abs());
            }
        }
        assert!(worst < 1e-13, "worst absolute error {worst:e}");
        // Tiny angles keep their relative accuracy (the short edges of a far light).
        for y in [1e-300, 1e-20, 1e-9] {
            assert!((atan2_nonneg(y, 1.0) / y - 1.0).abs() < 1e-15);
        }
        assert_eq!(atan2_nonneg(0.0, 0.0), 0.0);
        assert_eq!(atan2_nonneg(0.0, -1.0), std::f64::consts::PI);
        assert_eq!(atan2_nonneg(1.0, 0.0), std::f64::consts::FRAC_PI_2);
        assert!(atan2_nonneg(f64::NAN, 1.0).is_nan() && atan2_nonneg(1.0, f64::NAN).is_nan());
        assert_eq!(atan2_nonneg(f64::INFINITY, 1.0), std::f64::consts::FRAC_PI_2);
    }

    #[test]
    fn exp_neg_is_within_an_ulp_or_two_of_libm_over_its_range() {
        let mut worst = 0.0f64;
        for i in 0..=870_000 {
            let x = i as f32 * 1e-4;
            let (got, want) = (exp_neg(x) as f64, (-(x as f64)).exp());
            worst = worst.max(((got - want) / want).abs());
        }
        assert!(worst < 3e-7, "worst relative error {worst:e}");
        assert_eq!(exp_neg(0.0), 1.0);
    }

    #[test]
    fn exp_neg_clamps_out_of_range_and_nan_to_a_positive_normal_at_most_1() {
        let floor = exp_neg(EXP_NEG_MAX);
        assert!(floor.is_normal() && floor > 0.0 && floor < 2e-38);
        for x in [1e30, f32::INFINITY, f32::NAN, 88.0, 1e4] {
            assert_eq!(exp_neg(x), floor, "e^-{x}");
        }
        for x in [-1e-30, -1.0, f32::NEG_INFINITY] {
            assert_eq!(exp_neg(x), 1.0, "e^-{x}");
        }
    }

    #[test]
    fn ln_pos_is_accurate_from_1e_minus_6_to_1e6() {
        for i in 0..=100_000 {
            let x = 1e-6f32 * 1e12f32.powf(i as f32 / 100_000.0);
            let (exact, fast) = ((x as f64).ln(), ln_pos(x) as f64);
            assert!((fast - exact).abs() <= 2e-6 * (1.0 + exact.abs()), "ln({x}): {fast} vs {exact}");
        }
    }
}

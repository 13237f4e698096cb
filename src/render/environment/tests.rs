//! The map frame, the sampling density (it integrates to 1 and follows the map), and the
//! unbiasedness of radiance over density, for smooth maps, a small bright sun and black ones.
use super::*;
use crate::render::sky::Sky;

/// A smooth map: brighter towards +X and the zenith, never black.
fn smooth_map(width: usize, height: usize) -> LatLongMap {
    let mut texels = Vec::new();
    for y in 0..height {
        for x in 0..width {
            let (d, _) = uv_to_direction([(x as f32 + 0.5) / width as f32, (y as f32 + 0.5) / height as f32]);
            texels.push(Vec3::new(1.0 + d.x, 1.5 + d.y, 0.5) * 0.5);
        }
    }
    LatLongMap::new(width, height, texels)
}

/// A black map with one bright texel (a sun).
fn one_texel_map(width: usize, height: usize, at: (usize, usize)) -> LatLongMap {
    let mut texels = vec![Vec3::ZERO; width * height];
    texels[at.1 * width + at.0] = Vec3::new(1000.0, 800.0, 600.0);
    LatLongMap::new(width, height, texels)
}

fn light(map: LatLongMap, up: Vec3, rotation_deg: f32) -> EnvironmentLight {
    EnvironmentLight::new(EnvironmentRadiance::Map(Arc::new(map)), 1.0, up, rotation_deg)
}

/// Integral over the sphere of `f` by the midpoint rule on an n x n/2 (phi, theta) grid.
fn sphere_integral(n: usize, f: impl Fn(Vec3) -> f64) -> f64 {
    let (w, h) = (n, n / 2);
    let mut sum = 0.0;
    for y in 0..h {
        for x in 0..w {
            let (d, sin_t) = uv_to_direction([(x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32]);
            sum += f(d) * sin_t as f64;
        }
    }
    sum * (2.0 * std::f64::consts::PI / w as f64) * (std::f64::consts::PI / h as f64)
}

#[test]
fn the_map_frame_is_mitsubas() {
    // u = 0 faces -Z, u = 1/4 faces +X, v = 0 is +Y; and the two mappings invert each other.
    let close = |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6;
    assert!(close(direction_to_uv(Vec3::NEG_Z), [0.0, 0.5]));
    assert!(close(direction_to_uv(Vec3::X), [0.25, 0.5]));
    assert!(close(direction_to_uv(Vec3::Z), [0.5, 0.5]));
    assert!(close(direction_to_uv(Vec3::NEG_X), [0.75, 0.5]));
    assert!(direction_to_uv(Vec3::Y)[1] < 1e-6);
    for i in 0..100 {
        let uv = [((i * 37) % 100) as f32 / 100.0 + 0.003, (i as f32 + 0.5) / 100.0];
        let (d, sin_t) = uv_to_direction(uv);
        assert!((d.length() - 1.0).abs() < 1e-5 && (sin_t - (1.0 - d.y * d.y).sqrt()).abs() < 1e-3);
        assert!(close(direction_to_uv(d), uv) || (uv[0] - direction_to_uv(d)[0]).abs() > 0.999, "{uv:?}");
    }
}

#[test]
fn up_and_rotation_turn_the_map() {
    // The sun texel of a map lit at u = 1/4 (the +X column) on the horizon row.
    let (w, h) = (64, 32);
    let at = (w / 4, h / 2);
    let toward = |l: &EnvironmentLight| {
        let mut best = (0.0, Vec3::ZERO);
        for i in 0..4000 {
            let s = l.sample([(i % 63) as f32 / 63.0 + 0.005, (i / 63) as f32 / 64.0 + 0.005]).unwrap();
            if s.radiance.x > best.0 {
                best = (s.radiance.x, s.wi);
            }
        }
        best.1
    };
    let sun = toward;
    assert!(sun(&light(one_texel_map(w, h, at), Vec3::Y, 0.0)).dot(Vec3::X) > 0.98);
    // Turned 90 degrees counter-clockwise seen from above (+Y): +X goes to -Z.
    assert!(sun(&light(one_texel_map(w, h, at), Vec3::Y, 90.0)).dot(Vec3::NEG_Z) > 0.98);
    // With +Z as the zenith, the map's horizon (+X column) stays on the new horizon.
    let l = light(one_texel_map(w, h, at), Vec3::Z, 0.0);
    let d = sun(&l);
    assert!(d.z.abs() < 0.1, "{d}");
    // Radiance and sampling agree on where the sun is, whatever the frame.
    assert!(l.radiance(d).x > 100.0);
}

#[test]
fn the_density_integrates_to_one_and_follows_the_map() {
    let l = light(smooth_map(64, 32), Vec3::new(0.3, 1.0, 0.2), 33.0);
    let total = sphere_integral(1024, |d| l.pdf(d) as f64);
    assert!((total - 1.0).abs() < 2e-3, "integral of the pdf {total}");
    // Proportional to luminance, up to the cell-mean smoothing of a smooth map and the
    // piecewise-constant sin(theta) (taken at each row's centre).
    let norm = sphere_integral(1024, |d| luminance(l.radiance(d)) as f64);
    for i in 0..200 {
        let s = l.sample([((i * 61) % 200) as f32 / 200.0 + 0.001, (i as f32 + 0.5) / 200.0]).unwrap();
        assert!((s.pdf - l.pdf(s.wi)).abs() <= 1e-3 * s.pdf, "sample pdf {} vs pdf {}", s.pdf, l.pdf(s.wi));
        let local = l.to_map * s.wi;
        // The sampling table's rows are the 31 bands between the map's 32 rows.
        let row = (direction_to_uv(local)[1] * 31.0).floor();
        let sin_centre = (std::f32::consts::PI * (row + 0.5) / 31.0).sin();
        let sin_theta = (1.0 - local.y * local.y).sqrt();
        let want = luminance(s.radiance) as f64 / norm * (sin_centre / sin_theta) as f64;
        assert!((s.pdf as f64 / want - 1.0).abs() < 0.05, "pdf {} vs luminance / integral {want}", s.pdf);
    }
    // The one-texel sun: every sample lands in its bilinear footprint, and the density there
    // integrates to 1 as well.
    let sun = light(one_texel_map(32, 16, (5, 4)), Vec3::Y, 0.0);
    let total = sphere_integral(2048, |d| sun.pdf(d) as f64);
    assert!((total - 1.0).abs() < 5e-3, "{total}");
}

#[test]
fn radiance_over_density_estimates_the_maps_power() {
    // E[L / pdf] = the integral of L over the sphere, for a smooth map, a one-texel sun (whose
    // bilinear spread reaches cells where its own texel is not) and the baked sky; and each
    // estimate stays finite.
    let maps = [smooth_map(64, 32), one_texel_map(32, 16, (5, 4)), Sky::default().bake(128)];
    for (k, map) in maps.into_iter().enumerate() {
        let l = light(map, Vec3::Y, 12.0);
        let exact = sphere_integral(4096, |d| l.radiance(d).x as f64);
        let n = 256;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let s = l.sample([(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32]).unwrap();
                let v = s.radiance.x as f64 / s.pdf as f64;
                assert!(v.is_finite());
                sum += v;
            }
        }
        let estimate = sum / (n * n) as f64;
        assert!((estimate / exact - 1.0).abs() < 0.01, "map {k}: {estimate} vs {exact}");
    }
}

#[test]
fn black_lights_draw_nothing_and_constants_draw_the_whole_sphere() {
    let black = light(LatLongMap::new(4, 2, vec![Vec3::ZERO; 8]), Vec3::Y, 0.0);
    assert!(black.sample([0.3, 0.7]).is_none());
    assert_eq!(black.pdf(Vec3::X), 0.0);
    assert_eq!(black.radiance(Vec3::X), Vec3::ZERO);
    let off = EnvironmentLight::new(EnvironmentRadiance::Constant(Vec3::ONE), 0.0, Vec3::Y, 0.0);
    assert!(off.sample([0.3, 0.7]).is_none());
    let c = EnvironmentLight::new(EnvironmentRadiance::Constant(Vec3::new(1.0, 2.0, 3.0)), 2.0, Vec3::Y, 0.0);
    assert_eq!(c.radiance(Vec3::new(0.6, 0.0, 0.8)), Vec3::new(2.0, 4.0, 6.0));
    let total = sphere_integral(256, |d| c.pdf(d) as f64);
    assert!((total - 1.0).abs() < 1e-4);
    // Uniform over the sphere: the mean direction of a stratified set is near 0.
    let mut mean = Vec3::ZERO;
    for i in 0..64 {
        for j in 0..64 {
            mean += c.sample([(i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 64.0]).unwrap().wi;
        }
    }
    assert!((mean / 4096.0).length() < 1e-3);
    // A 1 x 1 map is a constant too (wrapping and clamping reach the one texel).
    let one = light(LatLongMap::new(1, 1, vec![Vec3::splat(0.5)]), Vec3::Y, 0.0);
    for d in [Vec3::X, Vec3::Y, Vec3::NEG_Y, Vec3::new(0.0, 0.6, -0.8)] {
        assert_eq!(one.radiance(d), Vec3::splat(0.5));
    }
}

#[test]
fn texels_sit_where_mitsuba_puts_them() {
    // Columns centred in their longitudes, rows from pole to pole: a map holding (x, y) in
    // each texel returns it at the texel's centre and blends neighbours between them
    // (Mitsuba 3.9's envmap, probed with the same map, gives the same numbers).
    let (w, h) = (8, 4);
    let texels = (0..w * h).map(|i| Vec3::new((i % w) as f32, (i / w) as f32, 1.0)).collect();
    let map = LatLongMap::new(w, h, texels);
    for (x, y) in [(2, 1), (5, 2), (0, 0), (7, 3)] {
        let got = map.lookup(map.texel_uv(x, y));
        assert!((got - Vec3::new(x as f32, y as f32, 1.0)).length() < 1e-5, "({x}, {y}): {got}");
    }
    assert!((map.texel_uv(2, 1)[1] - 1.0 / 3.0).abs() < 1e-6);
    // Between the last column and the first: wrapped.
    let got = map.lookup([0.01, 1.0 / 3.0]);
    assert!((got.x - 0.42 * 7.0).abs() < 1e-4, "{got}");
}

#[test]
fn the_lookup_equals_floor_and_wrapping_everywhere() {
    // The lookup avoids floor() and rem_euclid on interior texels; its results are those of
    // the plain formula at every u, wrapped or not, in and out of [0, 1).
    let (w, h) = (7usize, 5usize);
    let texels: Vec<Vec3> = (0..w * h).map(|i| Vec3::new(i as f32, (i * i % 11) as f32, 1.0)).collect();
    let map = LatLongMap::new(w, h, texels.clone());
    let plain = |uv: [f32; 2]| {
        let x = uv[0] * w as f32 - 0.5;
        let y = (uv[1] * (h - 1) as f32).clamp(0.0, (h - 1) as f32);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let col = |i: i64| i.rem_euclid(w as i64) as usize;
        let (c0, c1) = (col(x0 as i64), col(x0 as i64 + 1));
        let (r0, r1) = (y0 as usize, (y0 as usize + 1).min(h - 1));
        let at = |r: usize, c: usize| texels[r * w + c];
        (at(r0, c0) * (1.0 - fx) + at(r0, c1) * fx) * (1.0 - fy) + (at(r1, c0) * (1.0 - fx) + at(r1, c1) * fx) * fy
    };
    let mut us: Vec<f32> = (0..=700).map(|k| k as f32 / 700.0).collect();
    us.extend([-0.3, -1.0 / 14.0, 1.0 / 14.0, 13.0 / 14.0, 1.0 - f32::EPSILON, 1.0, 1.2, 2.5]);
    for &u in &us {
        for v in [0.0, 0.3, 0.5, 0.99, 1.0] {
            assert_eq!(map.lookup([u, v]), plain([u, v]), "uv ({u}, {v})");
        }
    }
}

#[test]
fn the_mean_radiance_weights_texels_by_solid_angle() {
    // Top row 0, bottom row 1 (a 2-row map): the mean over the sphere is 1/2 by symmetry.
    let map = LatLongMap::new(3, 2, vec![Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ONE, Vec3::ONE, Vec3::ONE]);
    assert!((map.mean_radiance() - Vec3::splat(0.5)).length() < 1e-6);
}

/// The batched calls (`sample_many`, `radiance_and_pdf_many`) give each lane exactly what one
/// call gives, on maps (smooth, a single bright texel, black), a turned map and a constant,
/// with lanes that ask for nothing among them.
#[test]
fn batched_calls_give_each_lane_the_single_calls_numbers() {
    use crate::render::test_rng::Rng;
    let lights = [
        light(smooth_map(64, 32), Vec3::Y, 0.0),
        light(one_texel_map(32, 16, (20, 5)), Vec3::new(0.3, 1.0, 0.2), 70.0),
        light(LatLongMap::new(8, 4, vec![Vec3::ZERO; 32]), Vec3::Y, 0.0),
        EnvironmentLight::new(EnvironmentRadiance::Constant(Vec3::new(0.5, 1.0, 2.0)), 1.5, Vec3::Y, 0.0),
    ];
    let mut rng = Rng(11);
    for l in &lights {
        for _ in 0..200 {
            let us: [[f32; 2]; 5] = std::array::from_fn(|_| [rng.f(), rng.f()]);
            let many = l.sample_many(&us);
            for (u, m) in us.iter().zip(&many) {
                let one = l.sample(*u);
                assert_eq!(one.map(|s| (s.wi, s.radiance, s.pdf)), m.map(|s| (s.wi, s.radiance, s.pdf)));
            }
            let ws: [Option<Vec3>; 3] = std::array::from_fn(|i| {
                (i != 1).then(|| Vec3::new(rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5).normalize())
            });
            let many = l.radiance_and_pdf_many(&ws);
            for (w, m) in ws.iter().zip(many) {
                assert_eq!(w.map_or((Vec3::ZERO, 0.0), |w| l.radiance_and_pdf(w)), m);
            }
        }
    }
}

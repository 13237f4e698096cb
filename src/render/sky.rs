//! A small procedural sky, so that scenes and tests can be lit by an environment without a map
//! file: a sky dome graded from the horizon colour to the zenith colour, a soft glow around the
//! sun, a sun disc, and a uniform ground below the horizon. It is baked into a
//! latitude-longitude map (the map frame of `environment`), so it is evaluated and importance
//! sampled exactly like a map read from a file, and can be written out and given to another
//! renderer as that file.
use super::environment::{uv_to_direction, LatLongMap};
use glam::Vec3;

#[derive(Clone, Debug, PartialEq)]
pub struct Sky {
    /// Unit direction towards the sun in the map frame (+Y the zenith).
    pub sun_direction: Vec3,
    /// Angular radius of the sun disc, radians.
    pub sun_radius: f32,
    pub sun_radiance: Vec3,
    pub zenith: Vec3,
    pub horizon: Vec3,
    pub ground: Vec3,
}

/// Defaults: a clear midday-ish sky whose sun gives about three times the sky's irradiance on
/// a horizontal surface (a sun 45 degrees up, 2 degrees in radius).
pub const DEFAULT_SUN_ELEVATION_DEG: f32 = 45.0;
pub const DEFAULT_SUN_RADIUS_DEG: f32 = 2.0;
pub const DEFAULT_SUN_RADIANCE: Vec3 = Vec3::new(1500.0, 1400.0, 1250.0);
pub const DEFAULT_ZENITH: Vec3 = Vec3::new(0.25, 0.45, 0.95);
pub const DEFAULT_HORIZON: Vec3 = Vec3::new(0.95, 0.95, 1.0);
pub const DEFAULT_GROUND: Vec3 = Vec3::new(0.2, 0.18, 0.15);
/// Width of the baked map when none is asked for (height is half of it): 0.7 degrees per
/// texel, so the default sun spans about six texels.
pub const DEFAULT_WIDTH: usize = 512;

impl Sky {
    /// The sun at `elevation_deg` above the horizon and `azimuth_deg` around it (0: towards
    /// the map frame's -Z, where u = 0; 90: towards +X, u = 1/4), as a unit direction.
    pub fn sun_direction_from(elevation_deg: f32, azimuth_deg: f32) -> Vec3 {
        let (el, az) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
        Vec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos())
    }

    /// Radiance towards map-frame direction `d` (unit).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        let cos_sun = d.dot(self.sun_direction).clamp(-1.0, 1.0);
        let angle = cos_sun.acos();
        // The disc, with its edge smoothed over a tenth of its radius (limb darkening
        // would be finer than any map that holds it).
        let edge = self.sun_radius * 0.1;
        let disc = ((self.sun_radius + edge - angle) / (2.0 * edge)).clamp(0.0, 1.0);
        let sun = self.sun_radiance * disc;
        if d.y < 0.0 {
            return self.ground + sun;
        }
        let t = d.y.max(0.0).powf(0.4);
        let dome = self.horizon * (1.0 - t) + self.zenith * t;
        // A glow of about ten degrees around the sun, in the sun's colour, dimmer than the
        // disc by four orders.
        let glow = self.sun_radiance * (2e-4 * (-(angle / 0.17).powi(2)).exp());
        dome + glow + sun
    }

    /// The sky baked into a `width` x `width / 2` map (`LatLongMap`'s layout), each texel the
    /// mean of 4 x 4 points over the span of directions it stands for, so that the small sun
    /// keeps its power whatever the resolution.
    pub fn bake(&self, width: usize) -> LatLongMap {
        let width = width.max(2);
        let height = (width / 2).max(2);
        const K: usize = 4;
        let mut texels = Vec::with_capacity(width * height);
        let band = 1.0 / (height - 1) as f32;
        for y in 0..height {
            // The latitudes halfway to the neighbouring rows, clipped at the poles.
            let v_lo = ((y as f32 - 0.5) * band).max(0.0);
            let v_hi = ((y as f32 + 0.5) * band).min(1.0);
            for x in 0..width {
                let mut sum = Vec3::ZERO;
                let mut weight = 0.0;
                for j in 0..K {
                    for i in 0..K {
                        let u = (x as f32 + (i as f32 + 0.5) / K as f32) / width as f32;
                        let v = v_lo + (v_hi - v_lo) * (j as f32 + 0.5) / K as f32;
                        let (d, sin_theta) = uv_to_direction([u, v]);
                        sum += self.radiance(d) * sin_theta;
                        weight += sin_theta;
                    }
                }
                texels.push(if weight > 0.0 { sum / weight } else { Vec3::ZERO });
            }
        }
        LatLongMap::new(width, height, texels)
    }
}

impl Default for Sky {
    fn default() -> Self {
        Sky {
            sun_direction: Sky::sun_direction_from(DEFAULT_SUN_ELEVATION_DEG, 0.0),
            sun_radius: DEFAULT_SUN_RADIUS_DEG.to_radians(),
            sun_radiance: DEFAULT_SUN_RADIANCE,
            zenith: DEFAULT_ZENITH,
            horizon: DEFAULT_HORIZON,
            ground: DEFAULT_GROUND,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    /// Power arriving on a horizontal unit area from the map, by quadrature over its texels.
    fn horizontal_irradiance(map: &LatLongMap) -> Vec3 {
        let mut e = Vec3::ZERO;
        for y in 0..map.height() {
            let (d, _) = uv_to_direction(map.texel_uv(0, y));
            for x in 0..map.width() {
                e += map.texel(x, y) * d.y.max(0.0) * map.texel_solid_angle(y);
            }
        }
        e
    }

    #[test]
    fn the_baked_sun_keeps_its_power_at_any_resolution() {
        // The disc alone: irradiance = L * solid angle * cos(zenith angle).
        let sky = Sky { zenith: Vec3::ZERO, horizon: Vec3::ZERO, ground: Vec3::ZERO, ..Sky::default() };
        let solid_angle = 2.0 * PI * (1.0 - sky.sun_radius.cos());
        let expected = sky.sun_radiance.x * solid_angle * sky.sun_direction.y;
        // The glow adds about 2e-4 * pi * 0.17^2 / solid angle, under 1% of the disc; a
        // coarse map resolves the disc's edge less well.
        for (width, tolerance) in [(128, 0.05), (512, 0.02), (1024, 0.02)] {
            let e = horizontal_irradiance(&sky.bake(width)).x;
            assert!((e / expected - 1.0).abs() < tolerance, "width {width}: {e} vs disc {expected}");
        }
    }

    #[test]
    fn the_sun_sits_where_it_is_asked_and_the_ground_is_below_the_horizon() {
        let sky = Sky { sun_direction: Sky::sun_direction_from(30.0, 90.0), ..Sky::default() };
        assert!((sky.sun_direction - Vec3::new(0.75f32.sqrt(), 0.5, 0.0)).length() < 1e-6);
        let map = sky.bake(256);
        let (mut best, mut at) = (0.0, (0, 0));
        for y in 0..map.height() {
            for x in 0..map.width() {
                if map.texel(x, y).x > best {
                    (best, at) = (map.texel(x, y).x, (x, y));
                }
            }
        }
        // Azimuth 90 is u = 1/4; elevation 30 is v = 1/3.
        let [u, v] = map.texel_uv(at.0, at.1);
        assert!((u - 0.25).abs() < 0.01 && (v - 1.0 / 3.0).abs() < 0.02, "sun at {u} {v}");
        assert_eq!(sky.radiance(Vec3::new(0.0, -0.5, 0.75f32.sqrt())), DEFAULT_GROUND);
        let zenith = sky.radiance(Vec3::Y);
        assert!((zenith - DEFAULT_ZENITH).length() < 1e-3, "{zenith}");
    }
}

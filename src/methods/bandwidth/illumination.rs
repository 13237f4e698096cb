//! The angular bandwidth of distant light in every direction (Bagher et al. 2012, Sec. 2.4):
//! the wavelet estimate of the environment map's luminance at each texel, turned into radians
//! by the map's own scale there.
use super::wavelet::{scale_exponents, Basis, Filter, Reference, EPSILON};
use crate::render::environment::{direction_to_uv, EnvironmentLight, EnvironmentRadiance, LatLongMap};
use glam::{Mat3, Vec3};
use std::f64::consts::PI;

/// How the wavelet estimates are taken (shared by maps, lobes and textures).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveletOptions {
    pub filter: Filter,
    pub basis: Basis,
    pub eps: f64,
    pub reference: Reference,
}

impl Default for WaveletOptions {
    fn default() -> Self {
        WaveletOptions {
            filter: Filter::default(),
            basis: Basis::default(),
            eps: EPSILON,
            reference: Reference::default(),
        }
    }
}

impl WaveletOptions {
    /// Scale exponent per texel of a `w` x `h` image (`wavelet::scale_exponents`).
    pub fn exponents(&self, image: &[f64], w: usize, h: usize) -> Vec<Option<u32>> {
        scale_exponents(image, w, h, self.filter, self.basis, self.eps, self.reference)
    }
}

/// A bandwidth of one cycle per 2^h texels, each `radians` wide, as an angular frequency
/// (radians per radian): `nu_a = 2 pi / (2^h lambda_max)` (Sec. 2.4).
pub fn angular(h: Option<u32>, radians: f64) -> f64 {
    match h {
        None => 0.0,
        Some(h) => 2.0 * PI / (2f64.powi(h as i32) * radians),
    }
}

/// Angular bandwidth of an environment light by direction.
#[derive(Clone, Debug)]
pub struct EnvironmentBandwidth {
    /// Per texel of the light's map (None: a constant, bandwidth 0 everywhere).
    map: Option<(usize, usize, Vec<f32>)>,
    to_map: Mat3,
}

impl EnvironmentBandwidth {
    pub fn new(env: &EnvironmentLight, opts: &WaveletOptions) -> Self {
        let map = match &env.radiance {
            EnvironmentRadiance::Constant(_) => None,
            EnvironmentRadiance::Map(m) => Some((m.width(), m.height(), map_bandwidth(m, opts))),
        };
        EnvironmentBandwidth { map, to_map: env.to_map }
    }

    /// The angular bandwidth of the light arriving from world direction `w` (radians^-1).
    pub fn at(&self, w: Vec3) -> f64 {
        let Some((width, height, nu)) = &self.map else { return 0.0 };
        let [u, v] = direction_to_uv(self.to_map * w);
        let x = ((u * *width as f32) as usize).min(width - 1);
        let y = ((v * (height - 1) as f32).round() as usize).min(height - 1);
        nu[y * width + x] as f64
    }
}

/// Each texel's angular bandwidth: its scale exponent over the map's luminance, at the larger
/// of the texel's two angular sizes (the Jacobian's largest eigenvalue: pi / (H - 1) along a
/// meridian, 2 pi sin(theta) / W along a parallel; `LatLongMap`'s rows run pole to pole).
pub fn map_bandwidth(map: &LatLongMap, opts: &WaveletOptions) -> Vec<f32> {
    let (w, h) = (map.width(), map.height());
    let luminance: Vec<f64> = (0..w * h)
        .map(|i| {
            let t = map.texel(i % w, i / w);
            (0.2126 * t.x + 0.7152 * t.y + 0.0722 * t.z) as f64
        })
        .collect();
    let exponents = opts.exponents(&luminance, w, h);
    let along_meridian = if h > 1 { PI / (h - 1) as f64 } else { PI };
    (0..w * h)
        .map(|i| {
            let theta = PI * map.texel_uv(0, i / w)[1] as f64;
            let size = along_meridian.max(2.0 * PI * theta.sin() / w as f64);
            angular(exponents[i], size) as f32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sky::Sky;
    use std::sync::Arc;

    fn light(map: LatLongMap) -> EnvironmentLight {
        EnvironmentLight::new(EnvironmentRadiance::Map(Arc::new(map)), 1.0, Vec3::Y, 0.0)
    }

    #[test]
    fn a_constant_sky_has_no_bandwidth_and_a_sun_has_more_than_the_dome() {
        let opts = WaveletOptions::default();
        let constant = EnvironmentLight::new(EnvironmentRadiance::Constant(Vec3::ONE), 1.0, Vec3::Y, 0.0);
        assert_eq!(EnvironmentBandwidth::new(&constant, &opts).at(Vec3::X), 0.0);
        let flat = light(LatLongMap::new(32, 16, vec![Vec3::splat(2.0); 512]));
        assert_eq!(EnvironmentBandwidth::new(&flat, &opts).at(Vec3::new(0.3, 0.4, 0.5).normalize()), 0.0);
        // The built-in sky: the sun's edge is sharp (a few texels: the map's resolution), the
        // smooth dome far from it is not.
        let sky = Sky::default();
        let nu = EnvironmentBandwidth::new(&light(sky.bake(256)), &opts);
        let sun = nu.at(sky.sun_direction);
        let dome = nu.at(Vec3::new(0.0, 0.9, 0.44).normalize());
        assert!(sun > 8.0 * dome, "sun {sun}, dome {dome}");
        // At the sun, about the finest the map can hold: 2 pi / (a few texels of 1.4 degrees).
        let texel = PI / 127.0;
        assert!(sun > 2.0 * PI / (8.0 * texel) && sun <= 2.0 * PI / texel, "{sun}");
    }

    #[test]
    fn the_bandwidth_turns_with_the_map() {
        // A map with a sharp feature on one side: turning the light turns where it is seen.
        let (w, h) = (64, 32);
        let mut texels = vec![Vec3::splat(0.5); w * h];
        for y in 12..20 {
            texels[y * w + 16] = Vec3::splat(10.0); // a thin line at u = 1/4: towards +X
        }
        let opts = WaveletOptions::default();
        let map = LatLongMap::new(w, h, texels);
        let straight = EnvironmentBandwidth::new(&light(map.clone()), &opts);
        let turned = EnvironmentBandwidth::new(
            &EnvironmentLight::new(EnvironmentRadiance::Map(Arc::new(map)), 1.0, Vec3::Y, 90.0),
            &opts,
        );
        assert!(straight.at(Vec3::X) > 3.5 * straight.at(Vec3::NEG_X));
        // Turned 90 degrees counter-clockwise seen from above, +X goes to -Z.
        assert!((turned.at(Vec3::NEG_Z) - straight.at(Vec3::X)).abs() < 1e-9);
    }

    #[test]
    fn single_texel_and_black_maps_stay_finite() {
        let opts = WaveletOptions::default();
        for map in [LatLongMap::new(1, 1, vec![Vec3::ONE]), LatLongMap::new(8, 4, vec![Vec3::ZERO; 32])] {
            let nu = EnvironmentBandwidth::new(&light(map), &opts);
            for d in [Vec3::X, Vec3::Y, Vec3::NEG_Y] {
                assert_eq!(nu.at(d), 0.0);
            }
        }
    }
}

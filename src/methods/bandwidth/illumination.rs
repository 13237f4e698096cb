//! The angular bandwidth of distant light in every direction (Bagher et al. 2012, Sec. 2.4):
//! the wavelet estimate of the environment map's luminance at each texel, turned into radians
//! by the map's own scale there.
use super::wavelet::{scale_exponents, Basis, Filter, Reference, EPSILON};
use crate::render::environment::{direction_to_uv, EnvironmentLight, EnvironmentRadiance, LatLongMap};
use glam::{Mat3, Vec3};
use std::f64::consts::PI;
use std::sync::{Arc, Mutex, Weak};

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
    map: Option<(usize, usize, Arc<Vec<f32>>)>,
    to_map: Mat3,
}

/// A map's bandwidths computed in this process. The map is held weakly (the scenes that use it
/// own it); a weak reference keeps the allocation, so no other map can take its address while
/// the entry lives.
struct CachedMap {
    map: Weak<LatLongMap>,
    options: WaveletOptions,
    bandwidth: Arc<Vec<f32>>,
}

/// Maps' bandwidths by map and options, at most `capacity` of them (the oldest goes first).
struct MapCache {
    entries: Vec<CachedMap>,
    capacity: usize,
}

impl MapCache {
    const fn new(capacity: usize) -> Self {
        MapCache { entries: Vec::new(), capacity }
    }

    fn get(&mut self, map: &Arc<LatLongMap>, opts: &WaveletOptions) -> Option<Arc<Vec<f32>>> {
        // Maps no scene holds any more can never be asked for again.
        self.entries.retain(|c| c.map.strong_count() > 0);
        let same = |c: &&CachedMap| c.options == *opts && std::ptr::eq(c.map.as_ptr(), Arc::as_ptr(map));
        self.entries.iter().find(same).map(|c| c.bandwidth.clone())
    }

    fn insert(&mut self, map: &Arc<LatLongMap>, opts: &WaveletOptions, bandwidth: Arc<Vec<f32>>) {
        if self.entries.len() >= self.capacity.max(1) {
            self.entries.remove(0);
        }
        self.entries.push(CachedMap { map: Arc::downgrade(map), options: *opts, bandwidth });
    }
}

/// Maps whose bandwidths the process keeps at most.
pub const MAX_CACHED_MAPS: usize = 4;

/// The process's maps' bandwidths: the wavelet transform of a large map is a sizeable part of
/// a first frame's analysis, and a server renders the same scene's light again and again
/// (every new view of an editing session). The map's rotation and scale do not enter (`map_bandwidth`).
static MAPS: Mutex<MapCache> = Mutex::new(MapCache::new(MAX_CACHED_MAPS));

/// `map_bandwidth` of `map`, from the process's cache or computed.
fn cached_map_bandwidth(map: &Arc<LatLongMap>, opts: &WaveletOptions) -> Arc<Vec<f32>> {
    cached_in(&MAPS, map, opts)
}

/// `map_bandwidth` of `map` from `cache`, or computed (outside the lock, so that renders of
/// other maps do not wait) and kept there.
fn cached_in(cache: &Mutex<MapCache>, map: &Arc<LatLongMap>, opts: &WaveletOptions) -> Arc<Vec<f32>> {
    if let Some(bandwidth) = cache.lock().ok().and_then(|mut c| c.get(map, opts)) {
        return bandwidth;
    }
    let bandwidth = Arc::new(map_bandwidth(map, opts));
    if let Ok(mut c) = cache.lock() {
        c.insert(map, opts, bandwidth.clone());
    }
    bandwidth
}

impl EnvironmentBandwidth {
    pub fn new(env: &EnvironmentLight, opts: &WaveletOptions) -> Self {
        let map = match &env.radiance {
            EnvironmentRadiance::Constant(_) => None,
            EnvironmentRadiance::Map(m) => Some((m.width(), m.height(), cached_map_bandwidth(m, opts))),
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
    fn a_maps_bandwidths_are_computed_once_per_map_and_options() {
        let opts = WaveletOptions::default();
        let cache = Mutex::new(MapCache::new(2));
        let map = Arc::new(Sky::default().bake(64));
        let first = cached_in(&cache, &map, &opts);
        assert_eq!(*first, map_bandwidth(&map, &opts));
        // The same map again (another light, another rotation): the same numbers, not recomputed.
        assert!(Arc::ptr_eq(&first, &cached_in(&cache, &map, &opts)));
        // An equal copy is another map, other options another estimate.
        let copy = Arc::new((*map).clone());
        let again = cached_in(&cache, &copy, &opts);
        assert!(!Arc::ptr_eq(&first, &again) && *first == *again);
        // Once no scene holds a map, its entry goes at the next lookup.
        drop(copy);
        assert!(cache.lock().unwrap().get(&map, &opts).is_some());
        assert_eq!(cache.lock().unwrap().entries.len(), 1);
        // Past the capacity the oldest entry goes.
        let d4 = WaveletOptions { filter: Filter::D4, ..opts };
        let db4_again = WaveletOptions { eps: 0.02, ..opts };
        assert_eq!(*cached_in(&cache, &map, &d4), map_bandwidth(&map, &d4));
        let _ = cached_in(&cache, &map, &db4_again);
        let mut c = cache.lock().unwrap();
        assert_eq!(c.entries.len(), 2);
        assert!(c.get(&map, &opts).is_none() && c.get(&map, &d4).is_some());
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

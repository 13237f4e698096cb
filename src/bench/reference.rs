//! Reference images for error measurements: plain Monte Carlo at high spp, cached on disk as
//! EXR under a key that hashes everything the image depends on, so a second benchmark run
//! reuses them; or loaded from a given EXR.
use super::convergence::{final_frame, job};
use crate::output::{read_exr, write_exr, OutputOptions};
use crate::pipeline::frame::{Frame, RenderInfo};
use crate::pipeline::job::Method;
use crate::proto;
use crate::render::sampler::hash_words;
use crate::render::scene::Scene;
use anyhow::Context;
use prost::Message;
use std::path::Path;
use std::sync::Arc;

/// Everything a reference image depends on.
pub struct ReferenceKey<'a> {
    /// The scene with the benchmark's resolution and camera applied.
    pub scene: &'a proto::Scene,
    pub bounces: u32,
    pub spp: f64,
    pub seed: u64,
    /// Samples at pixel centres (no antialiasing): another ground truth.
    pub pixel_centers: bool,
}

impl ReferenceKey<'_> {
    /// A stable hex digest of the key (the scene's protobuf bytes are deterministic for the
    /// same message).
    pub fn digest(&self) -> String {
        let bytes = self.scene.encode_to_vec();
        let mut words: Vec<u64> =
            bytes.chunks(8).map(|c| c.iter().enumerate().fold(0u64, |w, (i, &b)| w | (b as u64) << (8 * i))).collect();
        // The crate version: a renderer change (a new release) never reuses old references.
        let version = hash_words(&env!("CARGO_PKG_VERSION").bytes().map(u64::from).collect::<Vec<_>>());
        words.extend([bytes.len() as u64, self.bounces as u64, self.spp.to_bits(), self.seed, version]);
        if self.pixel_centers {
            words.push(0x63_656e_7472_6573);
        }
        format!("{:016x}", hash_words(&words))
    }
}

/// Loads the reference for `key` from `cache_dir`, or renders and stores it. Returns the
/// frame and whether it came from the cache.
pub fn cached_reference(
    cache_dir: &Path,
    key: &ReferenceKey,
    scene: Arc<Scene>,
    label: &str,
) -> anyhow::Result<(Frame, bool)> {
    let path = cache_dir.join(format!("{label}-{}.exr", key.digest()));
    if path.is_file() {
        if let Ok(img) = read_exr(&path) {
            return Ok((img.frame, true));
        }
    }
    let mut j = job(scene, Method::Uniform, 64, key.spp, key.seed, key.bounces);
    j.pixel_centers = key.pixel_centers;
    let frame = final_frame(&j).context("the reference render stopped early")?;
    std::fs::create_dir_all(cache_dir).with_context(|| format!("cannot create {}", cache_dir.display()))?;
    let info = RenderInfo {
        scene: label.to_string(),
        method: "uniform".into(),
        seed: key.seed,
        bounces: key.bounces,
        ..RenderInfo::default()
    };
    write_exr(&path, &frame, &info, &OutputOptions { reproducible: true })?;
    Ok((frame, false))
}

/// A reference given as an EXR file (e.g. from another renderer), checked against the size.
pub fn load_reference(path: &Path, width: u32, height: u32) -> anyhow::Result<Frame> {
    let img = read_exr(path)?;
    anyhow::ensure!(
        (img.frame.width, img.frame.height) == (width, height),
        "{}: reference is {}x{}, the benchmark renders {width}x{height}",
        path.display(),
        img.frame.width,
        img.frame.height
    );
    Ok(img.frame)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_key_changes_with_everything_the_image_depends_on() {
        let mut scene = crate::scene::builtin::get("cornell").unwrap();
        let k = |s: &proto::Scene, b: u32, spp: f64| {
            ReferenceKey { scene: s, bounces: b, spp, seed: 1, pixel_centers: false }.digest()
        };
        let base = k(&scene, 3, 1024.0);
        assert_eq!(base, k(&scene, 3, 1024.0));
        assert_ne!(base, k(&scene, 2, 1024.0));
        assert_ne!(base, k(&scene, 3, 2048.0));
        scene.camera.as_mut().unwrap().width += 1;
        assert_ne!(base, k(&scene, 3, 1024.0));
    }

    #[test]
    fn a_second_request_comes_from_the_cache() {
        let dir = std::env::temp_dir().join(format!("wedge-refcache-{}", std::process::id()));
        let mut s = crate::scene::builtin::get("curved").unwrap();
        s.camera.as_mut().unwrap().width = 8;
        s.camera.as_mut().unwrap().height = 6;
        let scene = Arc::new(crate::scene::compile(&s, &Default::default(), None).unwrap());
        let key = ReferenceKey { scene: &s, bounces: 0, spp: 4.0, seed: 3, pixel_centers: false };
        let (a, cached_a) = cached_reference(&dir, &key, scene.clone(), "curved").unwrap();
        let (b, cached_b) = cached_reference(&dir, &key, scene, "curved").unwrap();
        assert!(!cached_a && cached_b);
        assert_eq!(a.color, b.color);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

//! Scenes stored by content digest (`PutScene`): compiled once, then named by `Render` and
//! `Session` calls. A least-recently-used cache bounded by encoded bytes and by triangles (the
//! compiled scene's memory grows with both), with its limits as server options.
use crate::proto;
use crate::render::scene::Scene;
use prost::Message;
use sha2::{Digest, Sha256};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// A stored scene: what later calls need of it.
#[derive(Debug)]
pub struct StoredScene {
    pub digest: String,
    /// The source's camera and settings (`api::request::header`).
    pub header: proto::Scene,
    pub compiled: Arc<Scene>,
    pub bytes: u64,
    pub triangles: u64,
}

/// The digest a scene is stored under: "sha256:" and the hex SHA-256 of its encoding.
pub fn digest(scene: &proto::Scene) -> String {
    let hash = Sha256::digest(scene.encode_to_vec());
    let hex: String = hash.iter().map(|b| format!("{b:02x}")).collect();
    format!("sha256:{hex}")
}

/// Whether `s` has the form of a digest (so that a typo gets INVALID_ARGUMENT, not a miss).
pub fn is_digest(s: &str) -> bool {
    s.strip_prefix("sha256:").is_some_and(|h| h.len() == 64 && h.bytes().all(|b| b.is_ascii_hexdigit()))
}

#[derive(Debug)]
pub struct SceneCache {
    max_bytes: u64,
    max_triangles: u64,
    inner: Mutex<Entries>,
}

#[derive(Debug, Default)]
struct Entries {
    scenes: HashMap<String, (Arc<StoredScene>, u64)>,
    /// Use counter: the entry with the smallest stamp is evicted first.
    clock: u64,
    bytes: u64,
    triangles: u64,
}

impl SceneCache {
    pub fn new(max_bytes: u64, max_triangles: u64) -> SceneCache {
        SceneCache { max_bytes, max_triangles, inner: Mutex::new(Entries::default()) }
    }

    /// The stored scene, marked as just used.
    pub fn get(&self, digest: &str) -> Option<Arc<StoredScene>> {
        let mut e = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        e.clock += 1;
        let now = e.clock;
        let (scene, stamp) = e.scenes.get_mut(digest)?;
        *stamp = now;
        Some(Arc::clone(scene))
    }

    /// Stores `scene`, evicting the least recently used ones until the limits hold; an error
    /// when the scene alone is over a limit.
    pub fn insert(&self, scene: StoredScene) -> Result<Arc<StoredScene>, String> {
        if scene.bytes > self.max_bytes || scene.triangles > self.max_triangles {
            return Err(format!(
                "the scene ({} bytes, {} triangles) is larger than the scene store ({} bytes, {} triangles: \
                 scene_cache_bytes, scene_cache_triangles)",
                scene.bytes, scene.triangles, self.max_bytes, self.max_triangles
            ));
        }
        let mut e = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        e.clock += 1;
        let now = e.clock;
        if let Some((existing, stamp)) = e.scenes.get_mut(&scene.digest) {
            *stamp = now;
            return Ok(Arc::clone(existing));
        }
        while e.bytes + scene.bytes > self.max_bytes || e.triangles + scene.triangles > self.max_triangles {
            let Some(oldest) = e.scenes.iter().min_by_key(|(_, (_, stamp))| *stamp).map(|(k, _)| k.clone()) else {
                break;
            };
            if let Some((gone, _)) = e.scenes.remove(&oldest) {
                e.bytes -= gone.bytes;
                e.triangles -= gone.triangles;
                tracing::info!(digest = %gone.digest, "scene store: evicted the least recently used scene");
            }
        }
        let stored = Arc::new(scene);
        e.bytes += stored.bytes;
        e.triangles += stored.triangles;
        e.scenes.insert(stored.digest.clone(), (Arc::clone(&stored), now));
        Ok(stored)
    }

    /// Scenes stored, their bytes and triangles.
    pub fn usage(&self) -> (usize, u64, u64) {
        let e = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        (e.scenes.len(), e.bytes, e.triangles)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::scene::{CameraDesc, SceneBuilder};
    use glam::Vec3;

    fn stored(name: &str, bytes: u64, triangles: u64) -> StoredScene {
        let camera = CameraDesc {
            position: Vec3::Z,
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vertical_fov_deg: 40.0,
            width: 4,
            height: 4,
        };
        StoredScene {
            digest: name.to_string(),
            header: proto::Scene::default(),
            compiled: Arc::new(SceneBuilder::new(camera).build()),
            bytes,
            triangles,
        }
    }

    #[test]
    fn the_least_recently_used_scene_goes_first() {
        let cache = SceneCache::new(100, 1000);
        for name in ["a", "b", "c"] {
            cache.insert(stored(name, 30, 10)).unwrap();
        }
        assert!(cache.get("a").is_some(), "a is now the most recently used");
        cache.insert(stored("d", 30, 10)).unwrap();
        assert!(cache.get("b").is_none(), "b was the least recently used");
        assert!(cache.get("a").is_some() && cache.get("c").is_some() && cache.get("d").is_some());
        assert_eq!(cache.usage(), (3, 90, 30));
    }

    #[test]
    fn triangles_bound_the_store_too_and_oversized_scenes_are_refused() {
        let cache = SceneCache::new(1000, 100);
        cache.insert(stored("a", 1, 60)).unwrap();
        cache.insert(stored("b", 1, 60)).unwrap();
        assert!(cache.get("a").is_none());
        let e = cache.insert(stored("huge", 1, 101)).unwrap_err();
        assert!(e.contains("scene_cache_triangles"), "{e}");
        assert_eq!(cache.usage(), (1, 1, 60));
    }

    #[test]
    fn digests_are_stable_and_recognised() {
        let scene = crate::scene::builtin::get("cornell").unwrap();
        let d = digest(&scene);
        assert_eq!(d, digest(&scene.clone()));
        assert!(is_digest(&d), "{d}");
        assert!(!is_digest("sha256:xyz") && !is_digest(&d[7..]));
        let mut other = scene;
        other.description.push('!');
        assert_ne!(d, digest(&other));
    }
}

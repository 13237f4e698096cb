//! The built-in scenes, compiled into the binary so `wedge serve` and `wedge bench` offer them
//! from any directory. Their sources are scenes/*.json (made by scenes/generate.py).
use super::json::parse_scene;
use crate::proto;

/// (name, canonical JSON) of every built-in scene, in listing order.
const SOURCES: &[(&str, &str)] = &[
    ("cornell", include_str!("../../scenes/cornell.json")),
    ("grids", include_str!("../../scenes/grids.json")),
    ("curved", include_str!("../../scenes/curved.json")),
    ("cornell-glossy", include_str!("../../scenes/cornell-glossy.json")),
    ("cornell-polished", include_str!("../../scenes/cornell-polished.json")),
    ("interior", include_str!("../../scenes/interior.json")),
    ("grids-3sigma", include_str!("../../scenes/grids-3sigma.json")),
    ("curved-3sigma", include_str!("../../scenes/curved-3sigma.json")),
    ("glossy-plates", include_str!("../../scenes/glossy-plates.json")),
    ("sky-spheres", include_str!("../../scenes/sky-spheres.json")),
];

pub struct BuiltinScene {
    pub name: &'static str,
    pub description: String,
    pub scene: proto::Scene,
}

/// Names of the built-in scenes.
pub fn names() -> impl Iterator<Item = &'static str> {
    SOURCES.iter().map(|(n, _)| *n)
}

fn parse(name: &'static str, text: &str) -> BuiltinScene {
    // A built-in scene that does not parse is a build defect, caught by the tests below.
    let scene = parse_scene(text, name).unwrap_or_else(|e| panic!("built-in scene {name}: {e}"));
    BuiltinScene { name, description: scene.description.clone(), scene }
}

/// All built-in scenes, in a stable order.
pub fn list() -> Vec<BuiltinScene> {
    SOURCES.iter().map(|(n, t)| parse(n, t)).collect()
}

pub fn get(name: &str) -> Option<proto::Scene> {
    SOURCES.iter().find(|(n, _)| *n == name).map(|(n, t)| parse(n, t).scene)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{compile, SceneLimits};

    #[test]
    fn every_builtin_scene_parses_validates_and_has_light() {
        for s in list() {
            let c = compile(&s.scene, &SceneLimits::default(), None).unwrap_or_else(|e| panic!("{}: {e}", s.name));
            assert!(c.triangle_count() > 0 && !c.lights.is_empty(), "{}", s.name);
            assert!(!s.description.is_empty());
            assert_eq!(c.degenerate_triangles, 0, "{}", s.name);
        }
        assert_eq!(
            names().collect::<Vec<_>>(),
            [
                "cornell",
                "grids",
                "curved",
                "cornell-glossy",
                "cornell-polished",
                "interior",
                "grids-3sigma",
                "curved-3sigma",
                "glossy-plates",
                "sky-spheres"
            ]
        );
        assert!(get("nope").is_none());
    }
}

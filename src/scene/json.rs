//! Scene files: `Scene` messages in protobuf's canonical JSON form, read through the compiled
//! descriptor set (prost-reflect), so the proto is the only schema. Errors name file and line.
use crate::proto;
use prost_reflect::{DescriptorPool, DynamicMessage, MessageDescriptor, SerializeOptions};
use std::path::Path;
use std::sync::OnceLock;

#[derive(Debug, thiserror::Error)]
pub enum SceneFileError {
    #[error("{path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}:{line}:{column}: {message}")]
    Syntax { path: String, line: usize, column: usize, message: String },
}

fn scene_descriptor() -> MessageDescriptor {
    static POOL: OnceLock<DescriptorPool> = OnceLock::new();
    let pool = POOL.get_or_init(|| {
        DescriptorPool::decode(proto::FILE_DESCRIPTOR_SET).expect("the descriptor set built by build.rs decodes")
    });
    pool.get_message_by_name("wedge.v1.Scene").expect("wedge.v1.Scene is in the descriptor set")
}

/// Parses a scene from canonical JSON. `name` labels errors (a path or a built-in name).
pub fn parse_scene(text: &str, name: &str) -> Result<proto::Scene, SceneFileError> {
    let mut de = serde_json::Deserializer::from_str(text);
    let syntax = |e: serde_json::Error| SceneFileError::Syntax {
        path: name.to_string(),
        line: e.line(),
        column: e.column(),
        message: strip_position(&e.to_string()),
    };
    let msg = DynamicMessage::deserialize(scene_descriptor(), &mut de).map_err(syntax)?;
    de.end().map_err(syntax)?;
    msg.transcode_to::<proto::Scene>().map_err(|e| SceneFileError::Syntax {
        path: name.to_string(),
        line: 0,
        column: 0,
        message: e.to_string(),
    })
}

/// serde_json appends " at line L column C"; the error carries those separately.
fn strip_position(s: &str) -> String {
    match s.rfind(" at line ") {
        Some(i) => s[..i].to_string(),
        None => s.to_string(),
    }
}

pub fn load_scene(path: &Path) -> Result<proto::Scene, SceneFileError> {
    let text = std::fs::read_to_string(path)
        .map_err(|source| SceneFileError::Io { path: path.display().to_string(), source })?;
    parse_scene(&text, &path.display().to_string())
}

/// Canonical JSON of a scene (pretty-printed), e.g. to write a built-in scene out as a file.
pub fn to_json(scene: &proto::Scene) -> String {
    let mut msg = DynamicMessage::new(scene_descriptor());
    msg.transcode_from(scene).expect("a Scene transcodes to its own descriptor");
    let mut ser = serde_json::Serializer::pretty(Vec::new());
    msg.serialize_with_options(&mut ser, &SerializeOptions::new().skip_default_fields(true))
        .expect("serialising to memory cannot fail");
    String::from_utf8(ser.into_inner()).expect("serde_json writes UTF-8")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_accepts_canonical_names() {
        let text = r#"{
            "camera": {"position": {"x": 1, "y": 2, "z": 3}, "lookAt": {"z": -1}, "verticalFovDeg": 40,
                       "width": 64, "height": 48},
            "lights": [{"rect": {"corner": {}, "edgeU": {"x": 1}, "edgeV": {"z": 1},
                        "radiance": {"r": 1, "g": 1, "b": 1}, "profile": "EMISSION_PROFILE_GAUSSIAN"}}]
        }"#;
        let s = parse_scene(text, "t.json").unwrap();
        let c = s.camera.as_ref().unwrap();
        assert_eq!((c.width, c.vertical_fov_deg), (64, 40.0));
        assert_eq!(s.lights.len(), 1);
        let back = parse_scene(&to_json(&s), "again").unwrap();
        assert_eq!(back, s);
    }

    #[test]
    fn errors_name_the_file_line_and_field() {
        let text = "{\n  \"camera\": {\n    \"widht\": 3\n  }\n}";
        let e = parse_scene(text, "scenes/x.json").unwrap_err().to_string();
        assert!(e.starts_with("scenes/x.json:3:"), "{e}");
        assert!(e.contains("widht"), "{e}");
        let e = parse_scene("{\"camera\": {\"width\": -1}}", "y.json").unwrap_err().to_string();
        assert!(e.starts_with("y.json:1:"), "{e}");
        let e = parse_scene("{} trailing", "z.json").unwrap_err().to_string();
        assert!(e.starts_with("z.json:1:"), "{e}");
    }

    #[test]
    fn nan_and_infinity_parse_and_are_left_to_the_validator() {
        let s = parse_scene(r#"{"camera": {"verticalFovDeg": "NaN"}}"#, "n.json").unwrap();
        assert!(s.camera.unwrap().vertical_fov_deg.is_nan());
    }
}

//! The `wedge.*` EXR header attributes: what produced a frame, recorded in the file the way
//! pbrt-v4 records its render settings, so an image alone says how to reproduce it.
//!
//! Types: u64 counters are text (no 64-bit integer attribute type exists, and f64 would round
//! above 2^53); u32 counters are `int` (checked, never wrapped); seconds and spp are `double`;
//! camera vectors are `v3f`. Text is UTF-8, as the OpenEXR library uses it (the exr crate's
//! `Text::from(&str)` would store Latin-1 and panic on other characters).
use std::collections::{BTreeMap, HashMap};

use exr::meta::attribute::{AttributeValue, Text};

use crate::pipeline::frame::{CameraInfo, ComponentMaps, FrameStats, HaltReason, RenderInfo};

pub(super) const PREFIX: &str = "wedge.";
pub(super) const SCENE: &str = "wedge.scene";
pub(super) const METHOD: &str = "wedge.method";
pub(super) const SEED: &str = "wedge.seed";
pub(super) const BOUNCES: &str = "wedge.bounces";
pub(super) const PASS: &str = "wedge.pass";
pub(super) const MEAN_SPP: &str = "wedge.meanSpp";
pub(super) const RAYS_TRACED: &str = "wedge.raysTraced";
pub(super) const DROPPED_SAMPLES: &str = "wedge.droppedSamples";
pub(super) const SECONDS: &str = "wedge.seconds";
pub(super) const METHOD_SECONDS: &str = "wedge.methodSeconds";
// Not in the original attribute list, but without them `FrameStats` would not survive a round
// trip through the file.
pub(super) const FINAL: &str = "wedge.final";
pub(super) const PASS_COMPLETE: &str = "wedge.passComplete";
/// Absent on a first frame, which has no estimate.
pub(super) const ESTIMATED_ERROR: &str = "wedge.estimatedError";
/// Only for methods that shade at a reduced rate (`FrameStats::full_resolution_points` > 0).
pub(super) const SHADED_POINTS: &str = "wedge.shadedPoints";
pub(super) const FULL_RESOLUTION_POINTS: &str = "wedge.fullResolutionPoints";
pub(super) const HALT_REASON: &str = "wedge.haltReason";
pub(super) const CAMERA_POSITION: &str = "wedge.cameraPosition";
pub(super) const CAMERA_LOOK_AT: &str = "wedge.cameraLookAt";
pub(super) const CAMERA_UP: &str = "wedge.cameraUp";
pub(super) const FOV_Y: &str = "wedge.fovY";
/// The names of the frame's components, space-separated, in `Frame::components` order; only
/// in files of frames that have components.
pub(super) const COMPONENTS: &str = "wedge.components";

/// The header attributes for a frame. `with_seconds` false leaves out the wall-clock times,
/// the only attributes that differ between two runs of the same render.
pub(super) fn to_attributes(
    info: &RenderInfo,
    stats: &FrameStats,
    with_seconds: bool,
) -> Result<Vec<(&'static str, AttributeValue)>, String> {
    let int = |name: &str, value: u32| {
        i32::try_from(value)
            .map(AttributeValue::I32)
            .map_err(|_| format!("{name} = {value} does not fit an int attribute"))
    };
    let camera = &info.camera;
    let mut attributes = vec![
        (SCENE, text(&info.scene)),
        (METHOD, text(&info.method)),
        (SEED, text(&info.seed.to_string())),
        (BOUNCES, int(BOUNCES, info.bounces)?),
        (PASS, int(PASS, stats.pass)?),
        (MEAN_SPP, AttributeValue::F64(stats.mean_spp)),
        (RAYS_TRACED, text(&stats.rays_traced.to_string())),
        (DROPPED_SAMPLES, text(&stats.dropped_samples.to_string())),
        (FINAL, AttributeValue::I32(stats.is_final.into())),
        (HALT_REASON, text(halt_reason_name(stats.halt_reason))),
        (PASS_COMPLETE, AttributeValue::I32(stats.pass_complete.into())),
        (CAMERA_POSITION, vec3(camera.position)),
        (CAMERA_LOOK_AT, vec3(camera.look_at)),
        (CAMERA_UP, vec3(camera.up)),
        (FOV_Y, AttributeValue::F32(camera.vertical_fov_deg)),
    ];
    if let Some(e) = stats.estimated_error {
        attributes.push((ESTIMATED_ERROR, AttributeValue::F64(e)));
    }
    if stats.full_resolution_points > 0 {
        attributes.push((SHADED_POINTS, text(&stats.shaded_points.to_string())));
        attributes.push((FULL_RESOLUTION_POINTS, text(&stats.full_resolution_points.to_string())));
    }
    if with_seconds {
        attributes.push((SECONDS, AttributeValue::F64(stats.elapsed_seconds)));
        attributes.push((METHOD_SECONDS, AttributeValue::F64(stats.method_seconds)));
    }
    Ok(attributes)
}

/// The attribute listing the components of a frame that has any.
pub(super) fn components_attribute(components: &[ComponentMaps]) -> Option<(&'static str, AttributeValue)> {
    let names: Vec<&str> = components.iter().map(|c| c.name.as_str()).collect();
    (!names.is_empty()).then(|| (COMPONENTS, text(&names.join(" "))))
}

/// The component names `components_attribute` recorded; none when the attribute is absent.
pub(super) fn read_components(attributes: &HashMap<Text, AttributeValue>) -> Result<Vec<String>, String> {
    match attributes.get(COMPONENTS.as_bytes()) {
        None => Ok(Vec::new()),
        Some(AttributeValue::Text(t)) => match std::str::from_utf8(t.bytes()) {
            Ok(names) => Ok(names.split_whitespace().map(str::to_string).collect()),
            Err(_) => Err(format!("attribute {COMPONENTS} is not UTF-8")),
        },
        Some(other) => Err(format!("attribute {COMPONENTS} has unexpected type or value {other:?}")),
    }
}

/// Parses what `to_attributes` wrote. Missing seconds read as 0 (a reproducible file).
pub(super) fn from_attributes(attributes: &HashMap<Text, AttributeValue>) -> Result<(RenderInfo, FrameStats), String> {
    let get = |name: &str| attributes.get(name.as_bytes()).ok_or_else(|| format!("missing attribute {name}"));
    let wrong_type =
        |name: &str, value: &AttributeValue| format!("attribute {name} has unexpected type or value {value:?}");
    let string = |name: &str| match get(name)? {
        AttributeValue::Text(t) => {
            String::from_utf8(t.bytes().to_vec()).map_err(|_| format!("attribute {name} is not UTF-8"))
        }
        other => Err(wrong_type(name, other)),
    };
    let parsed_u64 = |name: &str| string(name)?.parse::<u64>().map_err(|e| format!("attribute {name}: {e}"));
    let unsigned = |name: &str| match get(name)? {
        AttributeValue::I32(v) => u32::try_from(*v).map_err(|_| format!("attribute {name} = {v} is negative")),
        other => Err(wrong_type(name, other)),
    };
    let double = |name: &str| match get(name)? {
        AttributeValue::F64(v) => Ok(*v),
        other => Err(wrong_type(name, other)),
    };
    let optional_double = |name: &str| match attributes.contains_key(name.as_bytes()) {
        true => double(name),
        false => Ok(0.0),
    };
    let optional_u64 = |name: &str| match attributes.contains_key(name.as_bytes()) {
        true => parsed_u64(name),
        false => Ok(0),
    };
    let float = |name: &str| match get(name)? {
        AttributeValue::F32(v) => Ok(*v),
        other => Err(wrong_type(name, other)),
    };
    let vector = |name: &str| match get(name)? {
        AttributeValue::FloatVec3((x, y, z)) => Ok([*x, *y, *z]),
        other => Err(wrong_type(name, other)),
    };
    let flag = |name: &str| match get(name)? {
        AttributeValue::I32(0) => Ok(false),
        AttributeValue::I32(1) => Ok(true),
        other => Err(wrong_type(name, other)),
    };

    let halt_reason = string(HALT_REASON)?;
    let info = RenderInfo {
        scene: string(SCENE)?,
        method: string(METHOD)?,
        seed: parsed_u64(SEED)?,
        bounces: unsigned(BOUNCES)?,
        camera: CameraInfo {
            position: vector(CAMERA_POSITION)?,
            look_at: vector(CAMERA_LOOK_AT)?,
            up: vector(CAMERA_UP)?,
            vertical_fov_deg: float(FOV_Y)?,
        },
    };
    let stats = FrameStats {
        pass: unsigned(PASS)?,
        mean_spp: double(MEAN_SPP)?,
        rays_traced: parsed_u64(RAYS_TRACED)?,
        elapsed_seconds: optional_double(SECONDS)?,
        is_final: flag(FINAL)?,
        halt_reason: parse_halt_reason(&halt_reason)
            .ok_or_else(|| format!("attribute {HALT_REASON}: unknown value {halt_reason:?}"))?,
        dropped_samples: parsed_u64(DROPPED_SAMPLES)?,
        pass_complete: flag(PASS_COMPLETE)?,
        estimated_error: attributes
            .contains_key(ESTIMATED_ERROR.as_bytes())
            .then(|| double(ESTIMATED_ERROR))
            .transpose()?,
        method_seconds: optional_double(METHOD_SECONDS)?,
        shaded_points: optional_u64(SHADED_POINTS)?,
        full_resolution_points: optional_u64(FULL_RESOLUTION_POINTS)?,
    };
    Ok((info, stats))
}

/// All `wedge.*` attributes as display text, for tests and tools that print headers.
pub(super) fn attributes_as_text(attributes: &HashMap<Text, AttributeValue>) -> BTreeMap<String, String> {
    attributes
        .iter()
        .map(|(name, value)| (String::from_utf8_lossy(name.bytes()).into_owned(), value))
        .filter(|(name, _)| name.starts_with(PREFIX))
        .map(|(name, value)| (name, value_as_text(value)))
        .collect()
}

fn value_as_text(value: &AttributeValue) -> String {
    match value {
        AttributeValue::Text(t) => String::from_utf8_lossy(t.bytes()).into_owned(),
        AttributeValue::I32(v) => v.to_string(),
        // Rust's float Display is the shortest text that parses back to the same value.
        AttributeValue::F32(v) => v.to_string(),
        AttributeValue::F64(v) => v.to_string(),
        AttributeValue::FloatVec3((x, y, z)) => format!("{x} {y} {z}"),
        other => format!("{other:?}"),
    }
}

fn text(s: &str) -> AttributeValue {
    AttributeValue::Text(Text::from_slice_unchecked(s.as_bytes()))
}

fn vec3([x, y, z]: [f32; 3]) -> AttributeValue {
    AttributeValue::FloatVec3((x, y, z))
}

fn halt_reason_name(reason: HaltReason) -> &'static str {
    match reason {
        HaltReason::None => "none",
        HaltReason::MaxPasses => "maxPasses",
        HaltReason::MaxSpp => "maxSpp",
        HaltReason::TimeBudget => "timeBudget",
        HaltReason::NoiseTarget => "noiseTarget",
    }
}

fn parse_halt_reason(name: &str) -> Option<HaltReason> {
    [HaltReason::None, HaltReason::MaxPasses, HaltReason::MaxSpp, HaltReason::TimeBudget, HaltReason::NoiseTarget]
        .into_iter()
        .find(|&reason| halt_reason_name(reason) == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn as_map(attributes: Vec<(&'static str, AttributeValue)>) -> HashMap<Text, AttributeValue> {
        attributes.into_iter().map(|(name, value)| (Text::from(name), value)).collect()
    }

    fn sample() -> (RenderInfo, FrameStats) {
        let info = RenderInfo {
            scene: "scènes/cornell.json".into(),
            method: "aaf".into(),
            seed: u64::MAX,
            bounces: 5,
            camera: CameraInfo {
                position: [0.0, 1.0, 5.5],
                look_at: [0.0, 1.0, 0.0],
                up: [0.0, 1.0, 0.0],
                vertical_fov_deg: 39.3,
            },
        };
        let stats = FrameStats {
            pass: 7,
            mean_spp: 12.345,
            rays_traced: (1 << 60) + 1,
            elapsed_seconds: 3.25,
            is_final: true,
            halt_reason: HaltReason::TimeBudget,
            dropped_samples: 3,
            method_seconds: 0.5,
            pass_complete: false,
            estimated_error: Some(0.0125),
            shaded_points: (1 << 59) + 3,
            full_resolution_points: (1 << 60) + 5,
        };
        (info, stats)
    }

    #[test]
    fn attributes_round_trip_exactly() {
        let (info, stats) = sample();
        let map = as_map(to_attributes(&info, &stats, true).unwrap());
        assert_eq!(from_attributes(&map).unwrap(), (info, stats));
    }

    #[test]
    fn without_seconds_the_times_read_as_zero() {
        let (info, stats) = sample();
        let map = as_map(to_attributes(&info, &stats, false).unwrap());
        assert!(!map.contains_key(SECONDS.as_bytes()));
        assert!(!map.contains_key(METHOD_SECONDS.as_bytes()));
        let (read_info, read_stats) = from_attributes(&map).unwrap();
        assert_eq!(read_info, info);
        let expected = FrameStats { elapsed_seconds: 0.0, method_seconds: 0.0, ..stats };
        assert_eq!(read_stats, expected);
    }

    #[test]
    fn every_halt_reason_round_trips() {
        for reason in [
            HaltReason::None,
            HaltReason::MaxPasses,
            HaltReason::MaxSpp,
            HaltReason::TimeBudget,
            HaltReason::NoiseTarget,
        ] {
            assert_eq!(parse_halt_reason(halt_reason_name(reason)), Some(reason));
        }
        assert_eq!(parse_halt_reason("bogus"), None);
    }

    #[test]
    fn oversized_counters_are_errors_not_wrapped() {
        let (mut info, stats) = sample();
        info.bounces = u32::MAX;
        let error = to_attributes(&info, &stats, true).unwrap_err();
        assert!(error.contains(BOUNCES), "{error}");
    }

    #[test]
    fn missing_or_mistyped_attributes_are_named() {
        let (info, stats) = sample();
        let mut map = as_map(to_attributes(&info, &stats, true).unwrap());
        map.remove(SEED.as_bytes());
        assert!(from_attributes(&map).unwrap_err().contains(SEED));
        let mut map = as_map(to_attributes(&info, &stats, true).unwrap());
        map.insert(Text::from(PASS), AttributeValue::I32(-1));
        assert!(from_attributes(&map).unwrap_err().contains(PASS));
        map.insert(Text::from(PASS), AttributeValue::F32(1.0));
        assert!(from_attributes(&map).unwrap_err().contains(PASS));
    }

    #[test]
    fn text_view_lists_only_wedge_attributes() {
        let (info, stats) = sample();
        let mut map = as_map(to_attributes(&info, &stats, true).unwrap());
        map.insert(Text::from("owner"), text("someone"));
        let texts = attributes_as_text(&map);
        assert!(texts.keys().all(|k| k.starts_with(PREFIX)));
        assert_eq!(texts[SCENE], "scènes/cornell.json");
        assert_eq!(texts[SEED], u64::MAX.to_string());
        assert_eq!(texts[CAMERA_POSITION], "0 1 5.5");
        assert_eq!(texts[FOV_Y], "39.3");
        assert_eq!(texts[FINAL], "1");
        assert_eq!(texts[HALT_REASON], "timeBudget");
        assert_eq!(texts[FULL_RESOLUTION_POINTS], ((1u64 << 60) + 5).to_string());
        assert_eq!(texts.len(), 20);
    }
}

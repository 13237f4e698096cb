//! Material and light edits of a compiled scene (`SceneEdit`, sent in a session): validated
//! like the scene they change, applied to its description, and compiled without its shapes,
//! so the BVH is shared (or refitted when a rect light moved) rather than built again.
use super::compile::{add_light, materials};
use super::fields::err;
use super::FieldError;
use super::SceneLimits;
use crate::proto;
use crate::render::scene::{EditRefused, Scene, SceneBuilder};

/// What a compiled scene keeps of its description for edits: everything but the shapes.
pub fn header(scene: &proto::Scene) -> proto::Scene {
    proto::Scene { shapes: Vec::new(), ..scene.clone() }
}

/// Applies `edit` to `header` (a description without shapes, of the scene `compiled` was
/// compiled from) and returns the edited header and scene. Errors name the edit's field
/// (`edit.materials[0].glossy.exponent: ...`, `edit.lights[1].index: ...`).
pub fn apply(
    header: &proto::Scene,
    compiled: &Scene,
    edit: &proto::SceneEdit,
    limits: &SceneLimits,
) -> Result<(proto::Scene, Scene), FieldError> {
    let mut next = header.clone();
    // Each edited material is validated as it is, under its own name in the edit.
    let mut scratch = SceneBuilder::new(compiled.default_camera.clone());
    materials("edit.materials", &edit.materials, &mut scratch)?;
    for (i, m) in edit.materials.iter().enumerate() {
        let Some(j) = next.materials.iter().position(|o| o.name == m.name) else {
            return err(format!("edit.materials[{i}].name"), format!("the scene has no material named {:?}", m.name));
        };
        let (before, after) = (&compiled.materials[j], &scratch.materials[i]);
        if after.uses_uv() && !before.uses_uv() {
            return err(
                format!("edit.materials[{i}]"),
                format!(
                    "{:?} had no texture, so its shapes' uv coordinates were not kept: a textured material needs \
                     the scene compiled again (a new session)",
                    m.name
                ),
            );
        }
        next.materials[j] = m.clone();
    }
    for (i, l) in edit.lights.iter().enumerate() {
        let path = format!("edit.lights[{i}]");
        let Some(old) = next.lights.get(l.index as usize) else {
            return err(
                format!("{path}.index"),
                format!("the scene has {} lights, there is no light {}", next.lights.len(), l.index),
            );
        };
        let Some(light) = &l.light else { return err(format!("{path}.light"), "is required") };
        add_light(&format!("{path}.light"), light, &mut scratch, limits, None)?;
        let kind = |l: &proto::Light| l.kind.as_ref().map(std::mem::discriminant);
        if kind(light) != kind(old) {
            return err(
                format!("{path}.light"),
                "must be of the kind it replaces (rect, point or environment): another kind changes the geometry, \
                 which needs the scene compiled again (a new session)",
            );
        }
        next.lights[l.index as usize] = light.clone();
    }
    // The whole edited list, compiled as at compile time (materials, then lights).
    let mut b = SceneBuilder::new(compiled.default_camera.clone());
    materials("scene.materials", &next.materials, &mut b)?;
    for (i, light) in next.lights.iter().enumerate() {
        // An environment the edit left alone keeps its compiled map (building a map's
        // sampling tables costs more than the rest of an edit).
        if light == &header.lights[i] && matches!(light.kind, Some(proto::light::Kind::Environment(_))) {
            b.lights.push(compiled.lights[i].clone());
            continue;
        }
        add_light(&format!("scene.lights[{i}]"), light, &mut b, limits, None)?;
    }
    let scene = compiled.with_lights(b).map_err(|e| FieldError {
        field: "edit".into(),
        message: match e {
            EditRefused::Shape => "the edited scene differs from the compiled one in more than its materials and \
                                   lights: it needs compiling again (a new session)"
                .into(),
            EditRefused::NoRefit => "lights cannot move in this scene's BVH layout".into(),
        },
    })?;
    Ok((next, scene))
}

#[cfg(test)]
mod tests;

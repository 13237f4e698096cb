//! Reading proto fields with their paths: every check names the field it failed on.
use super::FieldError;
use crate::proto;
use glam::Vec3;
use std::path::{Path, PathBuf};

pub type FieldResult<T> = Result<T, FieldError>;

/// Largest light radiance and intensity: far beyond any real light, yet small enough that
/// radiance times geometry terms cannot overflow f32 into infinity.
pub const MAX_RADIANCE: f32 = 1e9;

pub fn err<T>(field: impl Into<String>, message: impl Into<String>) -> FieldResult<T> {
    Err(FieldError { field: field.into(), message: message.into() })
}

pub fn finite(path: &str, v: f32) -> FieldResult<f32> {
    if v.is_finite() {
        Ok(v)
    } else {
        err(path, format!("must be a finite number, got {v}"))
    }
}

/// A required vector: present and finite.
pub fn vec3(path: &str, v: &Option<proto::Vec3>) -> FieldResult<Vec3> {
    match v {
        None => err(path, "is required"),
        Some(v) => opt_vec3(path, v),
    }
}

pub fn opt_vec3(path: &str, v: &proto::Vec3) -> FieldResult<Vec3> {
    for (name, c) in [("x", v.x), ("y", v.y), ("z", v.z)] {
        finite(&format!("{path}.{name}"), c)?;
    }
    Ok(Vec3::new(v.x, v.y, v.z))
}

/// A required colour: present, finite, non-negative, and at most `max` per channel.
pub fn rgb(path: &str, v: &Option<proto::Rgb>, max: f32) -> FieldResult<Vec3> {
    let Some(v) = v else { return err(path, "is required") };
    for (name, c) in [("r", v.r), ("g", v.g), ("b", v.b)] {
        let p = format!("{path}.{name}");
        finite(&p, c)?;
        if c < 0.0 {
            return err(p, format!("must be >= 0, got {c}"));
        }
        if c > max {
            return err(p, format!("must be <= {max}, got {c}"));
        }
    }
    Ok(Vec3::new(v.r, v.g, v.b))
}

/// A non-zero direction.
pub fn direction(path: &str, v: &Option<proto::Vec3>) -> FieldResult<Vec3> {
    let d = vec3(path, v)?;
    if !(d.length_squared() > 0.0) || !d.length_squared().is_finite() {
        return err(path, "must be a non-zero vector");
    }
    Ok(d)
}

pub fn positive(path: &str, v: f32) -> FieldResult<f32> {
    finite(path, v)?;
    if v > 0.0 {
        Ok(v)
    } else {
        err(path, format!("must be > 0, got {v}"))
    }
}

pub fn in_range(path: &str, v: f32, lo: f32, hi: f32) -> FieldResult<f32> {
    finite(path, v)?;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        err(path, format!("must be in [{lo}, {hi}], got {v}"))
    }
}

/// An enum field's value, which proto3 lets be any integer.
pub fn enum_value<E: TryFrom<i32>>(path: &str, v: i32) -> FieldResult<E> {
    E::try_from(v).or_else(|_| err(path, format!("unknown value {v}")))
}

/// A file named by a scene file (a mesh, an environment map): relative to the scene's
/// directory `base`, and refused unless it lies inside `root` once links are resolved.
pub(crate) fn resolve_file(path: &str, file: &str, root: &Path, base: &Path) -> FieldResult<PathBuf> {
    let full = base.join(file);
    let resolved = full.canonicalize().or_else(|e| err(path, format!("cannot open {}: {e}", full.display())))?;
    let root = root.canonicalize().or_else(|e| err(path, format!("file root {}: {e}", root.display())))?;
    if !resolved.starts_with(&root) {
        return err(path, format!("{} is outside the allowed root {}", resolved.display(), root.display()));
    }
    Ok(resolved)
}

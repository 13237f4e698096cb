//! Validates a proto `EnvironmentLight` and builds the tracer's light: its radiance from a
//! constant, a map file, an inline map or the procedural sky, then scale and orientation.
use super::fields::{err, finite, in_range, opt_vec3, resolve_file, rgb, FieldResult, MAX_RADIANCE};
use super::SceneLimits;
use crate::proto;
use crate::render::environment::{EnvironmentLight, EnvironmentRadiance, LatLongMap};
use crate::render::sky::{self, Sky};
use glam::Vec3;
use std::path::Path;
use std::sync::Arc;

/// Widest sky map (`Sky.resolution`).
pub const MAX_SKY_RESOLUTION: u32 = 8192;

pub fn environment_light(
    path: &str,
    e: &proto::EnvironmentLight,
    limits: &SceneLimits,
    base_dir: Option<&Path>,
) -> FieldResult<EnvironmentLight> {
    use proto::environment_light::Radiance;
    let radiance = match &e.radiance {
        None => return err(path, "needs a radiance (constant, path, map or sky)"),
        Some(Radiance::Constant(c)) => {
            EnvironmentRadiance::Constant(rgb(&format!("{path}.constant"), &Some(*c), MAX_RADIANCE)?)
        }
        Some(Radiance::Path(file)) => {
            EnvironmentRadiance::Map(Arc::new(map_file(&format!("{path}.path"), file, limits, base_dir)?))
        }
        Some(Radiance::Map(m)) => EnvironmentRadiance::Map(Arc::new(inline_map(&format!("{path}.map"), m, limits)?)),
        Some(Radiance::Sky(s)) => EnvironmentRadiance::Map(Arc::new(sky_map(&format!("{path}.sky"), s, limits)?)),
    };
    let scale = match finite(&format!("{path}.scale"), e.scale)? {
        0.0 => 1.0,
        s if s > 0.0 && s <= MAX_RADIANCE => s,
        s => return err(format!("{path}.scale"), format!("must be in (0, {MAX_RADIANCE}], or 0 for 1; got {s}")),
    };
    let up = match &e.up {
        None => Vec3::Y,
        Some(v) => {
            let up = opt_vec3(&format!("{path}.up"), v)?;
            if !(up.length_squared() > 0.0 && up.length_squared().is_finite()) {
                return err(format!("{path}.up"), "must be a non-zero vector (or unset for +Y)");
            }
            up
        }
    };
    let rotation = finite(&format!("{path}.rotation_deg"), e.rotation_deg)?;
    Ok(EnvironmentLight::new(radiance, scale, up, rotation))
}

fn map_file(path: &str, file: &str, limits: &SceneLimits, base_dir: Option<&Path>) -> FieldResult<LatLongMap> {
    let (Some(root), Some(base)) = (&limits.mesh_root, base_dir) else {
        return err(
            path,
            "map files are not allowed here (only in scene files under the file root; send the map inline)",
        );
    };
    let resolved = resolve_file(path, file, root, base)?;
    let data = super::envmap::load_map(&resolved, limits.max_environment_texels).or_else(|e| err(path, e))?;
    Ok(LatLongMap::new(data.width, data.height, data.rgb.into_iter().map(Vec3::from).collect()))
}

fn inline_map(path: &str, m: &proto::EnvironmentMap, limits: &SceneLimits) -> FieldResult<LatLongMap> {
    let (w, h) = (m.width as u64, m.height as u64);
    if w == 0 || h == 0 {
        return err(path, format!("needs a width and a height, got {w} x {h}"));
    }
    if w * h > limits.max_environment_texels {
        return err(path, format!("{w} x {h} texels exceeds the limit of {}", limits.max_environment_texels));
    }
    if m.rgb.len() as u64 != 3 * w * h {
        return err(
            format!("{path}.rgb"),
            format!("must have {} numbers (3 per texel), got {}", 3 * w * h, m.rgb.len()),
        );
    }
    if let Some(i) = m.rgb.iter().position(|c| !c.is_finite()) {
        return err(format!("{path}.rgb[{i}]"), format!("must be a finite number, got {}", m.rgb[i]));
    }
    let texels = m.rgb.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    Ok(LatLongMap::new(w as usize, h as usize, texels))
}

fn sky_map(path: &str, s: &proto::Sky, limits: &SceneLimits) -> FieldResult<LatLongMap> {
    let colour = |name: &str, v: &Option<proto::Rgb>, default: Vec3| match v {
        None => Ok(default),
        Some(_) => rgb(&format!("{path}.{name}"), v, MAX_RADIANCE),
    };
    let elevation = match s.sun_elevation_deg {
        None => sky::DEFAULT_SUN_ELEVATION_DEG,
        Some(e) => in_range(&format!("{path}.sun_elevation_deg"), e, -90.0, 90.0)?,
    };
    let azimuth = finite(&format!("{path}.sun_azimuth_deg"), s.sun_azimuth_deg)?;
    let radius = match s.sun_radius_deg {
        0.0 => sky::DEFAULT_SUN_RADIUS_DEG,
        r => {
            let r = in_range(&format!("{path}.sun_radius_deg"), r, 0.0, 45.0)?;
            if r <= 0.0 {
                return err(
                    format!("{path}.sun_radius_deg"),
                    format!("must be in (0, 45], or 0 for the default; got {r}"),
                );
            }
            r
        }
    };
    let width = match s.resolution {
        0 => sky::DEFAULT_WIDTH as u32,
        r if (8..=MAX_SKY_RESOLUTION).contains(&r) => r,
        r => {
            return err(
                format!("{path}.resolution"),
                format!("must be in [8, {MAX_SKY_RESOLUTION}], or 0 for 512; got {r}"),
            )
        }
    };
    let texels = width as u64 * (width / 2) as u64;
    if texels > limits.max_environment_texels {
        return err(
            format!("{path}.resolution"),
            format!("{width} x {} texels exceeds the limit of {}", width / 2, limits.max_environment_texels),
        );
    }
    let sky = Sky {
        sun_direction: Sky::sun_direction_from(elevation, azimuth),
        sun_radius: radius.to_radians(),
        sun_radiance: colour("sun_radiance", &s.sun_radiance, sky::DEFAULT_SUN_RADIANCE)?,
        zenith: colour("zenith", &s.zenith, sky::DEFAULT_ZENITH)?,
        horizon: colour("horizon", &s.horizon, sky::DEFAULT_HORIZON)?,
        ground: colour("ground", &s.ground, sky::DEFAULT_GROUND)?,
    };
    Ok(sky.bake(width as usize))
}

//! Wavefront OBJ: `v`, `vt`, `vn` and `f` statements, re-indexed into per-vertex arrays.
use super::{count_of, shown, MeshData, MeshFileError};
use std::collections::hash_map::Entry;
use std::collections::HashMap;

/// "No texture coordinate / normal" in a corner. Attribute counts are kept below it.
const NONE: u32 = u32::MAX;

/// One face corner: indices (0-based, resolved) of its position, uv and normal.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
struct Corner {
    v: u32,
    vt: u32,
    vn: u32,
}

pub(super) fn parse(text: &str, name: &str, max_triangles: u64) -> Result<MeshData, MeshFileError> {
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut uvs: Vec<[f32; 2]> = Vec::new();
    let mut normals: Vec<[f32; 3]> = Vec::new();
    let mut corners: Vec<Corner> = Vec::new();
    // Triangles as indices into `corners`; mapped to unified vertices at the end.
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut all_have_uv = true;
    let mut all_have_normal = true;

    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let err = |message: String| MeshFileError::at_line(name, line, message);
        let content = match raw.find('#') {
            Some(p) => raw.get(..p).unwrap_or(""),
            None => raw,
        };
        let mut tokens = content.split_whitespace();
        let Some(keyword) = tokens.next() else {
            continue;
        };
        match keyword {
            "v" => {
                let (c, n) = numbers(tokens, keyword).map_err(err)?;
                if n < 3 {
                    return Err(err(format!("v needs 3 coordinates, found {n}")));
                }
                check_room(positions.len(), "vertices").map_err(err)?;
                positions.push([c[0], c[1], c[2]]);
            }
            "vt" => {
                let (c, n) = numbers(tokens, keyword).map_err(err)?;
                if n < 1 {
                    return Err(err("vt needs at least 1 coordinate, found 0".into()));
                }
                check_room(uvs.len(), "texture coordinates").map_err(err)?;
                uvs.push([c[0], c[1]]);
            }
            "vn" => {
                let (c, n) = numbers(tokens, keyword).map_err(err)?;
                if n < 3 {
                    return Err(err(format!("vn needs 3 coordinates, found {n}")));
                }
                check_room(normals.len(), "normals").map_err(err)?;
                normals.push([c[0], c[1], c[2]]);
            }
            "f" => {
                let n = tokens.clone().count();
                if n < 3 {
                    return Err(err(format!(
                        "face has {} (at least 3 needed)",
                        count_of(n as u64, "vertex", "vertices")
                    )));
                }
                let new_triangles = n as u64 - 2;
                let total = (triangles.len() as u64).checked_add(new_triangles);
                if total.is_none_or(|t| t > max_triangles) {
                    return Err(MeshFileError::too_many_triangles(name, max_triangles));
                }
                let (first, n32) = match (u32::try_from(corners.len()), u32::try_from(n)) {
                    (Ok(first), Ok(n32)) if first.checked_add(n32).is_some() => (first, n32),
                    _ => return Err(err("too many face vertices in the file".into())),
                };
                for token in tokens {
                    let corner = parse_corner(token, &positions, &uvs, &normals).map_err(err)?;
                    all_have_uv &= corner.vt != NONE;
                    all_have_normal &= corner.vn != NONE;
                    corners.push(corner);
                }
                // Fan: (0, k-1, k) for k in 2..n; `first + n` fits in u32 (checked above).
                for k in 2..n32 {
                    triangles.push([first, first + k - 1, first + k]);
                }
            }
            // o, g, s, usemtl, mtllib, l, p and anything unknown (vp, curves, ...).
            _ => {}
        }
    }

    if triangles.is_empty() {
        return Err(MeshFileError::Empty { name: name.to_owned() });
    }
    Ok(unify(&positions, all_have_uv.then_some(&uvs[..]), all_have_normal.then_some(&normals[..]), &corners, triangles))
}

/// Fails if another attribute of this kind would not leave room for the `NONE` sentinel.
fn check_room(len: usize, plural: &str) -> Result<(), String> {
    if len >= (NONE - 1) as usize {
        Err(format!("too many {plural} in the file"))
    } else {
        Ok(())
    }
}

/// Parses all remaining tokens of a `v`/`vt`/`vn` statement as finite numbers; returns the
/// first three (missing ones zero) and how many there were.
fn numbers<'a>(tokens: impl Iterator<Item = &'a str>, keyword: &str) -> Result<([f32; 3], usize), String> {
    let mut out = [0.0f32; 3];
    let mut n = 0usize;
    for token in tokens {
        let value: f32 =
            token.parse().map_err(|_| format!("invalid number {} in {keyword} statement", shown(token)))?;
        if !value.is_finite() {
            return Err(format!("non-finite number {} in {keyword} statement", shown(token)));
        }
        if let Some(slot) = out.get_mut(n) {
            *slot = value;
        }
        n += 1;
    }
    Ok((out, n))
}

/// Parses a face corner `v`, `v/vt`, `v//vn` or `v/vt/vn` against the attributes defined so far.
fn parse_corner(token: &str, positions: &[[f32; 3]], uvs: &[[f32; 2]], normals: &[[f32; 3]]) -> Result<Corner, String> {
    let mut parts = token.split('/');
    let v = parts.next().unwrap_or("");
    let vt = parts.next().unwrap_or("");
    let vn = parts.next().unwrap_or("");
    if parts.next().is_some() {
        return Err(format!("invalid face vertex {}", shown(token)));
    }
    if v.is_empty() {
        return Err(format!("face vertex {} has no position index", shown(token)));
    }
    let v = resolve(v, positions.len(), "face index", "vertex", "vertices")?;
    let vt = if vt.is_empty() {
        NONE
    } else {
        resolve(vt, uvs.len(), "texture coordinate index", "texture coordinate", "texture coordinates")?
    };
    let vn = if vn.is_empty() { NONE } else { resolve(vn, normals.len(), "normal index", "normal", "normals")? };
    Ok(Corner { v, vt, vn })
}

/// Resolves a 1-based (or negative, relative to the end) OBJ index against `count` entries
/// defined so far into a 0-based index.
fn resolve(token: &str, count: usize, what: &str, singular: &str, plural: &str) -> Result<u32, String> {
    let index: i64 = token.parse().map_err(|_| format!("invalid {what} {}", shown(token)))?;
    if index == 0 {
        return Err(format!("{what} 0 is invalid (OBJ indices start at 1)"));
    }
    let count_i = count as i128;
    let resolved = if index > 0 { i128::from(index) - 1 } else { count_i + i128::from(index) };
    if resolved < 0 || resolved >= count_i {
        return Err(format!("{what} {index} out of range ({})", count_of(count as u64, singular, plural)));
    }
    u32::try_from(resolved).map_err(|_| format!("{what} {index} out of range"))
}

/// Turns corners into unified vertices (one per distinct position/uv/normal combination of the
/// kept attributes) and maps the corner triangles onto them.
fn unify(
    positions: &[[f32; 3]],
    uvs: Option<&[[f32; 2]]>,
    normals: Option<&[[f32; 3]]>,
    corners: &[Corner],
    mut triangles: Vec<[u32; 3]>,
) -> MeshData {
    // Corner indices were checked against the attribute arrays when the face was read and the
    // arrays only grow, so the lookups below always succeed; the fallbacks are never taken.
    let mut vertex_of: HashMap<Corner, u32> = HashMap::with_capacity(corners.len().min(1 << 20));
    let mut remap: Vec<u32> = Vec::with_capacity(corners.len());
    let mut out_positions: Vec<[f32; 3]> = Vec::new();
    let mut out_uvs: Vec<[f32; 2]> = Vec::new();
    let mut out_normals: Vec<[f32; 3]> = Vec::new();
    for corner in corners {
        let key = Corner {
            v: corner.v,
            vt: if uvs.is_some() { corner.vt } else { NONE },
            vn: if normals.is_some() { corner.vn } else { NONE },
        };
        let id = match vertex_of.entry(key) {
            Entry::Occupied(o) => *o.get(),
            Entry::Vacant(slot) => {
                // At most one vertex per corner, and the corner count fits in u32.
                let id = u32::try_from(out_positions.len()).unwrap_or(NONE);
                out_positions.push(lookup(positions, key.v));
                if let Some(uvs) = uvs {
                    out_uvs.push(lookup(uvs, key.vt));
                }
                if let Some(normals) = normals {
                    out_normals.push(lookup(normals, key.vn));
                }
                *slot.insert(id)
            }
        };
        remap.push(id);
    }
    for triangle in &mut triangles {
        for index in triangle.iter_mut() {
            *index = lookup(&remap, *index);
        }
    }
    MeshData {
        positions: out_positions,
        indices: triangles,
        normals: normals.map(|_| out_normals),
        uvs: uvs.map(|_| out_uvs),
    }
}

fn lookup<T: Copy + Default>(items: &[T], index: u32) -> T {
    items.get(index as usize).copied().unwrap_or_default()
}

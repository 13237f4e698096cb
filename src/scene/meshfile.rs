//! Readers for the triangle mesh files that scene files reference: Wavefront OBJ and PLY
//! (ascii, binary little- and big-endian).
//!
//! Every reader is total: any input gives `Ok` or an `Err` that names the file and, for text,
//! the line, so that a user can fix the file. Counts from headers are never trusted for
//! allocation (reservations are capped by the data actually present), and the triangle limit is
//! enforced while reading, before the whole mesh is built.
use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

mod obj;
mod ply;
#[cfg(test)]
mod tests;

/// A triangle mesh with per-vertex attributes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    pub positions: Vec<[f32; 3]>,
    /// Triangles, indices into `positions` (polygons are fan-triangulated). Degenerate
    /// triangles (a repeated index) are kept.
    pub indices: Vec<[u32; 3]>,
    /// Per vertex (same length as `positions`), when the file has normals for every vertex.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Per vertex (same length as `positions`), when the file has texture coordinates for every
    /// vertex.
    pub uvs: Option<Vec<[f32; 2]>>,
}

/// Where in a mesh file a [`MeshFileError::Parse`] was found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    /// A 1-based line of a text file (OBJ, or the body of an ascii PLY): shown as `name:12`.
    Line(usize),
    /// The PLY header, with the 1-based line when one line is at fault: shown as
    /// `name: header: line 3` or `name: header`.
    Header(Option<usize>),
    /// A 0-based element of a binary PLY body (e.g. `face` #12, the index that face indices
    /// use for vertices): shown as `name: face #12`.
    Element { element: String, index: u64 },
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(line) => write!(f, ":{line}"),
            Location::Header(Some(line)) => write!(f, ": header: line {line}"),
            Location::Header(None) => write!(f, ": header"),
            Location::Element { element, index } => write!(f, ": {element} #{index}"),
        }
    }
}

/// A mesh file that cannot be read. The `Display` form starts with the file name (and line),
/// e.g. `meshes/bunny.obj:12: face index 40 out of range (36 vertices)`.
#[derive(Debug, thiserror::Error)]
pub enum MeshFileError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("{}: unsupported mesh file type (expected a .obj or .ply extension)", path.display())]
    UnsupportedFormat { path: PathBuf },
    #[error("{name}{location}: {message}")]
    Parse { name: String, location: Location, message: String },
    #[error("{name}: mesh has more than {limit} triangles (the triangle limit)")]
    TooManyTriangles { name: String, limit: u64 },
    #[error("{name}: mesh has no triangles")]
    Empty { name: String },
}

impl MeshFileError {
    /// The 1-based line of a text file the error points at, if any.
    pub fn line(&self) -> Option<usize> {
        match self {
            MeshFileError::Parse { location: Location::Line(line) | Location::Header(Some(line)), .. } => Some(*line),
            _ => None,
        }
    }

    fn parse(name: &str, location: Location, message: impl Into<String>) -> Self {
        MeshFileError::Parse { name: name.to_owned(), location, message: message.into() }
    }

    fn at_line(name: &str, line: usize, message: impl Into<String>) -> Self {
        Self::parse(name, Location::Line(line), message)
    }

    fn too_many_triangles(name: &str, limit: u64) -> Self {
        MeshFileError::TooManyTriangles { name: name.to_owned(), limit }
    }
}

/// Reads the mesh file at `path`, choosing the format by extension (`.obj` or `.ply`, any
/// case). Fails if the mesh has more than `max_triangles` triangles or none at all.
pub fn load_mesh(path: &Path, max_triangles: u64) -> Result<MeshData, MeshFileError> {
    enum Kind {
        Obj,
        Ply,
    }
    let kind = match path.extension().and_then(|e| e.to_str()) {
        Some(ext) if ext.eq_ignore_ascii_case("obj") => Kind::Obj,
        Some(ext) if ext.eq_ignore_ascii_case("ply") => Kind::Ply,
        _ => return Err(MeshFileError::UnsupportedFormat { path: path.to_path_buf() }),
    };
    let bytes = std::fs::read(path).map_err(|source| MeshFileError::Io { path: path.to_path_buf(), source })?;
    let name = path.display().to_string();
    match kind {
        // Names and comments in OBJ files are often in a legacy 8-bit encoding; they are ignored,
        // and a stray replacement character in a number still fails with its line.
        Kind::Obj => parse_obj(&String::from_utf8_lossy(&bytes), &name, max_triangles),
        Kind::Ply => parse_ply(&bytes, &name, max_triangles),
    }
}

/// Parses Wavefront OBJ text (`v`, `vt`, `vn`, `f`; other statements are ignored). `name` is
/// used in error messages.
pub fn parse_obj(text: &str, name: &str, max_triangles: u64) -> Result<MeshData, MeshFileError> {
    obj::parse(text, name, max_triangles)
}

/// Parses a PLY file (ascii, binary little- or big-endian). `name` is used in error messages.
pub fn parse_ply(bytes: &[u8], name: &str, max_triangles: u64) -> Result<MeshData, MeshFileError> {
    ply::parse(bytes, name, max_triangles)
}

/// A token from the file for an error message, shortened if it is long.
fn shown(token: &str) -> String {
    const MAX_CHARS: usize = 40;
    if token.chars().count() <= MAX_CHARS {
        format!("{token:?}")
    } else {
        let head: String = token.chars().take(MAX_CHARS).collect();
        format!("{head:?}...")
    }
}

/// `1 vertex`, `2 vertices`.
fn count_of(n: impl Into<u64>, singular: &str, plural: &str) -> String {
    let n = n.into();
    if n == 1 {
        format!("1 {singular}")
    } else {
        format!("{n} {plural}")
    }
}

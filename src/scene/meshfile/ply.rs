//! PLY: header, then an ascii or binary (little- or big-endian) body. The `vertex` and `face`
//! elements are read; every other element and property is skipped.
use super::{count_of, shown, Location, MeshData, MeshFileError};
use std::collections::HashSet;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_int(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The inclusive value range of an integer type.
    fn int_range(self) -> (i64, i64) {
        match self {
            Scalar::I8 => (i8::MIN.into(), i8::MAX.into()),
            Scalar::U8 => (0, u8::MAX.into()),
            Scalar::I16 => (i16::MIN.into(), i16::MAX.into()),
            Scalar::U16 => (0, u16::MAX.into()),
            Scalar::I32 => (i32::MIN.into(), i32::MAX.into()),
            Scalar::U32 => (0, u32::MAX.into()),
            Scalar::F32 | Scalar::F64 => (i64::MIN, i64::MAX),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Num {
    Int(i64),
    Float(f64),
}

impl Num {
    fn as_f64(self) -> f64 {
        match self {
            Num::Int(i) => i as f64,
            Num::Float(f) => f,
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
    /// Header line of the `element` statement.
    line: usize,
}

impl Element {
    fn prop(&self, name: &str) -> Option<(usize, &Property)> {
        self.props.iter().enumerate().find(|(_, p)| p.name == name)
    }

    /// The fewest body bytes one instance can take: binary sizes, or two characters (a digit
    /// and a separator) per ascii value; the list property `face_list`, if any, has at least 3
    /// items. Used to cap reservations by the data present.
    fn min_row_bytes(&self, ascii: bool, face_list: Option<usize>) -> usize {
        self.props
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let items = if Some(i) == face_list { 3 } else { 0 };
                match (ascii, p.kind) {
                    (true, Kind::Scalar(_)) => 2,
                    (true, Kind::List { .. }) => 2 + 2 * items,
                    (false, Kind::Scalar(s)) => s.size(),
                    (false, Kind::List { count, item }) => count.size() + items * item.size(),
                }
            })
            .sum::<usize>()
            .max(1)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset of the body.
    body_start: usize,
    /// Number of header lines (the body's first line is `lines + 1`).
    lines: usize,
}

/// What to read from the `vertex` element: property positions of each target.
struct VertexPlan {
    element: usize,
    xyz: [usize; 3],
    normal: Option<[usize; 3]>,
    uv: Option<[usize; 2]>,
}

struct FacePlan {
    element: usize,
    indices: usize,
}

pub(super) fn parse(bytes: &[u8], name: &str, max_triangles: u64) -> Result<MeshData, MeshFileError> {
    let header = parse_header(bytes, name)?;
    let (vertex, face) = plan(&header, name, max_triangles)?;
    let body = bytes.get(header.body_start..).unwrap_or(&[]);
    match header.format {
        Format::Ascii => {
            let mut reader = AsciiReader { name, body, pos: 0, line: header.lines, tokens: "".split_whitespace() };
            read_body(&mut reader, &header, &vertex, &face, name, max_triangles)
        }
        Format::BinaryLe | Format::BinaryBe => {
            let mut reader = BinaryReader {
                name,
                data: body,
                pos: 0,
                big_endian: header.format == Format::BinaryBe,
                element: "",
                index: 0,
            };
            read_body(&mut reader, &header, &vertex, &face, name, max_triangles)
        }
    }
}

fn parse_header(bytes: &[u8], name: &str) -> Result<Header, MeshFileError> {
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut format: Option<Format> = None;
    let mut elements: Vec<Element> = Vec::new();
    // Names seen so far (sets, so that a hostile header with many names stays linear).
    let mut element_names: HashSet<String> = HashSet::new();
    let mut property_names: HashSet<String> = HashSet::new();
    loop {
        let rest = bytes.get(pos..).unwrap_or(&[]);
        if rest.is_empty() {
            let message = if line_no == 0 {
                "empty file (expected a PLY header)"
            } else {
                "missing end_header (the file ends inside the header)"
            };
            return Err(MeshFileError::parse(name, Location::Header(None), message));
        }
        let (line_bytes, next) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (rest.get(..i).unwrap_or(&[]), pos.saturating_add(i + 1)),
            None => (rest, bytes.len()),
        };
        pos = next;
        line_no += 1;
        let err = |message: String| MeshFileError::parse(name, Location::Header(Some(line_no)), message);
        let text = String::from_utf8_lossy(line_bytes);
        let mut tokens = text.split_whitespace();
        let keyword = tokens.next();
        if line_no == 1 {
            if keyword != Some("ply") || tokens.next().is_some() {
                return Err(err("not a PLY file (the first line must be \"ply\")".into()));
            }
            continue;
        }
        let Some(keyword) = keyword else {
            continue;
        };
        let args: Vec<&str> = tokens.collect();
        match keyword {
            "comment" | "obj_info" => {}
            "format" => {
                if format.is_some() {
                    return Err(err("duplicate format line".into()));
                }
                let [kind, version] = args[..] else {
                    return Err(err("expected \"format <ascii|binary_little_endian|binary_big_endian> 1.0\"".into()));
                };
                format = Some(match kind {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLe,
                    "binary_big_endian" => Format::BinaryBe,
                    _ => return Err(err(format!("unknown format {}", shown(kind)))),
                });
                if version != "1.0" && version != "1" {
                    return Err(err(format!("unsupported PLY version {}", shown(version))));
                }
            }
            "element" => {
                let [element_name, count] = args[..] else {
                    return Err(err("expected \"element <name> <count>\"".into()));
                };
                let count: u64 = count.parse().map_err(|_| err(format!("invalid element count {}", shown(count))))?;
                if !element_names.insert(element_name.to_owned()) {
                    return Err(err(format!("duplicate element {}", shown(element_name))));
                }
                property_names.clear();
                elements.push(Element { name: element_name.to_owned(), count, props: Vec::new(), line: line_no });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(err("property before any element".into()));
                };
                let scalar =
                    |s: &str| Scalar::parse(s).ok_or_else(|| err(format!("unknown property type {}", shown(s))));
                let (kind, prop_name) = match args[..] {
                    ["list", count, item, prop_name] => {
                        let count = scalar(count)?;
                        if !count.is_int() {
                            return Err(err(format!("list count type must be an integer type, not {}", count.name())));
                        }
                        (Kind::List { count, item: scalar(item)? }, prop_name)
                    }
                    ["list", ..] => {
                        return Err(err("expected \"property list <count type> <item type> <name>\"".into()))
                    }
                    [ty, prop_name] => (Kind::Scalar(scalar(ty)?), prop_name),
                    _ => return Err(err("expected \"property <type> <name>\"".into())),
                };
                if !property_names.insert(prop_name.to_owned()) {
                    return Err(err(format!(
                        "duplicate property {} in element {}",
                        shown(prop_name),
                        shown(&element.name)
                    )));
                }
                element.props.push(Property { name: prop_name.to_owned(), kind });
            }
            "end_header" => {
                let Some(format) = format else {
                    return Err(err("end_header before the format line".into()));
                };
                return Ok(Header { format, elements, body_start: pos, lines: line_no });
            }
            _ => return Err(err(format!("unknown header keyword {}", shown(keyword)))),
        }
    }
}

/// Checks that the header describes a triangle mesh and finds the properties to read.
fn plan(header: &Header, name: &str, max_triangles: u64) -> Result<(VertexPlan, FacePlan), MeshFileError> {
    let header_err = |line: Option<usize>, message: String| MeshFileError::parse(name, Location::Header(line), message);
    let find = |wanted: &str| header.elements.iter().enumerate().find(|(_, e)| e.name == wanted);

    let Some((vertex_index, vertex)) = find("vertex") else {
        return Err(header_err(None, "no vertex element".into()));
    };
    let scalar_prop = |prop: &str| -> Result<Option<usize>, MeshFileError> {
        match vertex.prop(prop) {
            None => Ok(None),
            Some((i, Property { kind: Kind::Scalar(_), .. })) => Ok(Some(i)),
            Some(_) => {
                Err(header_err(Some(vertex.line), format!("vertex property {prop} must be a scalar, not a list")))
            }
        }
    };
    let mut xyz = [0usize; 3];
    for (slot, axis) in xyz.iter_mut().zip(["x", "y", "z"]) {
        *slot = scalar_prop(axis)?
            .ok_or_else(|| header_err(Some(vertex.line), format!("vertex element has no {axis} property")))?;
    }
    let normal = match (scalar_prop("nx")?, scalar_prop("ny")?, scalar_prop("nz")?) {
        (Some(x), Some(y), Some(z)) => Some([x, y, z]),
        _ => None,
    };
    let mut uv = None;
    for (u, v) in [("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")] {
        if let (Some(u), Some(v)) = (scalar_prop(u)?, scalar_prop(v)?) {
            uv = Some([u, v]);
            break;
        }
    }
    if vertex.count > u64::from(u32::MAX) {
        return Err(header_err(
            Some(vertex.line),
            format!("{} vertices is more than 32-bit indices can address", vertex.count),
        ));
    }

    let Some((face_index, face)) = find("face") else {
        // A point cloud (or triangle strips, which are not supported).
        return Err(MeshFileError::Empty { name: name.to_owned() });
    };
    let indices = face
        .prop("vertex_indices")
        .or_else(|| face.prop("vertex_index"))
        .ok_or_else(|| header_err(Some(face.line), "face element has no vertex_indices list".into()))?;
    match indices.1.kind {
        Kind::List { item, .. } if item.is_int() => {}
        Kind::List { item, .. } => {
            return Err(header_err(
                Some(face.line),
                format!("face {} must be a list of integers, not {}", indices.1.name, item.name()),
            ))
        }
        Kind::Scalar(_) => {
            return Err(header_err(Some(face.line), format!("face {} must be a list property", indices.1.name)))
        }
    }
    // Every face gives at least one triangle (smaller faces are an error).
    if face.count > max_triangles {
        return Err(MeshFileError::too_many_triangles(name, max_triangles));
    }
    Ok((VertexPlan { element: vertex_index, xyz, normal, uv }, FacePlan { element: face_index, indices: indices.0 }))
}

/// Reading one body format. Errors name the current line (ascii) or element instance (binary).
trait Reader<'a> {
    /// Bytes of the body not read yet.
    fn remaining(&self) -> usize;
    /// Whether this is the ascii format (for estimating sizes).
    fn is_ascii(&self) -> bool;
    /// Starts instance `index` of `element` (which has `count` instances).
    fn start_row(&mut self, element: &'a str, index: u64, count: u64) -> Result<(), MeshFileError>;
    fn scalar(&mut self, ty: Scalar) -> Result<Num, MeshFileError>;
    fn skip_scalar(&mut self, ty: Scalar) -> Result<(), MeshFileError>;
    /// Reads a list length.
    fn list_len(&mut self, ty: Scalar) -> Result<u64, MeshFileError>;
    fn skip_items(&mut self, n: u64, ty: Scalar) -> Result<(), MeshFileError>;
    fn end_row(&mut self) -> Result<(), MeshFileError>;
    /// Skips all `count` instances of `element`, whose instances all take `stride` bytes, if
    /// this format can do so without reading them one by one; returns whether it did.
    fn skip_fixed_rows(&mut self, element: &'a str, count: u64, stride: usize) -> Result<bool, MeshFileError>;
    fn error(&self, message: String) -> MeshFileError;
}

fn read_body<'a, R: Reader<'a>>(
    r: &mut R,
    header: &'a Header,
    vertex: &VertexPlan,
    face: &FacePlan,
    name: &str,
    max_triangles: u64,
) -> Result<MeshData, MeshFileError> {
    let mut mesh = MeshData::default();
    let mut normals: Vec<[f32; 3]> = Vec::new();
    let mut uvs: Vec<[f32; 2]> = Vec::new();
    for (index, element) in header.elements.iter().enumerate() {
        if element.props.is_empty() || element.count == 0 {
            continue;
        }
        // Never reserve more instances than the remaining data could hold.
        let face_list = (index == face.element).then_some(face.indices);
        let cap = (r.remaining() / element.min_row_bytes(r.is_ascii(), face_list))
            .min(usize::try_from(element.count).unwrap_or(usize::MAX));
        if index == vertex.element {
            mesh.positions.reserve(cap);
            if vertex.normal.is_some() {
                normals.reserve(cap);
            }
            if vertex.uv.is_some() {
                uvs.reserve(cap);
            }
            read_vertices(r, element, vertex, &mut mesh.positions, &mut normals, &mut uvs)?;
        } else if index == face.element {
            mesh.indices.reserve(cap.min(usize::try_from(max_triangles).unwrap_or(usize::MAX)));
            read_faces(
                r,
                element,
                face.indices,
                header_vertex_count(header, vertex),
                &mut mesh.indices,
                name,
                max_triangles,
            )?;
        } else {
            skip_element(r, element)?;
        }
    }
    if mesh.indices.is_empty() {
        return Err(MeshFileError::Empty { name: name.to_owned() });
    }
    mesh.normals = vertex.normal.map(|_| normals);
    mesh.uvs = vertex.uv.map(|_| uvs);
    Ok(mesh)
}

fn header_vertex_count(header: &Header, vertex: &VertexPlan) -> u64 {
    header.elements.get(vertex.element).map_or(0, |e| e.count)
}

fn read_vertices<'a, R: Reader<'a>>(
    r: &mut R,
    element: &'a Element,
    plan: &VertexPlan,
    positions: &mut Vec<[f32; 3]>,
    normals: &mut Vec<[f32; 3]>,
    uvs: &mut Vec<[f32; 2]>,
) -> Result<(), MeshFileError> {
    // Which of the 8 values (x y z nx ny nz u v) each property fills.
    let mut target: Vec<Option<usize>> = vec![None; element.props.len()];
    let mut set = |prop: usize, slot: usize| {
        if let Some(t) = target.get_mut(prop) {
            *t = Some(slot);
        }
    };
    for (slot, &prop) in plan.xyz.iter().enumerate() {
        set(prop, slot);
    }
    if let Some(normal) = plan.normal {
        for (slot, &prop) in normal.iter().enumerate() {
            set(prop, 3 + slot);
        }
    }
    if let Some(uv) = plan.uv {
        for (slot, &prop) in uv.iter().enumerate() {
            set(prop, 6 + slot);
        }
    }
    const WHAT: [&str; 8] = [
        "x coordinate",
        "y coordinate",
        "z coordinate",
        "normal nx",
        "normal ny",
        "normal nz",
        "texture coordinate u",
        "texture coordinate v",
    ];
    for row in 0..element.count {
        r.start_row(&element.name, row, element.count)?;
        let mut values = [0.0f32; 8];
        for (prop, slot) in element.props.iter().zip(&target) {
            match (prop.kind, slot) {
                (Kind::Scalar(ty), Some(slot)) => {
                    let value = r.scalar(ty)?.as_f64() as f32;
                    if !value.is_finite() {
                        let what = WHAT.get(*slot).copied().unwrap_or("value");
                        return Err(r.error(format!("non-finite {what} ({} {})", prop.name, value)));
                    }
                    if let Some(v) = values.get_mut(*slot) {
                        *v = value;
                    }
                }
                (Kind::Scalar(ty), None) => r.skip_scalar(ty)?,
                (Kind::List { count, item }, _) => {
                    let n = r.list_len(count)?;
                    r.skip_items(n, item)?;
                }
            }
        }
        r.end_row()?;
        let [x, y, z, nx, ny, nz, u, v] = values;
        positions.push([x, y, z]);
        if plan.normal.is_some() {
            normals.push([nx, ny, nz]);
        }
        if plan.uv.is_some() {
            uvs.push([u, v]);
        }
    }
    Ok(())
}

fn read_faces<'a, R: Reader<'a>>(
    r: &mut R,
    element: &'a Element,
    indices_prop: usize,
    vertex_count: u64,
    triangles: &mut Vec<[u32; 3]>,
    name: &str,
    max_triangles: u64,
) -> Result<(), MeshFileError> {
    for row in 0..element.count {
        r.start_row(&element.name, row, element.count)?;
        for (p, prop) in element.props.iter().enumerate() {
            match prop.kind {
                Kind::List { count, item } if p == indices_prop => {
                    let n = r.list_len(count)?;
                    if n < 3 {
                        return Err(
                            r.error(format!("face has {} (at least 3 needed)", count_of(n, "vertex", "vertices")))
                        );
                    }
                    let total = (triangles.len() as u64).checked_add(n - 2);
                    if total.is_none_or(|t| t > max_triangles) {
                        return Err(MeshFileError::too_many_triangles(name, max_triangles));
                    }
                    let mut index = || -> Result<u32, MeshFileError> {
                        let value = match r.scalar(item)? {
                            Num::Int(i) => i,
                            // Item types are checked to be integers in the header.
                            Num::Float(f) => return Err(r.error(format!("vertex index {f} is not an integer"))),
                        };
                        match u32::try_from(value) {
                            Ok(v) if u64::from(v) < vertex_count => Ok(v),
                            _ => Err(r.error(format!(
                                "vertex index {value} out of range ({})",
                                count_of(vertex_count, "vertex", "vertices")
                            ))),
                        }
                    };
                    let first = index()?;
                    let mut previous = index()?;
                    for _ in 2..n {
                        let current = index()?;
                        triangles.push([first, previous, current]);
                        previous = current;
                    }
                }
                Kind::List { count, item } => {
                    let n = r.list_len(count)?;
                    r.skip_items(n, item)?;
                }
                Kind::Scalar(ty) => r.skip_scalar(ty)?,
            }
        }
        r.end_row()?;
    }
    Ok(())
}

fn skip_element<'a, R: Reader<'a>>(r: &mut R, element: &'a Element) -> Result<(), MeshFileError> {
    let fixed_stride: Option<usize> = element
        .props
        .iter()
        .map(|p| match p.kind {
            Kind::Scalar(s) => Some(s.size()),
            Kind::List { .. } => None,
        })
        .sum();
    if let Some(stride) = fixed_stride {
        if r.skip_fixed_rows(&element.name, element.count, stride)? {
            return Ok(());
        }
    }
    for row in 0..element.count {
        r.start_row(&element.name, row, element.count)?;
        for prop in &element.props {
            match prop.kind {
                Kind::Scalar(ty) => r.skip_scalar(ty)?,
                Kind::List { count, item } => {
                    let n = r.list_len(count)?;
                    r.skip_items(n, item)?;
                }
            }
        }
        r.end_row()?;
    }
    Ok(())
}

struct AsciiReader<'a> {
    name: &'a str,
    body: &'a [u8],
    pos: usize,
    /// 1-based line number of the current line (the header's last line before the first row).
    line: usize,
    tokens: std::str::SplitWhitespace<'a>,
}

impl<'a> AsciiReader<'a> {
    fn token(&mut self) -> Result<&'a str, MeshFileError> {
        self.tokens.next().ok_or_else(|| self.error("too few values on the line".into()))
    }

    fn int_token(&mut self, ty: Scalar, what: &str) -> Result<i64, MeshFileError> {
        let token = self.token()?;
        let value = token.parse::<i64>().ok().or_else(|| {
            // Some writers print integers as floats ("3.0").
            token.parse::<f64>().ok().filter(|f| f.fract() == 0.0 && f.abs() < 9.0e18).map(|f| f as i64)
        });
        let (min, max) = ty.int_range();
        match value {
            Some(v) if (min..=max).contains(&v) => Ok(v),
            Some(_) => Err(self.error(format!("{what} {} out of range for type {}", shown(token), ty.name()))),
            None => Err(self.error(format!("invalid {what} {} (expected {})", shown(token), ty.name()))),
        }
    }
}

impl<'a> Reader<'a> for AsciiReader<'a> {
    fn remaining(&self) -> usize {
        self.body.len().saturating_sub(self.pos)
    }

    fn is_ascii(&self) -> bool {
        true
    }

    fn start_row(&mut self, element: &'a str, index: u64, count: u64) -> Result<(), MeshFileError> {
        // One instance per line; blank lines are skipped.
        loop {
            let rest = self.body.get(self.pos..).unwrap_or(&[]);
            if rest.is_empty() {
                return Err(MeshFileError::at_line(
                    self.name,
                    self.line + 1,
                    format!("unexpected end of file: {} {element} instances declared, found {index}", count),
                ));
            }
            let (line, next) = match rest.iter().position(|&b| b == b'\n') {
                Some(i) => (rest.get(..i).unwrap_or(&[]), self.pos.saturating_add(i + 1)),
                None => (rest, self.body.len()),
            };
            self.pos = next;
            self.line += 1;
            let text = std::str::from_utf8(line)
                .map_err(|_| self.error("invalid text (not UTF-8) in an ascii PLY body".into()))?;
            if !text.trim().is_empty() {
                self.tokens = text.split_whitespace();
                return Ok(());
            }
        }
    }

    fn scalar(&mut self, ty: Scalar) -> Result<Num, MeshFileError> {
        if ty.is_int() {
            return self.int_token(ty, "value").map(Num::Int);
        }
        let token = self.token()?;
        token
            .parse::<f64>()
            .map(Num::Float)
            .map_err(|_| self.error(format!("invalid {} value {}", ty.name(), shown(token))))
    }

    fn skip_scalar(&mut self, _ty: Scalar) -> Result<(), MeshFileError> {
        self.token().map(|_| ())
    }

    fn list_len(&mut self, ty: Scalar) -> Result<u64, MeshFileError> {
        let n = self.int_token(ty, "list length")?;
        u64::try_from(n).map_err(|_| self.error(format!("negative list length {n}")))
    }

    fn skip_items(&mut self, n: u64, _ty: Scalar) -> Result<(), MeshFileError> {
        // Bounded by the tokens on the line: stops at the first missing one.
        for _ in 0..n {
            self.token()?;
        }
        Ok(())
    }

    fn end_row(&mut self) -> Result<(), MeshFileError> {
        match self.tokens.next() {
            None => Ok(()),
            Some(extra) => Err(self.error(format!(
                "unexpected extra value {} at the end of the line (the header declares fewer properties)",
                shown(extra)
            ))),
        }
    }

    fn skip_fixed_rows(&mut self, _element: &'a str, _count: u64, _stride: usize) -> Result<bool, MeshFileError> {
        Ok(false)
    }

    fn error(&self, message: String) -> MeshFileError {
        MeshFileError::at_line(self.name, self.line, message)
    }
}

struct BinaryReader<'a> {
    name: &'a str,
    data: &'a [u8],
    pos: usize,
    big_endian: bool,
    /// Current element instance, for errors.
    element: &'a str,
    index: u64,
}

impl<'a> BinaryReader<'a> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], MeshFileError> {
        let bytes = self
            .pos
            .checked_add(N)
            .and_then(|end| self.data.get(self.pos..end))
            .and_then(|s| <[u8; N]>::try_from(s).ok())
            .ok_or_else(|| self.truncated())?;
        self.pos += N;
        Ok(bytes)
    }

    fn truncated(&self) -> MeshFileError {
        self.error("unexpected end of data (the file is truncated)".into())
    }

    fn advance(&mut self, bytes: u64) -> Result<(), MeshFileError> {
        match usize::try_from(bytes).ok().and_then(|b| self.pos.checked_add(b)) {
            Some(end) if end <= self.data.len() => {
                self.pos = end;
                Ok(())
            }
            _ => Err(self.truncated()),
        }
    }
}

macro_rules! read_as {
    ($self:ident, $t:ty) => {{
        let bytes = $self.take()?;
        if $self.big_endian {
            <$t>::from_be_bytes(bytes)
        } else {
            <$t>::from_le_bytes(bytes)
        }
    }};
}

impl<'a> Reader<'a> for BinaryReader<'a> {
    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    fn is_ascii(&self) -> bool {
        false
    }

    fn start_row(&mut self, element: &'a str, index: u64, _count: u64) -> Result<(), MeshFileError> {
        self.element = element;
        self.index = index;
        Ok(())
    }

    fn scalar(&mut self, ty: Scalar) -> Result<Num, MeshFileError> {
        Ok(match ty {
            Scalar::I8 => Num::Int(read_as!(self, i8).into()),
            Scalar::U8 => Num::Int(read_as!(self, u8).into()),
            Scalar::I16 => Num::Int(read_as!(self, i16).into()),
            Scalar::U16 => Num::Int(read_as!(self, u16).into()),
            Scalar::I32 => Num::Int(read_as!(self, i32).into()),
            Scalar::U32 => Num::Int(read_as!(self, u32).into()),
            Scalar::F32 => Num::Float(read_as!(self, f32).into()),
            Scalar::F64 => Num::Float(read_as!(self, f64)),
        })
    }

    fn skip_scalar(&mut self, ty: Scalar) -> Result<(), MeshFileError> {
        self.advance(ty.size() as u64)
    }

    fn list_len(&mut self, ty: Scalar) -> Result<u64, MeshFileError> {
        match self.scalar(ty)? {
            Num::Int(n) => u64::try_from(n).map_err(|_| self.error(format!("negative list length {n}"))),
            // Count types are checked to be integers in the header.
            Num::Float(f) => Err(self.error(format!("invalid list length {f}"))),
        }
    }

    fn skip_items(&mut self, n: u64, ty: Scalar) -> Result<(), MeshFileError> {
        let bytes = n.checked_mul(ty.size() as u64).ok_or_else(|| self.truncated())?;
        self.advance(bytes)
    }

    fn end_row(&mut self) -> Result<(), MeshFileError> {
        Ok(())
    }

    fn skip_fixed_rows(&mut self, element: &'a str, count: u64, stride: usize) -> Result<bool, MeshFileError> {
        let stride = stride as u64;
        let total = count.checked_mul(stride);
        match total.and_then(|t| usize::try_from(t).ok()) {
            Some(t) if t <= self.remaining() => {
                self.pos += t;
                Ok(true)
            }
            _ => {
                // Name the first instance that does not fit.
                self.element = element;
                self.index = (self.remaining() as u64).checked_div(stride).unwrap_or(0);
                Err(self.truncated())
            }
        }
    }

    fn error(&self, message: String) -> MeshFileError {
        MeshFileError::parse(
            self.name,
            Location::Element { element: self.element.to_owned(), index: self.index },
            message,
        )
    }
}

use super::*;

const MAX: u64 = 1_000_000;

fn obj(text: &str) -> Result<MeshData, MeshFileError> {
    parse_obj(text, "t.obj", MAX)
}

fn obj_err(text: &str) -> String {
    match obj(text) {
        Ok(mesh) => panic!("expected an error, got {mesh:?}"),
        Err(e) => e.to_string(),
    }
}

const CUBE: &str = "\
# a unit cube made of quads
mtllib cube.mtl
o Cube
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1

g sides
usemtl grey
s off
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
l 1 2
p 3
vp 0.5 0.5
";

#[test]
fn obj_cube_with_quads() {
    let mesh = obj(CUBE).unwrap();
    assert_eq!(mesh.indices.len(), 12);
    assert_eq!(mesh.positions.len(), 8);
    assert!(mesh.normals.is_none());
    assert!(mesh.uvs.is_none());
    assert!(mesh.indices.iter().flatten().all(|&i| (i as usize) < 8));
    // Fan triangulation of the first quad (1 4 3 2): (1 4 3) and (1 3 2).
    let p = |i: u32| mesh.positions[i as usize];
    let first: Vec<_> = mesh.indices[0].iter().map(|&i| p(i)).collect();
    assert_eq!(first, vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]);
    let second: Vec<_> = mesh.indices[1].iter().map(|&i| p(i)).collect();
    assert_eq!(second, vec![[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]]);
}

#[test]
fn obj_crlf_comments_and_extra_columns() {
    let text = "v 0 0 0 1 0.5 0.5 0.5\r\nv 1 0 0 # trailing comment\r\n\r\n  v 0 1 0\r\nf 1 2 3#c\r\n";
    let mesh = obj(text).unwrap();
    assert_eq!(mesh.positions, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    assert_eq!(mesh.indices, vec![[0, 1, 2]]);
}

#[test]
fn obj_negative_indices_match_positive() {
    let positive = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\nv 5 5 5\nf 1/1/1 3/3/1 5/3/1\n";
    let negative = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\nf -4/-3/-1 -3/-2/-1 -2/-1/-1\nv 5 5 5\nf -5/-3/-1 -3/-1/-1 -1/-1/-1\n";
    let a = obj(positive).unwrap();
    let b = obj(negative).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.indices.len(), 2);
    // vertex 4 is never used: only referenced vertices are emitted.
    assert_eq!(a.positions.len(), 4);
    assert_eq!(a.uvs.as_ref().unwrap().len(), 4);
    assert_eq!(a.normals.as_ref().unwrap().len(), 4);
}

#[test]
fn obj_reindexes_position_normal_pairs() {
    // Two triangles share positions 1 and 3 but have different normals: those positions become
    // two vertices each; corners with identical (v, vt, vn) are shared.
    let text = "\
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vn 0 0 1
vn 0 0 -1
f 1/1/1 2/1/1 3/1/1
f 1/1/2 3/1/2 4/1/2
f 3/1/1 2/1/1 1/1/1
";
    let mesh = obj(text).unwrap();
    assert_eq!(mesh.positions.len(), 6);
    let normals = mesh.normals.as_ref().unwrap();
    assert_eq!(normals.len(), 6);
    assert_eq!(mesh.uvs.as_ref().unwrap(), &vec![[0.0, 0.0]; 6]);
    assert_eq!(mesh.indices, vec![[0, 1, 2], [3, 4, 5], [2, 1, 0]]);
    assert_eq!(mesh.positions[0], mesh.positions[3]);
    assert_eq!(normals[0], [0.0, 0.0, 1.0]);
    assert_eq!(normals[3], [0.0, 0.0, -1.0]);
    for (i, [a, b, c]) in mesh.indices.iter().map(|t| t.map(|i| i as usize)).enumerate() {
        let n = if i == 1 { -1.0 } else { 1.0 };
        assert!([a, b, c].iter().all(|&v| normals[v] == [0.0, 0.0, n]));
    }
}

#[test]
fn obj_forms_and_partial_attributes() {
    // i, i/j, i//k and i/j/k forms; attributes some faces lack are dropped, not invented.
    let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\n";
    let all_uv = obj(&format!("{base}f 1/1 2/2 3/3\n")).unwrap();
    assert_eq!(all_uv.uvs, Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]));
    assert_eq!(all_uv.normals, None);
    let all_n = obj(&format!("{base}f 1//1 2//1 3//1\n")).unwrap();
    assert_eq!(all_n.normals, Some(vec![[0.0, 0.0, 1.0]; 3]));
    assert_eq!(all_n.uvs, None);
    let mixed = obj(&format!("{base}f 1/1/1 2/2/1 3/3/1\nf 1 2 3\nf 3//1 2//1 1//1\n")).unwrap();
    assert_eq!(mixed.normals, None);
    assert_eq!(mixed.uvs, None);
    // With attributes dropped, corners that differed only in them share a vertex again.
    assert_eq!(mixed.positions.len(), 3);
    assert_eq!(mixed.indices.len(), 3);
    // vt with one coordinate: v defaults to 0; vt with three: w ignored.
    let short_vt = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5\nvt 1 1 1\nf 1/1 2/2 3/1\n").unwrap();
    assert_eq!(short_vt.uvs, Some(vec![[0.5, 0.0], [1.0, 1.0], [0.5, 0.0]]));
    // Degenerate triangles are kept.
    let degenerate = obj("v 0 0 0\nv 1 0 0\nf 1 1 2\n").unwrap();
    assert_eq!(degenerate.indices, vec![[0, 0, 1]]);
}

#[test]
fn obj_errors_name_the_line() {
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases: &[(String, &str)] = &[
        (format!("{tri}# comment\n\nf 1 2 40\n"), "t.obj:6: face index 40 out of range (3 vertices)"),
        (format!("{tri}f 1 2 -4\n"), "t.obj:4: face index -4 out of range (3 vertices)"),
        (format!("{tri}f 1 2 0\n"), "t.obj:4: face index 0 is invalid (OBJ indices start at 1)"),
        (format!("{tri}f 1/1 2/1 3/1\n"), "t.obj:4: texture coordinate index 1 out of range (0 texture coordinates)"),
        (format!("{tri}vn 0 0 1\nf 1//1 2//2 3//1\n"), "t.obj:5: normal index 2 out of range (1 normal)"),
        (format!("{tri}f 1 2\n"), "t.obj:4: face has 2 vertices (at least 3 needed)"),
        (format!("{tri}f\n"), "t.obj:4: face has 0 vertices (at least 3 needed)"),
        (format!("{tri}f 1 2 3/1/1/1\n"), "t.obj:4: invalid face vertex \"3/1/1/1\""),
        (format!("{tri}f 1 2 /1\n"), "t.obj:4: face vertex \"/1\" has no position index"),
        (format!("{tri}f 1 2 x\n"), "t.obj:4: invalid face index \"x\""),
        (format!("{tri}f 1 2 3/y\n"), "t.obj:4: invalid texture coordinate index \"y\""),
        ("v 0 0\n".into(), "t.obj:1: v needs 3 coordinates, found 2"),
        ("v 0 0 0\nvn 0 1\n".into(), "t.obj:2: vn needs 3 coordinates, found 2"),
        ("vt\n".into(), "t.obj:1: vt needs at least 1 coordinate, found 0"),
        ("v 0 0 0\nv 1 abc 0\n".into(), "t.obj:2: invalid number \"abc\" in v statement"),
        ("v 0 0 0\nv 1 nan 0\n".into(), "t.obj:2: non-finite number \"nan\" in v statement"),
        ("v 0 0 0\nv 1 0 -inf\n".into(), "t.obj:2: non-finite number \"-inf\" in v statement"),
        // Overflows f32.
        ("\n\nv 1e39 0 0\n".into(), "t.obj:3: non-finite number \"1e39\" in v statement"),
        ("vt 0 inf\n".into(), "t.obj:1: non-finite number \"inf\" in vt statement"),
        ("vn NaN 0 1\n".into(), "t.obj:1: non-finite number \"NaN\" in vn statement"),
        (format!("{tri}o only-points\np 1\n"), "t.obj: mesh has no triangles"),
        (String::new(), "t.obj: mesh has no triangles"),
    ];
    for (text, expected) in cases {
        assert_eq!(&obj_err(text), expected, "for {text:?}");
    }
    let err = obj(&format!("{tri}\nf 1 2 9\n")).unwrap_err();
    assert_eq!(err.line(), Some(5));
}

#[test]
fn obj_triangle_limit() {
    // 12 triangles: fine at 12, rejected at 11 (on the face that crosses the limit).
    assert_eq!(parse_obj(CUBE, "c.obj", 12).unwrap().indices.len(), 12);
    let err = parse_obj(CUBE, "c.obj", 11).unwrap_err();
    assert!(matches!(err, MeshFileError::TooManyTriangles { limit: 11, .. }));
    assert_eq!(err.to_string(), "c.obj: mesh has more than 11 triangles (the triangle limit)");
    assert!(matches!(parse_obj(CUBE, "c.obj", 0), Err(MeshFileError::TooManyTriangles { .. })));
    // A single huge polygon is rejected before its corners are parsed.
    let mut big = String::from("v 0 0 0\nf");
    for _ in 0..10_000 {
        big.push_str(" 1");
    }
    assert!(matches!(parse_obj(&big, "big.obj", 100), Err(MeshFileError::TooManyTriangles { .. })));
}

// ---------------------------------------------------------------------------------------------
// PLY

/// A typed value of a PLY row, written as ascii text or binary bytes.
#[derive(Clone, Copy)]
enum V {
    I8(i8),
    U8(u8),
    I16(i16),
    U16(u16),
    I32(i32),
    U32(u32),
    F32(f32),
    F64(f64),
}

impl V {
    fn ascii(self) -> String {
        match self {
            V::I8(v) => v.to_string(),
            V::U8(v) => v.to_string(),
            V::I16(v) => v.to_string(),
            V::U16(v) => v.to_string(),
            V::I32(v) => v.to_string(),
            V::U32(v) => v.to_string(),
            V::F32(v) => v.to_string(),
            V::F64(v) => v.to_string(),
        }
    }

    fn bytes(self, big: bool) -> Vec<u8> {
        macro_rules! b {
            ($v:expr) => {
                if big {
                    $v.to_be_bytes().to_vec()
                } else {
                    $v.to_le_bytes().to_vec()
                }
            };
        }
        match self {
            V::I8(v) => b!(v),
            V::U8(v) => b!(v),
            V::I16(v) => b!(v),
            V::U16(v) => b!(v),
            V::I32(v) => b!(v),
            V::U32(v) => b!(v),
            V::F32(v) => b!(v),
            V::F64(v) => b!(v),
        }
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Fmt {
    Ascii,
    Le,
    Be,
}

/// Builds a PLY file: `elements` is the header text between the format line and end_header,
/// `rows` the body, one row per element instance.
fn build_ply(format: Fmt, elements: &str, rows: &[Vec<V>]) -> Vec<u8> {
    let name = match format {
        Fmt::Ascii => "ascii",
        Fmt::Le => "binary_little_endian",
        Fmt::Be => "binary_big_endian",
    };
    let mut out = format!("ply\nformat {name} 1.0\ncomment made by a test\n{elements}end_header\n").into_bytes();
    for row in rows {
        match format {
            Fmt::Ascii => {
                let text: Vec<String> = row.iter().map(|v| v.ascii()).collect();
                out.extend_from_slice(text.join(" ").as_bytes());
                out.push(b'\n');
            }
            Fmt::Le | Fmt::Be => {
                for v in row {
                    out.extend(v.bytes(format == Fmt::Be));
                }
            }
        }
    }
    out
}

/// A tetrahedron with normals, uvs, unknown properties of every type, unknown elements with
/// list properties before, between and after the known ones, and a face element with extra
/// properties.
const TETRA_HEADER: &str = "\
obj_info generated for tests
element material 2
property uchar r
property list uint8 int32 tags
property float64 shininess
element vertex 4
property float32 x
property float32 y
property float32 z
property int16 pad16
property float nx
property float ny
property float nz
property list ushort char junk
property double s
property double t
property uint32 id
element edge 2
property list int int vertex_pair
property list uchar float weights
element face 4
property uchar flags
property list uchar uint vertex_indices
property list int8 uint16 other
property short tail
element trailer 3
property int8 a
property uint16 b
";

fn tetra_rows() -> Vec<Vec<V>> {
    let mut rows =
        vec![vec![V::U8(1), V::U8(2), V::I32(-5), V::I32(7), V::F64(0.5)], vec![V::U8(3), V::U8(0), V::F64(2.0)]];
    let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.5]];
    for (i, p) in positions.iter().enumerate() {
        let f = i as f32;
        rows.push(vec![
            V::F32(p[0]),
            V::F32(p[1]),
            V::F32(p[2]),
            V::I16(-3),
            V::F32(0.25 * f),
            V::F32(-0.5),
            V::F32(1.0),
            V::U16(2),
            V::I8(-1),
            V::I8(100),
            V::F64(0.125 * f64::from(f)),
            V::F64(1.0 - 0.125 * f64::from(f)),
            V::U32(4_000_000_000),
        ]);
    }
    rows.push(vec![V::I32(2), V::I32(0), V::I32(1), V::U8(1), V::F32(0.5)]);
    rows.push(vec![V::I32(0), V::U8(0)]);
    for (i, face) in [[0u32, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]].iter().enumerate() {
        let mut row = vec![V::U8(i as u8), V::U8(3)];
        row.extend(face.iter().map(|&v| V::U32(v)));
        row.extend([V::I8(2), V::U16(9), V::U16(65535), V::I16(-7)]);
        rows.push(row);
    }
    for _ in 0..3 {
        rows.push(vec![V::I8(-128), V::U16(1)]);
    }
    rows
}

fn tetra(format: Fmt) -> Vec<u8> {
    build_ply(format, TETRA_HEADER, &tetra_rows())
}

fn ply(bytes: &[u8]) -> Result<MeshData, MeshFileError> {
    parse_ply(bytes, "t.ply", MAX)
}

fn ply_err(bytes: &[u8]) -> String {
    match ply(bytes) {
        Ok(mesh) => panic!("expected an error, got {mesh:?}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn ply_ascii_and_binary_tetrahedra_agree() {
    let ascii = ply(&tetra(Fmt::Ascii)).unwrap();
    let le = ply(&tetra(Fmt::Le)).unwrap();
    let be = ply(&tetra(Fmt::Be)).unwrap();
    assert_eq!(ascii, le);
    assert_eq!(ascii, be);
    assert_eq!(ascii.positions, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.5]]);
    assert_eq!(ascii.indices, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]);
    assert_eq!(ascii.normals, Some(vec![[0.0, -0.5, 1.0], [0.25, -0.5, 1.0], [0.5, -0.5, 1.0], [0.75, -0.5, 1.0]]));
    assert_eq!(ascii.uvs, Some(vec![[0.0, 1.0], [0.125, 0.875], [0.25, 0.75], [0.375, 0.625]]));
}

#[test]
fn ply_minimal_with_quads_crlf_and_alternative_names() {
    let text = "ply\r\nformat ascii 1.0\r\nelement vertex 4\r\nproperty double z\r\nproperty double y\r\nproperty double x\r\nproperty float u\r\nproperty float v\r\nelement face 1\r\nproperty list uchar int vertex_index\r\nend_header\r\n0 0 0 0 0\r\n\r\n0 0 1 1 0\r\n0 1 1 1 1\r\n0 1 0 0 1\r\n4 0 1 2 3\r\n";
    let mesh = ply(text.as_bytes()).unwrap();
    assert_eq!(mesh.indices, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(mesh.positions[1], [1.0, 0.0, 0.0]);
    assert_eq!(mesh.normals, None);
    assert_eq!(mesh.uvs.as_ref().map(Vec::len), Some(4));
    // Integer coordinates, the face element before the vertex element.
    let text = "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar uint vertex_indices\nelement vertex 3\nproperty int x\nproperty int y\nproperty int z\nproperty float s\nproperty float t\nend_header\n3 2 1 0\n0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n";
    let mesh = ply(text.as_bytes()).unwrap();
    assert_eq!(mesh.indices, vec![[2, 1, 0]]);
    assert_eq!(mesh.positions[2], [0.0, 1.0, 0.0]);
    assert_eq!(mesh.uvs, Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]));
}

const TRI_HEADER: &str = "\
element vertex 3
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
";

fn tri_rows(face: Vec<V>) -> Vec<Vec<V>> {
    vec![
        vec![V::F32(0.0), V::F32(0.0), V::F32(0.0)],
        vec![V::F32(1.0), V::F32(0.0), V::F32(0.0)],
        vec![V::F32(0.0), V::F32(1.0), V::F32(0.0)],
        face,
    ]
}

fn tri_face(indices: &[i32]) -> Vec<V> {
    let mut row = vec![V::U8(indices.len() as u8)];
    row.extend(indices.iter().map(|&i| V::I32(i)));
    row
}

#[test]
fn ply_body_errors() {
    // Ascii body errors name the line (header: 10 lines, body starts at line 11).
    let a = |rows: Vec<Vec<V>>| build_ply(Fmt::Ascii, TRI_HEADER, &rows);
    let b = |rows: Vec<Vec<V>>| build_ply(Fmt::Le, TRI_HEADER, &rows);
    assert_eq!(ply_err(&a(tri_rows(tri_face(&[0, 1, 3])))), "t.ply:14: vertex index 3 out of range (3 vertices)");
    assert_eq!(ply_err(&a(tri_rows(tri_face(&[0, -1, 2])))), "t.ply:14: vertex index -1 out of range (3 vertices)");
    assert_eq!(ply_err(&a(tri_rows(tri_face(&[0, 1])))), "t.ply:14: face has 2 vertices (at least 3 needed)");
    assert_eq!(ply_err(&b(tri_rows(tri_face(&[0, 1, 3])))), "t.ply: face #0: vertex index 3 out of range (3 vertices)");
    assert_eq!(ply_err(&b(tri_rows(tri_face(&[2])))), "t.ply: face #0: face has 1 vertex (at least 3 needed)");
    let mut nan_rows = tri_rows(tri_face(&[0, 1, 2]));
    nan_rows[1][1] = V::F32(f32::NAN);
    assert_eq!(ply_err(&a(nan_rows.clone())), "t.ply:12: non-finite y coordinate (y NaN)");
    assert_eq!(ply_err(&b(nan_rows)), "t.ply: vertex #1: non-finite y coordinate (y NaN)");
    let mut inf_rows = tri_rows(tri_face(&[0, 1, 2]));
    inf_rows[2][2] = V::F32(f32::INFINITY);
    assert_eq!(ply_err(&b(inf_rows)), "t.ply: vertex #2: non-finite z coordinate (z inf)");
    // Doubles beyond the f32 range are non-finite too.
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1e300 0 0\n0 1 0\n3 0 1 2\n";
    assert_eq!(ply_err(text.as_bytes()), "t.ply:11: non-finite x coordinate (x inf)");

    let good = a(tri_rows(tri_face(&[0, 1, 2])));
    let good_text = String::from_utf8(good).unwrap();
    let edit = |from: &str, to: &str| ply_err(good_text.replacen(from, to, 1).as_bytes());
    assert_eq!(edit("\n1 0 0\n", "\n1 0\n"), "t.ply:12: too few values on the line");
    assert_eq!(
        edit("\n1 0 0\n", "\n1 0 0 7\n"),
        "t.ply:12: unexpected extra value \"7\" at the end of the line (the header declares fewer properties)"
    );
    assert_eq!(edit("\n1 0 0\n", "\n1 zero 0\n"), "t.ply:12: invalid float value \"zero\"");
    assert_eq!(edit("3 0 1 2\n", "300 0 1 2\n"), "t.ply:14: list length \"300\" out of range for type uchar");
    assert_eq!(edit("3 0 1 2\n", "3 0 1 2.5\n"), "t.ply:14: invalid value \"2.5\" (expected int)");
    assert_eq!(edit("3 0 1 2\n", ""), "t.ply:14: unexpected end of file: 1 face instances declared, found 0");
    // Integers written as floats are accepted.
    assert!(ply(good_text.replacen("3 0 1 2", "3.0 0 1.0 2", 1).as_bytes()).is_ok());
}

#[test]
fn ply_truncated_binary() {
    for fmt in [Fmt::Le, Fmt::Be] {
        let full = tetra(fmt);
        assert!(ply(&full).is_ok());
        // The trailer element is 3 bytes a row: cutting one byte truncates its last row.
        assert_eq!(
            ply_err(&full[..full.len() - 1]),
            "t.ply: trailer #2: unexpected end of data (the file is truncated)"
        );
        // Cut inside the last face (each face: 1 + 1 + 12 + 1 + 4 + 2 = 21 bytes).
        assert_eq!(
            ply_err(&full[..full.len() - 9 - 5]),
            "t.ply: face #3: unexpected end of data (the file is truncated)"
        );
        // Every prefix fails cleanly.
        let body_start = full.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        for len in 0..full.len() {
            let err = ply(&full[..len]).unwrap_err();
            if len >= body_start {
                assert!(err.to_string().contains("truncated"), "{len}: {err}");
            }
        }
    }
}

#[test]
fn ply_header_errors() {
    let header_err = |header: &str| ply_err(format!("{header}end_header\n").as_bytes());
    let cases: &[(&str, &str)] = &[
        ("plx\nformat ascii 1.0\n", "t.ply: header: line 1: not a PLY file (the first line must be \"ply\")"),
        ("ply\nformat ascii 2.0\n", "t.ply: header: line 2: unsupported PLY version \"2.0\""),
        ("ply\nformat text 1.0\n", "t.ply: header: line 2: unknown format \"text\""),
        ("ply\nformat ascii\n", "t.ply: header: line 2: expected \"format <ascii|binary_little_endian|binary_big_endian> 1.0\""),
        ("ply\nformat ascii 1.0\nformat ascii 1.0\n", "t.ply: header: line 3: duplicate format line"),
        ("ply\nelement vertex 3\n", "t.ply: header: line 3: end_header before the format line"),
        ("ply\nformat ascii 1.0\nproperty float x\n", "t.ply: header: line 3: property before any element"),
        ("ply\nformat ascii 1.0\nelement vertex -3\n", "t.ply: header: line 3: invalid element count \"-3\""),
        ("ply\nformat ascii 1.0\nelement vertex\n", "t.ply: header: line 3: expected \"element <name> <count>\""),
        ("ply\nformat ascii 1.0\nelement vertex 1\nelement vertex 1\n", "t.ply: header: line 4: duplicate element \"vertex\""),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\n", "t.ply: header: line 4: unknown property type \"float128\""),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\n", "t.ply: header: line 5: duplicate property \"x\" in element \"vertex\""),
        ("ply\nformat ascii 1.0\nelement face 1\nproperty list float int vertex_indices\n", "t.ply: header: line 4: list count type must be an integer type, not float"),
        ("ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int\n", "t.ply: header: line 4: expected \"property list <count type> <item type> <name>\""),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty x\n", "t.ply: header: line 4: expected \"property <type> <name>\""),
        ("ply\nformat ascii 1.0\nfoo bar\n", "t.ply: header: line 3: unknown header keyword \"foo\""),
        ("ply\nformat ascii 1.0\n", "t.ply: header: no vertex element"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\n", "t.ply: header: line 3: vertex element has no y property"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\n", "t.ply: header: line 3: vertex property x must be a scalar, not a list"),
        ("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n", "t.ply: mesh has no triangles"),
        ("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\n", "t.ply: mesh has no triangles"),
        ("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int indices\n", "t.ply: header: line 7: face element has no vertex_indices list"),
        ("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty int vertex_indices\n", "t.ply: header: line 7: face vertex_indices must be a list property"),
        ("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar float vertex_indices\n", "t.ply: header: line 7: face vertex_indices must be a list of integers, not float"),
        ("ply\nformat binary_little_endian 1.0\nelement vertex 5000000000\nproperty float x\nproperty float y\nproperty float z\n", "t.ply: header: line 3: 5000000000 vertices is more than 32-bit indices can address"),
    ];
    for (header, expected) in cases {
        assert_eq!(&header_err(header), expected, "for {header:?}");
    }
    assert_eq!(ply_err(b""), "t.ply: header: empty file (expected a PLY header)");
    assert_eq!(
        ply_err(b"ply\nformat ascii 1.0\nelement vertex 3\n"),
        "t.ply: header: missing end_header (the file ends inside the header)"
    );
    let err = ply(b"ply\nformat ascii 1.0\nbogus\nend_header\n").unwrap_err();
    assert_eq!(err.line(), Some(3));
}

#[test]
fn ply_list_and_count_errors() {
    // A negative list length in a signed count type.
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list char int vertex_indices\n";
    let mut rows = tri_rows(vec![]);
    rows[3] = vec![V::I8(-3), V::I32(0), V::I32(1), V::I32(2)];
    assert_eq!(ply_err(&build_ply(Fmt::Be, header, &rows)), "t.ply: face #0: negative list length -3");
    assert_eq!(ply_err(&build_ply(Fmt::Ascii, header, &rows)), "t.ply:14: negative list length -3");
    // A huge list in an unknown element: truncation, not a long loop or allocation.
    let header = "element blob 1\nproperty list uint uchar data\n".to_owned() + TRI_HEADER;
    let mut rows = vec![vec![V::U32(u32::MAX), V::U8(0)]];
    rows.extend(tri_rows(tri_face(&[0, 1, 2])));
    assert_eq!(
        ply_err(&build_ply(Fmt::Le, &header, &rows)),
        "t.ply: blob #0: unexpected end of data (the file is truncated)"
    );
    assert_eq!(ply_err(&build_ply(Fmt::Ascii, &header, &rows)), "t.ply:13: too few values on the line");
}

#[test]
fn ply_huge_header_counts_do_not_allocate() {
    // Claims of billions of instances with almost no data fail quickly, without reserving
    // memory for the claimed counts.
    let vertex = "element vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n";
    for fmt in [Fmt::Ascii, Fmt::Le, Fmt::Be] {
        let bytes = build_ply(fmt, vertex, &tri_rows(tri_face(&[0, 1, 2]))[..3]);
        let err = parse_ply(&bytes, "t.ply", u64::MAX).unwrap_err().to_string();
        assert!(err.contains("end of"), "{err}");
    }
    let face = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 4000000000\nproperty list uchar int vertex_indices\n";
    for fmt in [Fmt::Ascii, Fmt::Le] {
        let bytes = build_ply(fmt, face, &tri_rows(tri_face(&[0, 1, 2])));
        let err = parse_ply(&bytes, "t.ply", u64::MAX).unwrap_err().to_string();
        assert!(err.contains("face #1") || err.contains("t.ply:15"), "{err}");
    }
    // Unknown elements of fixed-size rows, or with no properties at all.
    let skipped = "element huge 18446744073709551615\nproperty double d\n".to_owned() + TRI_HEADER;
    let bytes = build_ply(Fmt::Le, &skipped, &tri_rows(tri_face(&[0, 1, 2])));
    assert_eq!(ply_err(&bytes), "t.ply: huge #6: unexpected end of data (the file is truncated)");
    let empty = "element nothing 18446744073709551615\n".to_owned() + TRI_HEADER;
    for fmt in [Fmt::Ascii, Fmt::Le] {
        let bytes = build_ply(fmt, &empty, &tri_rows(tri_face(&[0, 1, 2])));
        assert_eq!(ply(&bytes).unwrap().indices, vec![[0, 1, 2]]);
    }
}

#[test]
fn ply_triangle_limit() {
    // Rejected from the header's face count, before reading the body.
    let bytes = tetra(Fmt::Le);
    assert_eq!(parse_ply(&bytes, "t.ply", 4).unwrap().indices.len(), 4);
    let body_start = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let err = parse_ply(&bytes[..body_start], "t.ply", 3).unwrap_err();
    assert_eq!(err.to_string(), "t.ply: mesh has more than 3 triangles (the triangle limit)");
    // Polygons count by their triangles while reading.
    let mut rows = tri_rows(vec![]);
    rows.push(vec![V::F32(1.0), V::F32(1.0), V::F32(0.0)]);
    rows.swap(3, 4);
    rows[4] = tri_face(&[0, 1, 3, 2]);
    let header = TRI_HEADER.replace("vertex 3", "vertex 4");
    let quad = build_ply(Fmt::Ascii, &header, &rows);
    assert_eq!(parse_ply(&quad, "q.ply", 2).unwrap().indices, vec![[0, 1, 3], [0, 3, 2]]);
    assert!(matches!(parse_ply(&quad, "q.ply", 1), Err(MeshFileError::TooManyTriangles { limit: 1, .. })));
}

#[test]
fn load_mesh_dispatches_on_extension() {
    let dir = std::env::temp_dir().join(format!("wedge-meshfile-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj_path = dir.join("cube.OBJ");
    std::fs::write(&obj_path, CUBE).unwrap();
    assert_eq!(load_mesh(&obj_path, MAX).unwrap().indices.len(), 12);
    let ply_path = dir.join("tetra.Ply");
    std::fs::write(&ply_path, tetra(Fmt::Be)).unwrap();
    assert_eq!(load_mesh(&ply_path, MAX).unwrap(), ply(&tetra(Fmt::Ascii)).unwrap());
    // Latin-1 in an object name is not an error.
    let latin1_path = dir.join("latin1.obj");
    let mut latin1 = b"o W\xfcrfel\n".to_vec();
    latin1.extend_from_slice(CUBE.as_bytes());
    std::fs::write(&latin1_path, latin1).unwrap();
    assert_eq!(load_mesh(&latin1_path, MAX).unwrap().indices.len(), 12);
    // Errors name the file.
    let err = load_mesh(&dir.join("cube.obj"), MAX).unwrap_err();
    assert!(matches!(err, MeshFileError::Io { .. }));
    assert!(err.to_string().starts_with(&format!("{}: ", dir.join("cube.obj").display())));
    let err = load_mesh(&obj_path, 5).unwrap_err();
    assert_eq!(err.to_string(), format!("{}: mesh has more than 5 triangles (the triangle limit)", obj_path.display()));
    for unsupported in ["mesh.stl", "mesh", "obj", "mesh.obj.gz"] {
        let err = load_mesh(Path::new(unsupported), MAX).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!("{unsupported}: unsupported mesh file type (expected a .obj or .ply extension)")
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Random byte mutations of valid files: the parsers must return, never panic or hang.
#[test]
fn random_mutations_never_panic() {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let seeds: Vec<(bool, Vec<u8>)> = vec![
        (false, tetra(Fmt::Ascii)),
        (false, tetra(Fmt::Le)),
        (false, tetra(Fmt::Be)),
        (true, CUBE.as_bytes().to_vec()),
        (
            true,
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/2/1\nf -3//-1 -2//-1 -1//-1\n"
                .to_vec(),
        ),
    ];
    // Bytes likely to matter: digits, separators, signs, keywords' letters, newlines, 0xff.
    const INTERESTING: &[u8] = b"0123456789 /-+.#\n\r\tevfnltx\x00\xff";
    let mut ok = 0usize;
    for iteration in 0..5000usize {
        let (is_obj, seed) = &seeds[iteration % seeds.len()];
        let mut data = seed.clone();
        let mutations = 1 + next() % 4;
        for _ in 0..mutations {
            let r = next();
            let at = if data.is_empty() { 0 } else { (r >> 8) as usize % data.len() };
            let byte =
                if r & 0x10 == 0 { INTERESTING[(r >> 40) as usize % INTERESTING.len()] } else { (r >> 32) as u8 };
            match r % 5 {
                0 if !data.is_empty() => data[at] = byte,
                1 => data.insert(at, byte),
                2 if !data.is_empty() => {
                    data.remove(at);
                }
                3 => data.truncate(at),
                _ if !data.is_empty() => data[at] ^= 1 << ((r >> 20) % 8),
                _ => {}
            }
        }
        let limit = if next() % 2 == 0 { u64::MAX } else { 64 };
        let result = if *is_obj {
            parse_obj(&String::from_utf8_lossy(&data), "f.obj", limit)
        } else {
            parse_ply(&data, "f.ply", limit)
        };
        match result {
            Ok(mesh) => {
                ok += 1;
                // Whatever parses is consistent.
                let n = mesh.positions.len();
                assert!(mesh.indices.iter().flatten().all(|&i| (i as usize) < n));
                assert!(mesh.normals.as_ref().is_none_or(|v| v.len() == n));
                assert!(mesh.uvs.as_ref().is_none_or(|v| v.len() == n));
                assert!(!mesh.indices.is_empty());
                assert!(mesh.positions.iter().flatten().all(|c| c.is_finite()));
            }
            Err(e) => {
                let message = e.to_string();
                assert!(message.starts_with("f.obj") || message.starts_with("f.ply"));
            }
        }
    }
    // The mutations are mild enough that some files still parse.
    assert!(ok > 100, "{ok}");
}

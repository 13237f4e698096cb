//! Structured fuzzing, for a fixed time per target (WEDGE_FUZZ_SECONDS, default 3; CI gives
//! more): request decoding, scene JSON, OBJ and PLY. Inputs are mutations of valid ones (bytes
//! flipped, inserted, deleted, truncated) or generated line by line, so that most get past the
//! first check. Whatever the input: no panic, no hang, and what is accepted renders to finite
//! pixels or parses to in-range indices. Each batch has a fixed seed (reproducible runs), and a
//! failing case is shrunk and saved to tests/proptest-regressions/fuzz.txt, replayed first on
//! every run from then on: each crash becomes a regression test.
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use prost::Message;
use std::time::{Duration, Instant};
use wedge::api::request::{prepare, Limits};
use wedge::pipeline::job::{CancelToken, Halt};
use wedge::proto::{render_request::SceneSource, RenderRequest, RenderSettings};

fn budget() -> Duration {
    let secs = std::env::var("WEDGE_FUZZ_SECONDS").ok().and_then(|s| s.parse::<f64>().ok()).unwrap_or(3.0);
    Duration::from_secs_f64(secs.clamp(0.1, 3600.0))
}

/// Runs `test` on values of `strategy` in batches of fixed-seed cases until the time budget is
/// spent; returns the number of cases run.
fn fuzz<S: Strategy>(name: &str, strategy: S, test: impl Fn(S::Value) -> Result<(), TestCaseError>) -> u64
where
    S::Value: std::fmt::Debug,
{
    let deadline = Instant::now() + budget();
    let mut cases = 0u64;
    let mut batch = 0u64;
    while Instant::now() < deadline {
        let config = Config {
            cases: 32,
            failure_persistence: Some(Box::new(FileFailurePersistence::Direct("tests/proptest-regressions/fuzz.txt"))),
            ..Config::default()
        };
        let mut seed = [0u8; 32];
        seed[..8].copy_from_slice(&batch.to_le_bytes());
        seed[8..8 + name.len().min(24)].copy_from_slice(&name.as_bytes()[..name.len().min(24)]);
        let mut runner = TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &seed));
        if let Err(e) = runner.run(&strategy, &test) {
            panic!("{name}: {e}");
        }
        cases += 32;
        batch += 1;
    }
    println!(
        "{name}: {cases} cases ({} requests rendered so far in this run)",
        RENDERED.load(std::sync::atomic::Ordering::Relaxed)
    );
    cases
}

/// An edit of a byte string: (position, operation, byte).
fn mutations() -> impl Strategy<Value = Vec<(usize, u8, u8)>> {
    prop::collection::vec((any::<usize>(), 0u8..5, any::<u8>()), 1..5)
}

/// Applies `edits` to `base`: replace, insert, delete, truncate, or set a byte to an extreme.
fn mutate(base: &[u8], edits: &[(usize, u8, u8)]) -> Vec<u8> {
    let mut b = base.to_vec();
    for &(at, op, byte) in edits {
        if b.is_empty() {
            b.push(byte);
            continue;
        }
        let i = at % b.len();
        match op {
            0 => b[i] = byte,
            1 => b.insert(i, byte),
            2 => {
                b.remove(i);
            }
            3 => b.truncate(i),
            _ => b[i] = if byte & 1 == 0 { 0 } else { 0xff },
        }
    }
    b
}

/// Small limits, so that whatever gets through renders in milliseconds.
fn limits() -> Limits {
    Limits {
        max_pixels: 32 * 32,
        max_triangles: 20_000,
        max_passes: 2,
        max_mean_spp: 4.0,
        max_time_budget_seconds: 1.0,
        mesh_root: None,
        max_environment_texels: 64 * 32,
    }
}

/// Requests that got through `prepare` and rendered (to see that mutations reach the tracer).
static RENDERED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Prepares `req`; if accepted, renders one pass and checks every pixel is finite.
fn accept_or_refuse(req: &RenderRequest) -> Result<(), TestCaseError> {
    let Ok(mut prepared) = prepare(req, &limits(), None, "fuzz") else { return Ok(()) };
    RENDERED.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    prepared.job.halt = Halt::passes(1);
    let mut finite = true;
    let _ = wedge::pipeline::progressive::render(&prepared.job, &CancelToken::new(), &mut |f| {
        finite &= f.color.iter().flatten().all(|v| v.is_finite());
        true
    });
    prop_assert!(finite, "an accepted request rendered a non-finite pixel");
    Ok(())
}

fn cornell_request() -> RenderRequest {
    RenderRequest {
        scene_source: Some(SceneSource::Scene(wedge::scene::builtin::get("cornell").unwrap())),
        width: 16,
        height: 12,
        settings: Some(RenderSettings { max_passes: 1, ..Default::default() }),
        ..Default::default()
    }
}

#[test]
fn fuzz_request_decoding() {
    let base = cornell_request().encode_to_vec();
    let n = fuzz("request", mutations(), |edits| {
        let bytes = mutate(&base, &edits);
        match RenderRequest::decode(bytes.as_slice()) {
            Ok(req) => accept_or_refuse(&req),
            Err(_) => Ok(()),
        }
    });
    assert!(n > 0);
}

#[test]
fn fuzz_scene_json() {
    let bases = [include_str!("../scenes/cornell.json"), include_str!("../scenes/curved.json")];
    let n = fuzz("scene-json", (0..bases.len(), mutations()), |(which, edits)| {
        let bytes = mutate(bases[which].as_bytes(), &edits);
        let Ok(text) = String::from_utf8(bytes) else { return Ok(()) };
        let Ok(scene) = wedge::scene::json::parse_scene(&text, "fuzz.json") else { return Ok(()) };
        let mut req = cornell_request();
        req.scene_source = Some(SceneSource::Scene(scene));
        accept_or_refuse(&req)
    });
    assert!(n > 0);
}

/// A number as a mesh file may hold it: ordinary, huge, tiny, negative, not finite, or junk.
fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => (-10.0f32..10.0).prop_map(|v| v.to_string()),
        1 => Just("1e39".to_string()),
        1 => Just("-0".to_string()),
        1 => Just("nan".to_string()),
        1 => Just("inf".to_string()),
        1 => Just("".to_string()),
        1 => "[a-z/#.-]{1,4}",
    ]
}

fn index() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => (1i64..12).prop_map(|v| v.to_string()),
        2 => (-12i64..0).prop_map(|v| v.to_string()),
        1 => Just("0".to_string()),
        1 => Just("4294967296".to_string()),
        1 => (1i64..12, 0i64..12, 0i64..12).prop_map(|(a, b, c)| format!("{a}/{b}/{c}")),
        1 => (1i64..12).prop_map(|a| format!("{a}//{a}")),
    ]
}

fn obj_line() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => prop::collection::vec(number(), 0..5).prop_map(|v| format!("v {}", v.join(" "))),
        1 => prop::collection::vec(number(), 0..4).prop_map(|v| format!("vn {}", v.join(" "))),
        1 => prop::collection::vec(number(), 0..3).prop_map(|v| format!("vt {}", v.join(" "))),
        4 => prop::collection::vec(index(), 0..6).prop_map(|v| format!("f {}", v.join(" "))),
        1 => "[ -~]{0,20}",
    ]
}

/// What a parsed mesh must satisfy: indices in range, attributes one per vertex.
fn check_mesh(mesh: &wedge::scene::meshfile::MeshData) -> Result<(), TestCaseError> {
    let n = mesh.positions.len();
    prop_assert!(mesh.indices.iter().flatten().all(|&i| (i as usize) < n), "an index out of range");
    prop_assert!(mesh.normals.as_ref().is_none_or(|v| v.len() == n));
    prop_assert!(mesh.uvs.as_ref().is_none_or(|v| v.len() == n));
    Ok(())
}

#[test]
fn fuzz_obj() {
    let n = fuzz("obj", prop::collection::vec(obj_line(), 0..40), |lines| {
        match wedge::scene::meshfile::parse_obj(&lines.join("\n"), "fuzz.obj", 1000) {
            Ok(mesh) => check_mesh(&mesh),
            Err(_) => Ok(()),
        }
    });
    assert!(n > 0);
}

/// A quad as ASCII and as binary little-endian PLY, with normals.
fn ply_bases() -> [Vec<u8>; 2] {
    let header = |format: &str| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
             property float nx\nproperty float ny\nproperty float nz\nelement face 2\n\
             property list uchar int vertex_indices\nend_header\n"
        )
    };
    let verts = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let mut ascii = header("ascii");
    for v in verts {
        ascii += &format!("{} {} {} 0 0 1\n", v[0], v[1], v[2]);
    }
    ascii += "3 0 1 2\n3 0 2 3\n";
    let mut binary = header("binary_little_endian").into_bytes();
    for v in verts {
        for x in v.into_iter().chain([0.0, 0.0, 1.0]) {
            binary.extend_from_slice(&x.to_le_bytes());
        }
    }
    for face in [[0i32, 1, 2], [0, 2, 3]] {
        binary.push(3);
        for i in face {
            binary.extend_from_slice(&i.to_le_bytes());
        }
    }
    [ascii.into_bytes(), binary]
}

#[test]
fn fuzz_ply() {
    let bases = ply_bases();
    for base in &bases {
        let mesh = wedge::scene::meshfile::parse_ply(base, "base.ply", 1000).expect("the unmutated PLY parses");
        assert_eq!((mesh.positions.len(), mesh.indices.len()), (4, 2));
    }
    let n = fuzz("ply", (0..2usize, mutations()), |(which, edits)| {
        match wedge::scene::meshfile::parse_ply(&mutate(&bases[which], &edits), "fuzz.ply", 1000) {
            Ok(mesh) => check_mesh(&mesh),
            Err(_) => Ok(()),
        }
    });
    assert!(n > 0);
}

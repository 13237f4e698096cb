//! Limits answer as gRPC prescribes: a request over `max_request_bytes` gets RESOURCE_EXHAUSTED
//! naming the limit, and a render's slot is taken before its request is read, so a busy server
//! refuses a huge request without decoding it.
mod common;

use common::*;
use prost::Message;
use std::time::Duration;
use tonic::Code;
use wedge::proto::{render_request::SceneSource, shape, Mesh, RenderRequest, Shape};
use wedge::server::ServerConfig;

/// The built-in Cornell box with an extra inline mesh of `triangles` triangles (a strip).
fn cornell_with_mesh(triangles: u32) -> RenderRequest {
    let mut scene = wedge::scene::builtin::get("cornell").expect("cornell");
    let material = scene.shapes[0].material.clone();
    let columns = triangles / 2 + 1;
    let mut positions = Vec::new();
    for i in 0..columns {
        let x = -0.5 + i as f32 / columns as f32;
        positions.extend_from_slice(&[x, 0.01, 0.0, x, 0.01, 0.2]);
    }
    let mut indices = Vec::new();
    for i in 0..columns - 1 {
        let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        indices.extend_from_slice(&[a, b, c, c, b, d]);
    }
    scene.shapes.push(Shape {
        material,
        geometry: Some(shape::Geometry::Mesh(Mesh { positions, indices, ..Default::default() })),
        ..Default::default()
    });
    let mut req = cornell(8, 6, 1, 1);
    req.scene_source = Some(SceneSource::Scene(scene));
    req
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_request_over_the_size_limit_is_resource_exhausted() {
    let limit = 64 << 10;
    let server = TestServer::with_config(ServerConfig { max_request_bytes: limit, ..Default::default() }).await;
    let small = cornell_with_mesh(200);
    assert!(small.encoded_len() < limit);
    let ok = collect(&mut server.client().await, small).await.expect("a request under the limit renders");
    assert!(ok.frames.last().unwrap().stats.is_final);

    let big = cornell_with_mesh(20_000);
    let size = big.encoded_len();
    assert!(size > limit);
    let err = server.client().await.render(big).await.expect_err("over the limit");
    assert_eq!(err.code(), Code::ResourceExhausted, "{err:?}");
    let text = err.message();
    assert!(text.contains(&size.to_string()) && text.contains("max_request_bytes"), "{text}");
    assert_eq!(server.state.renders_started(), 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_render_slot_is_taken_before_the_request_is_read() {
    // One slot, held by a long render. A request over the size limit then gets "busy", not
    // the size error: it was refused before a byte of it was read.
    let config = ServerConfig { max_concurrent_renders: 1, max_request_bytes: 64 << 10, ..Default::default() };
    let server = TestServer::with_config(config).await;
    let mut holder = server.client().await;
    let mut stream = holder.render(long_render(2)).await.expect("render starts").into_inner();
    within(60, "first frame", next_frame_complete(&mut stream)).await;

    let err = server.client().await.render(cornell_with_mesh(20_000)).await.expect_err("busy");
    assert_eq!(err.code(), Code::ResourceExhausted, "{err:?}");
    assert!(err.message().contains("max_concurrent_renders"), "{}", err.message());

    // The slot comes back when the render ends, and the next request is read and checked.
    drop(stream);
    assert!(wait_until(Duration::from_secs(30), || server.state.active_renders() == 0).await);
    let err = server.client().await.render(cornell_with_mesh(20_000)).await.expect_err("too big");
    assert!(err.message().contains("max_request_bytes"), "{}", err.message());
    // A refused request gives its slot back: a small one renders.
    collect(&mut server.client().await, cornell(8, 6, 1, 1)).await.expect("renders");
}

/// The built-in Cornell box lit also by an environment light.
fn cornell_with_environment(env: wedge::proto::EnvironmentLight) -> RenderRequest {
    let mut scene = wedge::scene::builtin::get("cornell").expect("cornell");
    scene.lights.push(wedge::proto::Light { kind: Some(wedge::proto::light::Kind::Environment(env)) });
    let mut req = cornell(8, 6, 1, 1);
    req.scene_source = Some(SceneSource::Scene(scene));
    req
}

fn inline_map(width: u32, height: u32) -> wedge::proto::EnvironmentLight {
    use wedge::proto::environment_light::Radiance;
    let rgb = vec![0.5; (3 * width * height) as usize];
    wedge::proto::EnvironmentLight {
        radiance: Some(Radiance::Map(wedge::proto::EnvironmentMap { width, height, rgb })),
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_environment_map_over_the_texel_limit_is_invalid_argument() {
    let limits = wedge::api::request::Limits { max_environment_texels: 64, ..Default::default() };
    let server = TestServer::with_config(ServerConfig { limits, ..Default::default() }).await;
    let ok = collect(&mut server.client().await, cornell_with_environment(inline_map(8, 8))).await;
    assert!(ok.expect("a map at the limit renders").frames.last().unwrap().stats.is_final);
    let err = server.client().await.render(cornell_with_environment(inline_map(16, 8))).await.expect_err("over");
    assert_eq!(err.code(), Code::InvalidArgument, "{err:?}");
    let text = err.message();
    assert!(text.contains("scene.lights[1].environment.map") && text.contains("limit of 64"), "{text}");
    // The sky is baked into a map: the same limit holds (its default 512 x 256 is over 64).
    let sky = wedge::proto::EnvironmentLight {
        radiance: Some(wedge::proto::environment_light::Radiance::Sky(Default::default())),
        ..Default::default()
    };
    let err = server.client().await.render(cornell_with_environment(sky)).await.expect_err("over");
    assert!(err.message().contains("sky.resolution") && err.message().contains("limit of 64"), "{}", err.message());
    // A server reads no files for a request: a map path is refused, by name.
    let path = wedge::proto::EnvironmentLight {
        radiance: Some(wedge::proto::environment_light::Radiance::Path("/etc/passwd.hdr".into())),
        ..Default::default()
    };
    let err = server.client().await.render(cornell_with_environment(path)).await.expect_err("a path");
    assert_eq!(err.code(), Code::InvalidArgument, "{err:?}");
    assert!(err.message().contains("scene.lights[1].environment.path"), "{}", err.message());
}

//! The Prometheus endpoint counts what happened: renders by outcome, rejections by reason,
//! frame latencies and rays, read over HTTP from a real server.
mod common;

use common::*;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tonic::Code;
use wedge::client::Target;
use wedge::proto::{render_request::SceneSource, Mesh, RenderRequest, Shape};
use wedge::server::auth::Tokens;
use wedge::server::ServerConfig;

const TOKEN: &str = "metrics-test-token-0123";

/// `GET path` on `addr` with plain HTTP/1.1; the status line and the body.
async fn http_get(addr: std::net::SocketAddr, path: &str) -> (String, String) {
    let mut s = tokio::net::TcpStream::connect(addr).await.expect("connect to metrics");
    s.write_all(format!("GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n").as_bytes()).await.unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).await.unwrap();
    let (head, body) = text.split_once("\r\n\r\n").expect("an HTTP response");
    (head.lines().next().unwrap_or("").to_string(), body.to_string())
}

/// The value of the sample named exactly `name` (with its labels).
fn sample(text: &str, name: &str) -> f64 {
    text.lines()
        .find_map(|l| l.strip_prefix(name).and_then(|rest| rest.strip_prefix(' ')))
        .unwrap_or_else(|| panic!("no sample {name} in\n{text}"))
        .parse()
        .unwrap()
}

fn oversized() -> RenderRequest {
    let mut scene = wedge::scene::builtin::get("cornell").unwrap();
    let n = 30_000u32;
    scene.shapes.push(Shape {
        material: scene.shapes[0].material.clone(),
        geometry: Some(wedge::proto::shape::Geometry::Mesh(Mesh {
            positions: (0..3 * n).map(|i| i as f32).collect(),
            indices: (0..n).collect(),
            ..Default::default()
        })),
        ..Default::default()
    });
    let mut req = cornell(8, 6, 1, 1);
    req.scene_source = Some(SceneSource::Scene(scene));
    req
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn metrics_count_renders_rejections_and_frames() {
    let config = ServerConfig {
        max_concurrent_renders: 1,
        max_request_bytes: 64 << 10,
        tokens: Tokens::parse(TOKEN).unwrap(),
        metrics_addr: Some("127.0.0.1:0".parse().unwrap()),
        ..Default::default()
    };
    let server = TestServer::with_config(config).await;
    // Bound by the server task, which starts concurrently.
    assert!(wait_until(Duration::from_secs(30), || server.state.metrics_addr().is_some()).await);
    let addr = server.state.metrics_addr().unwrap();
    let target = Target { addr: server.addr_str(), ca_pem: None, token: Some(TOKEN.to_string()) };
    let mut client = wedge::client::connect(&target).await.unwrap();

    // One render of three frames.
    let mut stream = client.render(cornell(8, 6, 3, 1)).await.unwrap().into_inner();
    while stream.message().await.unwrap().is_some() {}
    // One rejection of each kind.
    let mut bad = cornell(8, 6, 1, 1);
    bad.scene_source = Some(SceneSource::Builtin("no-such-scene".into()));
    assert_eq!(client.render(bad).await.unwrap_err().code(), Code::InvalidArgument);
    assert_eq!(client.render(oversized()).await.unwrap_err().code(), Code::ResourceExhausted);
    let mut anonymous = wedge::client::connect(&Target::from(server.addr_str().as_str())).await.unwrap();
    assert_eq!(anonymous.render(cornell(8, 6, 1, 1)).await.unwrap_err().code(), Code::Unauthenticated);
    let mut holder = client.render(long_render(1)).await.unwrap().into_inner();
    within(60, "first frame", next_frame_complete(&mut holder)).await;
    assert_eq!(client.render(cornell(8, 6, 1, 1)).await.unwrap_err().code(), Code::ResourceExhausted);

    let (status, text) = http_get(addr, "/metrics").await;
    assert!(status.contains("200"), "{status}");
    assert_eq!(sample(&text, "wedge_active_renders"), 1.0);
    drop(holder);
    assert!(wait_until(Duration::from_secs(30), || server.state.active_renders() == 0).await);

    let (_, text) = http_get(addr, "/metrics").await;
    assert_eq!(sample(&text, "wedge_renders_started_total"), 2.0);
    assert_eq!(sample(&text, "wedge_renders_finished_total"), 1.0);
    assert_eq!(sample(&text, "wedge_renders_cancelled_total"), 1.0);
    assert_eq!(sample(&text, "wedge_active_renders"), 0.0);
    for reason in ["busy", "too_large", "invalid", "unauthenticated"] {
        assert_eq!(sample(&text, &format!("wedge_renders_rejected_total{{reason=\"{reason}\"}}")), 1.0, "{reason}");
    }
    // Two first frames (the finished render's and the holder's), two intervals (3 frames).
    assert_eq!(sample(&text, "wedge_first_frame_seconds_count"), 2.0);
    assert!(sample(&text, "wedge_frame_interval_seconds_count") >= 2.0);
    // 8x6 pixels, 1 + 2 + 4 samples, at least a camera ray each.
    assert!(sample(&text, "wedge_rays_traced_total") >= 48.0 * 7.0, "{text}");

    let (status, _) = http_get(addr, "/other").await;
    assert!(status.contains("404"), "{status}");
}

//! Shutdown always ends within the grace period, whatever clients do: a health watch held
//! open, a render whose client stopped reading. And a client that stops reading loses its
//! render slot after the stall timeout.
mod common;

use common::*;
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use tonic::Code;
use tonic_health::pb::{health_check_response::ServingStatus, health_client::HealthClient, HealthCheckRequest};
use wedge::proto::{OutputSelection, RenderRequest};
use wedge::server::ServerConfig;

/// A long render whose frames are large enough (every layer, 160x120) to fill the transport's
/// flow-control window within a frame or two when nobody reads them.
fn heavy_long_render(seed: u64) -> RenderRequest {
    let mut req = long_render(seed);
    req.width = 160;
    req.height = 120;
    req.outputs = Some(OutputSelection {
        color: true,
        spp: true,
        filter_width: true,
        unfiltered: true,
        components: true,
        ..Default::default()
    });
    req
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_health_watch_does_not_hold_the_shutdown() {
    let config = ServerConfig { shutdown_grace: Duration::from_millis(300), ..Default::default() };
    let mut server = TestServer::with_config(config).await;
    let mut health = HealthClient::new(server.channel().await);
    let mut watch = health.watch(HealthCheckRequest { service: String::new() }).await.expect("watch").into_inner();
    let first = watch.message().await.expect("watch").expect("status");
    assert_eq!(first.status, ServingStatus::Serving as i32);

    server.begin_shutdown();
    let next = within(10, "health update", watch.message()).await.expect("watch").expect("status");
    assert_eq!(next.status, ServingStatus::NotServing as i32);
    // The watch never ends by itself: the end of the grace period ends it.
    let t0 = Instant::now();
    let end = within(10, "watch end", watch.message()).await.expect_err("the watch ends with a status");
    assert_eq!(end.code(), Code::Unavailable, "{end:?}");
    assert!(end.message().contains("shutting down"), "{}", end.message());
    assert!(t0.elapsed() < Duration::from_secs(5), "ended after {:?}", t0.elapsed());
    server.stop(Duration::from_secs(5)).await.expect("server stops");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_that_stopped_reading_does_not_hold_the_shutdown() {
    let config = ServerConfig { shutdown_grace: Duration::from_millis(300), ..Default::default() };
    let mut server = TestServer::with_config(config).await;
    let mut client = server.client().await;
    let mut stream = client.render(heavy_long_render(5)).await.expect("render starts").into_inner();
    within(60, "first frame", next_frame_complete(&mut stream)).await;
    // From here on nobody reads: the render thread soon waits on a full channel.
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(server.state.active_renders(), 1);
    server.begin_shutdown();
    let state = std::sync::Arc::clone(&server.state);
    server.stop(Duration::from_secs(10)).await.expect("the server stops although a client never reads");
    assert!(wait_until(Duration::from_secs(5), || state.active_renders() == 0).await, "the render thread still runs");
    assert_eq!(state.renders_cancelled(), 1);
    drop(stream);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stalled_client_loses_its_slot() {
    let config =
        ServerConfig { max_concurrent_renders: 1, stall_timeout: Duration::from_millis(400), ..Default::default() };
    let server = TestServer::with_config(config).await;
    let mut stalled = server.client().await;
    let mut stream = stalled.render(heavy_long_render(6)).await.expect("render starts").into_inner();
    within(60, "first frame", next_frame_complete(&mut stream)).await;

    // While it renders the only slot is taken.
    let busy = server.client().await.render(cornell(8, 6, 1, 1)).await.expect_err("no free slot");
    assert_eq!(busy.code(), Code::ResourceExhausted);
    // Nobody reads: after the stall timeout the render is cancelled and the slot freed.
    let freed = wait_until(Duration::from_secs(30), || server.state.active_renders() == 0).await;
    assert!(freed, "the stalled render still holds its slot");
    assert_eq!(server.state.renders_cancelled(), 1);
    let other = collect(&mut server.client().await, cornell(8, 6, 2, 1)).await.expect("the freed slot serves others");
    assert!(other.frames.last().unwrap().stats.is_final);

    // The stalled client, reading again, gets what was queued and then the reason.
    let status = within(30, "stalled stream end", final_status(&mut stream)).await;
    assert_eq!(status.code(), Code::DeadlineExceeded, "{status:?}");
    assert!(status.message().contains("stall timeout"), "{}", status.message());
}

/// The real binary, as an orchestrator stops it: SIGTERM with a health watch open.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn wedge_serve_exits_after_sigterm_with_a_watch_open() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_wedge"))
        .args(["serve", "--addr", "127.0.0.1:0", "--shutdown-grace", "1"])
        .env("RUST_LOG", "wedge=info")
        .stderr(Stdio::piped())
        .spawn()
        .expect("start wedge serve");
    let stderr = child.stderr.take().unwrap();
    let (addr_tx, addr_rx) = std::sync::mpsc::channel::<String>();
    let log = std::thread::spawn(move || {
        let mut lines = Vec::new();
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if line.contains("serving wedge.v1.Renderer") {
                let addr = line.split("addr=").nth(1).and_then(|s| s.split_whitespace().next()).unwrap_or("");
                let _ = addr_tx.send(addr.to_string());
            }
            lines.push(line);
        }
        lines
    });
    let addr = addr_rx.recv_timeout(Duration::from_secs(60)).expect("the server logs its address");
    let channel = tonic::transport::Endpoint::from_shared(format!("http://{addr}")).unwrap().connect().await.unwrap();
    let mut watch = HealthClient::new(channel)
        .watch(HealthCheckRequest { service: String::new() })
        .await
        .expect("watch")
        .into_inner();
    watch.message().await.expect("watch").expect("status");

    let t0 = Instant::now();
    let killed = Command::new("kill").args(["-TERM", &child.id().to_string()]).status().expect("kill");
    assert!(killed.success());
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        if t0.elapsed() > Duration::from_secs(15) {
            let _ = child.kill();
            panic!("wedge serve still runs 15 s after SIGTERM with a 1 s grace period");
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    assert!(status.success(), "{status:?}");
    let lines = log.join().unwrap();
    assert!(lines.iter().any(|l| l.contains("server stopped") || l.contains("closing them")), "{lines:#?}");
    // The watch saw NOT_SERVING and then UNAVAILABLE (or the closed connection).
    let mut saw_not_serving = false;
    loop {
        match watch.message().await {
            Ok(Some(m)) => saw_not_serving |= m.status == ServingStatus::NotServing as i32,
            Ok(None) => panic!("the watch ended with OK"),
            Err(s) => {
                assert!(matches!(s.code(), Code::Unavailable | Code::Unknown | Code::Internal), "{s:?}");
                break;
            }
        }
    }
    assert!(saw_not_serving);
}

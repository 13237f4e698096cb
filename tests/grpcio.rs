//! Stock Python clients against real servers. Replicas behind client-side balancing: grpcio with
//! `round_robin` over three local servers spreads renders across all three, and a render on a
//! draining server ends with UNAVAILABLE and is retried on another. Reflection: Python's
//! grpcio-reflection (v1alpha) lists and resolves the services.
//!
//! Needs Python with grpcio, grpcio-tools and grpcio-reflection; `.ci/run` installs them and sets
//! WEDGE_TEST_GRPCIO=1, which makes this test mandatory. Without that variable it is skipped
//! (a plain `cargo test` on a machine with only Rust).
mod common;

use common::*;
use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};
use std::time::Duration;
use wedge::server::ServerConfig;

fn grpcio_enabled() -> bool {
    std::env::var("WEDGE_TEST_GRPCIO").is_ok_and(|v| v == "1")
}

fn python() -> String {
    std::env::var("WEDGE_TEST_PYTHON").unwrap_or_else(|_| "python3".to_string())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn grpcio_reflection_lists_and_resolves_the_services() {
    if !grpcio_enabled() {
        eprintln!("skipped: set WEDGE_TEST_GRPCIO=1 with grpcio-reflection installed");
        return;
    }
    let server = TestServer::start().await;
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/grpcio/reflection.py");
    let addr = server.addr_str();
    let out = tokio::task::spawn_blocking(move || Command::new(python()).arg(script).arg(addr).output());
    let out = within(60, "the reflection client", out).await.expect("join").expect("run python");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{}", String::from_utf8_lossy(&out.stderr));
    for line in [
        "service grpc.health.v1.Health",
        "service wedge.v1.Renderer",
        "method Render wedge.v1.RenderRequest -> wedge.v1.RenderUpdate",
        "method ListScenes wedge.v1.ListScenesRequest -> wedge.v1.ListScenesResponse",
    ] {
        assert!(text.lines().any(|l| l == line), "no {line:?} in\n{text}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn grpcio_round_robin_spreads_renders_and_retries_a_draining_replica() {
    if !grpcio_enabled() {
        eprintln!("skipped: set WEDGE_TEST_GRPCIO=1 with grpcio and grpcio-tools installed");
        return;
    }
    let config = ServerConfig { shutdown_grace: Duration::from_millis(300), ..Default::default() };
    let mut servers = Vec::new();
    for _ in 0..3 {
        servers.push(TestServer::with_config(config.clone()).await);
    }
    let addrs: Vec<String> = servers.iter().map(TestServer::addr_str).collect();
    let python = python();
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/grpcio/round_robin.py");
    let mut child = Command::new(&python)
        .arg(script)
        .arg(addrs.join(","))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {python}: {e}"));
    let mut stdin = child.stdin.take().unwrap();
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<String>();
    let stdout = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let mut next_line = async || within(120, "the grpcio client", rx.recv()).await.expect("the client exited early");

    assert_eq!(next_line().await, "spread");
    let counts: Vec<u64> = servers.iter().map(|s| s.state.renders_started()).collect();
    assert_eq!(counts.iter().sum::<u64>(), 9, "{counts:?}");
    assert!(counts.iter().all(|&c| c > 0), "round_robin left a server out: {counts:?}");

    writeln!(stdin, "go").unwrap();
    assert_eq!(next_line().await, "long-started");
    let busy = servers.iter().position(|s| s.state.active_renders() == 1).expect("a server runs the long render");
    let before: Vec<u64> = servers.iter().map(|s| s.state.renders_started()).collect();
    servers[busy].begin_shutdown();

    assert_eq!(next_line().await, "long-ended UNAVAILABLE");
    assert_eq!(next_line().await, "retried OK");
    let after: Vec<u64> = servers.iter().map(|s| s.state.renders_started()).collect();
    assert_eq!(after[busy], before[busy], "the retry went to the draining server: {before:?} -> {after:?}");
    assert_eq!(after.iter().sum::<u64>(), before.iter().sum::<u64>() + 1, "{before:?} -> {after:?}");
    let status = child.wait().expect("client exit");
    assert!(status.success(), "{status:?}");
}

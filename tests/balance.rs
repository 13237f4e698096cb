//! Replicas behind client-side balancing: a stock grpcio client with `round_robin` over three
//! local servers spreads renders across all three, and a render on a draining server ends with
//! UNAVAILABLE and is retried on another.
//!
//! Needs Python with grpcio and grpcio-tools; `.ci/run` installs them and sets
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
    let python = std::env::var("WEDGE_TEST_PYTHON").unwrap_or_else(|_| "python3".to_string());
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

//! Load and soak against a real server on 127.0.0.1, bounded in time: 32 concurrent clients
//! retrying on RESOURCE_EXHAUSTED all get their final frame with bounded memory, and 1000
//! renders cancelled after their first chunk leave no work running and no memory behind.
mod common;

use common::*;
use std::time::{Duration, Instant};
use tonic::Code;
use wedge::proto::render_update::Kind;

/// The two tests read the process's memory: run them one at a time.
static SERIAL: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// This process's resident and peak resident memory in MiB (`/proc/self/status`).
fn memory_mib() -> (f64, f64) {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    let field = |name: &str| -> f64 {
        let line = status.lines().find(|l| l.starts_with(name)).unwrap_or_else(|| panic!("no {name}"));
        line.split_whitespace().nth(1).unwrap().parse::<f64>().unwrap() / 1024.0
    };
    (field("VmRSS:"), field("VmHWM:"))
}

/// Peak memory the 32-client run may reach (server and clients together, in this process).
const LOAD_PEAK_MIB: f64 = 128.0;
/// Resident memory the 1000 cancelled renders may add after a warm-up of 100.
const SOAK_GROWTH_MIB: f64 = 16.0;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn thirty_two_clients_with_retries_all_finish() {
    let _serial = SERIAL.lock().await;
    let server = TestServer::start().await;
    let t0 = Instant::now();
    let mut tasks = Vec::new();
    for client in 0..32u64 {
        let addr = server.addr_str();
        tasks.push(tokio::spawn(async move {
            let mut c = wedge::client::connect(&addr.as_str().into()).await.expect("connect");
            let mut refused = 0u32;
            loop {
                match collect_dyn(&mut c, cornell(48, 36, 3, client)).await {
                    Ok(last) => return (last, refused),
                    Err(s) if s.code() == Code::ResourceExhausted => {
                        refused += 1;
                        // Back off with jitter, as a well-behaved client does.
                        tokio::time::sleep(Duration::from_millis(5 + (client * 7 + u64::from(refused)) % 20)).await;
                    }
                    Err(s) => panic!("client {client}: {s:?}"),
                }
            }
        }));
    }
    let mut refusals = 0;
    for task in tasks {
        let (is_final, refused) = within(300, "a client", task).await.expect("client task");
        assert!(is_final, "a stream ended without its final frame");
        refusals += refused;
    }
    let (rss, peak) = memory_mib();
    println!(
        "32 clients: {:.1} s, {refusals} refusals retried, RSS {rss:.0} MiB, peak {peak:.0} MiB",
        t0.elapsed().as_secs_f64()
    );
    assert!(refusals > 0, "with 2 slots and 32 clients some calls must have been refused");
    assert_eq!(server.state.renders_finished(), 32);
    assert!(peak < LOAD_PEAK_MIB, "peak memory {peak:.0} MiB over {LOAD_PEAK_MIB} MiB");
}

/// Reads a render to its end with the token-carrying client; whether the last frame was final.
async fn collect_dyn(c: &mut wedge::client::Client, req: wedge::proto::RenderRequest) -> Result<bool, tonic::Status> {
    let mut stream = c.render(req).await?.into_inner();
    let mut is_final = false;
    while let Some(u) = stream.message().await? {
        if let Some(Kind::FrameComplete(f)) = u.kind {
            is_final = f.is_final;
        }
    }
    Ok(is_final)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_thousand_cancelled_renders_leave_nothing_behind() {
    let _serial = SERIAL.lock().await;
    let server = TestServer::start().await;
    let mut client = server.client().await;
    let mut cancel_after_first_chunk = async |seed: u64| {
        let mut stream = client.render(long_render(seed)).await.expect("render starts").into_inner();
        loop {
            let u = stream.message().await.expect("stream").expect("not ended");
            if matches!(u.kind, Some(Kind::Chunk(_))) {
                return;
            }
        }
    };
    let t0 = Instant::now();
    for seed in 0..100 {
        cancel_after_first_chunk(seed).await;
    }
    assert!(wait_until(Duration::from_secs(30), || server.state.active_renders() == 0).await);
    let (warm, _) = memory_mib();
    for seed in 100..1000 {
        // Slots free up as cancelled renders wind down; wait for one rather than be refused.
        assert!(wait_until(Duration::from_secs(30), || server.state.active_renders() < 2).await);
        cancel_after_first_chunk(seed).await;
    }
    let drained = wait_until(Duration::from_secs(30), || server.state.active_renders() == 0).await;
    assert!(drained, "{} renders still running", server.state.active_renders());
    let (rss, _) = memory_mib();
    let s = &server.state;
    println!(
        "1000 cancelled renders: {:.1} s, RSS {warm:.0} MiB after 100, {rss:.0} MiB after 1000",
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(s.renders_started(), 1000);
    assert_eq!(s.renders_cancelled(), 1000, "finished {} failed {}", s.renders_finished(), s.renders_failed());
    assert!(rss - warm < SOAK_GROWTH_MIB, "memory grew {:.0} MiB over {SOAK_GROWTH_MIB} MiB", rss - warm);
}

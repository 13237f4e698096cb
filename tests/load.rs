//! Load and soak against a real server on 127.0.0.1, bounded in time: 32 concurrent clients
//! retrying on RESOURCE_EXHAUSTED all get their final frame with bounded memory, and 1000
//! renders cancelled after their first chunk leave no work running and no memory behind.
mod common;

use common::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};
use tonic::Code;
use wedge::proto::render_update::Kind;

/// The two tests read the process's memory: run them one at a time.
static SERIAL: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// The system allocator with a count of live and peak heap bytes. Server and clients run in
/// this process, so the count is every byte they hold; unlike the resident set size it does not
/// move with the allocator's arenas and free lists, so a small leak per render shows at once.
struct CountingAlloc;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded unchanged to the system allocator.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(live, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

const MIB: f64 = 1024.0 * 1024.0;

/// Live heap bytes in MiB.
fn live_mib() -> f64 {
    LIVE.load(Ordering::Relaxed) as f64 / MIB
}

/// Peak live heap bytes in MiB since the last reset.
fn peak_mib() -> f64 {
    PEAK.load(Ordering::Relaxed) as f64 / MIB
}

fn reset_peak() {
    PEAK.store(LIVE.load(Ordering::Relaxed), Ordering::Relaxed);
}

/// Peak heap the 32-client run may reach (server and clients together, in this process).
const LOAD_PEAK_MIB: f64 = 128.0;
/// Heap the 1000 cancelled renders may add after a warm-up of 100: a leak of 2.5 KiB per render
/// goes over it.
const SOAK_GROWTH_MIB: f64 = 2.0;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn thirty_two_clients_with_retries_all_finish() {
    let _serial = SERIAL.lock().await;
    let server = TestServer::start().await;
    reset_peak();
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
    let (live, peak) = (live_mib(), peak_mib());
    println!(
        "32 clients: {:.1} s, {refusals} refusals retried, heap {live:.1} MiB, peak {peak:.1} MiB",
        t0.elapsed().as_secs_f64()
    );
    assert!(refusals > 0, "with 2 slots and 32 clients some calls must have been refused");
    assert_eq!(server.state.renders_finished(), 32);
    assert!(peak < LOAD_PEAK_MIB, "peak heap {peak:.0} MiB over {LOAD_PEAK_MIB} MiB");
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
    let warm = live_mib();
    for seed in 100..1000 {
        // Slots free up as cancelled renders wind down; wait for one rather than be refused.
        assert!(wait_until(Duration::from_secs(30), || server.state.active_renders() < 2).await);
        cancel_after_first_chunk(seed).await;
    }
    let drained = wait_until(Duration::from_secs(30), || server.state.active_renders() == 0).await;
    assert!(drained, "{} renders still running", server.state.active_renders());
    let after = live_mib();
    let s = &server.state;
    println!(
        "1000 cancelled renders: {:.1} s, heap {warm:.2} MiB after 100, {after:.2} MiB after 1000",
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(s.renders_started(), 1000);
    assert_eq!(s.renders_cancelled(), 1000, "finished {} failed {}", s.renders_finished(), s.renders_failed());
    assert!(after - warm < SOAK_GROWTH_MIB, "heap grew {:.2} MiB, over {SOAK_GROWTH_MIB} MiB", after - warm);
}

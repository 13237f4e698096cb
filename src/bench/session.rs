//! Camera-update latency of an editing session over gRPC: a client orbits the camera with
//! `updates` changes at `rate` Hz, as an editor's drag does, and times each change to the first
//! frame of its view. Against a server on 127.0.0.1 in this process (or a given address).
use crate::client::{connect, Target};
use crate::proto::{self, session_event::Kind, session_request, CameraOverride, SessionRequest, SessionUpdate};
use glam::{Quat, Vec3};
use std::collections::HashMap;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;

pub struct SessionReport {
    /// Seconds from sending a change to the first frame of its view, for every change whose
    /// view got a frame (a change superseded before its first frame has none).
    pub latencies: Vec<f64>,
    /// The same to the first full-resolution frame (after the quick preview).
    pub full_latencies: Vec<f64>,
    /// Changes sent.
    pub updates: usize,
    /// Frames received, and frames the server skipped because a newer one was waiting.
    pub frames: u64,
    pub dropped: u64,
}

/// The camera position `deg` degrees around the look-at point, about the up axis.
fn orbit(camera: &proto::Camera, deg: f32) -> proto::Vec3 {
    let v = |v: &Option<proto::Vec3>, d: Vec3| v.as_ref().map_or(d, |v| Vec3::new(v.x, v.y, v.z));
    let (p, at, up) = (v(&camera.position, Vec3::Z), v(&camera.look_at, Vec3::ZERO), v(&camera.up, Vec3::Y));
    let q = Quat::from_axis_angle(up.normalize(), deg.to_radians());
    let r = at + q * (p - at);
    proto::Vec3 { x: r.x, y: r.y, z: r.z }
}

/// Opens a session with `req`, waits for its first frame, then sends `updates` camera changes
/// at `rate` Hz sweeping `sweep_deg` degrees around the scene camera's look-at point, and waits
/// for the last view's first frame.
pub async fn measure(
    req: proto::RenderRequest,
    camera: proto::Camera,
    updates: usize,
    rate: f64,
    sweep_deg: f32,
    addr: Option<String>,
) -> anyhow::Result<SessionReport> {
    let (addr, local) = crate::bench::bench_server(addr).await?;
    let mut client = connect(&Target::from(addr.as_str())).await?;
    let (tx, rx) = mpsc::channel::<SessionRequest>(updates + 1);
    tx.send(SessionRequest { kind: Some(session_request::Kind::Open(req)) }).await?;
    let mut events = client.session(ReceiverStream::new(rx)).await?.into_inner();

    // The reader records when the first frame of each generation arrived.
    let (frames_tx, mut frames_rx) = tokio::sync::watch::channel(0u64);
    let reader = tokio::spawn(async move {
        let mut first_frame: HashMap<u64, Instant> = HashMap::new();
        let mut first_full: HashMap<u64, Instant> = HashMap::new();
        let (mut frames, mut dropped) = (0u64, 0u64);
        while let Some(e) = events.message().await? {
            if let Some(Kind::FrameComplete(_)) = e.kind {
                frames += 1;
                dropped = dropped.max(e.frames_dropped);
                first_frame.entry(e.generation).or_insert_with(Instant::now);
                if e.preview_divider == 0 {
                    first_full.entry(e.generation).or_insert_with(Instant::now);
                }
                let _ = frames_tx.send(frames);
            }
        }
        anyhow::Ok((first_frame, first_full, frames, dropped))
    });
    // Generation 1 is the open: wait for its first frame before the drag starts (the compile
    // and the first frame are `wedge bench latency`'s subject), and let it settle.
    // (The borrow `wait_for` returns is dropped at once: holding it would block the reader.)
    let first = tokio::time::timeout(Duration::from_secs(60), frames_rx.wait_for(|&n| n > 0)).await;
    if !matches!(first.map(|r| r.map(|_| ())), Ok(Ok(()))) {
        anyhow::bail!("the session sent no frame within 60 s");
    }
    tokio::time::sleep(Duration::from_millis(500)).await;

    let period = Duration::from_secs_f64(1.0 / rate.max(1e-3));
    let mut sent: Vec<(u64, Instant)> = Vec::with_capacity(updates);
    let start = tokio::time::Instant::now();
    for k in 0..updates {
        tokio::time::sleep_until(start + period * k as u32).await;
        let deg = -sweep_deg / 2.0 + sweep_deg * k as f32 / (updates.max(2) - 1) as f32;
        let camera = CameraOverride { position: Some(orbit(&camera, deg)), ..Default::default() };
        let u = SessionUpdate { camera: Some(camera), ..Default::default() };
        tx.send(SessionRequest { kind: Some(session_request::Kind::Update(u)) }).await?;
        // The open is generation 1; each accepted change bumps it.
        sent.push((k as u64 + 2, Instant::now()));
    }
    // Time for the last view's first frame, then close the session.
    tokio::time::sleep(Duration::from_secs(2)).await;
    drop(tx);
    let (first_frame, first_full, frames, dropped) = reader.await??;
    let since_sent = |arrivals: &HashMap<u64, Instant>| -> Vec<f64> {
        sent.iter()
            .filter_map(|(g, t)| arrivals.get(g).map(|f| f.saturating_duration_since(*t).as_secs_f64()))
            .collect()
    };
    let (latencies, full_latencies) = (since_sent(&first_frame), since_sent(&first_full));
    if let Some(server) = local {
        server.stop().await?;
    }
    Ok(SessionReport { latencies, full_latencies, updates, frames, dropped })
}

impl SessionReport {
    /// The 95th percentile of the change-to-first-frame times (nearest rank), seconds.
    pub fn p95(&self) -> f64 {
        let mut l = self.latencies.clone();
        l.sort_by(f64::total_cmp);
        l.get(((l.len() as f64 * 0.95).ceil() as usize).saturating_sub(1)).copied().unwrap_or(f64::NAN)
    }

    /// The line scripts read: `METHOD: median N ms, p95 M ms, dropped K of T`.
    pub fn line(&self, method: &str) -> String {
        format!(
            "{method}: median {:.0} ms, p95 {:.0} ms, dropped {} of {}",
            super::median(self.latencies.clone()) * 1e3,
            self.p95() * 1e3,
            self.dropped,
            self.frames + self.dropped
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_report_line_has_the_median_the_nearest_rank_p95_and_the_drops() {
        let r = SessionReport {
            latencies: (1..=21).map(|ms| ms as f64 / 1e3).collect(),
            full_latencies: vec![],
            updates: 21,
            frames: 30,
            dropped: 4,
        };
        assert_eq!(r.line("auto"), "auto: median 11 ms, p95 20 ms, dropped 4 of 34");
    }

    #[test]
    fn the_orbit_keeps_the_distance_and_turns_about_up() {
        let cam = proto::Camera {
            position: Some(proto::Vec3 { x: 0.0, y: 1.0, z: 5.0 }),
            look_at: Some(proto::Vec3 { x: 0.0, y: 1.0, z: 0.0 }),
            ..Default::default()
        };
        let p = orbit(&cam, 90.0);
        assert!((p.x - 5.0).abs() < 1e-4 && (p.y - 1.0).abs() < 1e-6 && p.z.abs() < 1e-4, "{p:?}");
        let p = orbit(&cam, 0.0);
        assert!((p.z - 5.0).abs() < 1e-6);
    }
}

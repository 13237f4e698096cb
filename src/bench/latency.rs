//! Latency from a Render request to its first frames over gRPC, against a server on 127.0.0.1
//! in this process (or a given address).
use crate::client::connect;
use crate::proto::{self, render_update::Kind};
use std::time::Instant;

pub struct LatencyReport {
    /// Per run, the seconds from sending the request to receiving each FrameComplete.
    pub frames: Vec<Vec<f64>>,
    /// Seconds to open the connection.
    pub connect: f64,
}

/// Runs `runs` renders of `req` on a fresh in-process server (when `addr` is None) and times
/// each one's frames. The first run warms up and is not counted.
pub async fn measure(req: proto::RenderRequest, runs: usize, addr: Option<String>) -> anyhow::Result<LatencyReport> {
    let (addr, local) = crate::bench::bench_server(addr).await?;
    let t = Instant::now();
    let mut client = connect(&addr.as_str().into()).await?;
    let connect_s = t.elapsed().as_secs_f64();
    let mut times = Vec::new();
    for run in 0..=runs {
        let start = Instant::now();
        let mut stream = client.render(req.clone()).await?.into_inner();
        let mut frames = Vec::new();
        while let Some(u) = stream.message().await? {
            if let Some(Kind::FrameComplete(_)) = u.kind {
                frames.push(start.elapsed().as_secs_f64());
            }
        }
        if run > 0 {
            times.push(frames);
        }
    }
    if let Some(server) = local {
        server.stop().await?;
    }
    Ok(LatencyReport { frames: times, connect: connect_s })
}

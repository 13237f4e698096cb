//! Benchmarks that `wedge bench` runs: ray throughput of the tracer (`rays`), samples per
//! second of the path tracer (`throughput`) and latency to the first frame over gRPC
//! (`latency`). Results are printed as Markdown for BENCHMARKS.md.
pub mod convergence;
pub mod flip;
pub mod latency;
pub mod noise;
pub mod plot;
pub mod rays;
pub mod reference;
pub mod run;
pub mod session;
pub mod throughput;

/// Median of a non-empty sample (the mean of the middle two for even counts).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// CPU seconds this process has used (user + system, all threads), from /proc on Linux.
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are the 14th and 15th.
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    // Linux reports in USER_HZ, 100 on every architecture Rust targets.
    Some(ticks / 100.0)
}

/// One line describing this machine, for benchmark reports.
pub fn machine_description() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    format!("{cpu}, {cores} hardware threads, {} {}", std::env::consts::OS, std::env::consts::ARCH)
}

/// A wedge server for the service benchmarks: `addr` when given, else one started in this
/// process on 127.0.0.1 (stop it with `LocalServer::stop`).
pub async fn bench_server(addr: Option<String>) -> anyhow::Result<(String, Option<LocalServer>)> {
    if let Some(a) = addr {
        return Ok((a, None));
    }
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let local = listener.local_addr()?;
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let config = crate::server::ServerConfig::default();
    let task = tokio::spawn(crate::server::serve_on(listener, config, crate::server::ServerState::new(), async {
        let _ = rx.await;
    }));
    Ok((format!("http://{local}"), Some(LocalServer { tx, task })))
}

pub struct LocalServer {
    tx: tokio::sync::oneshot::Sender<()>,
    task: tokio::task::JoinHandle<anyhow::Result<()>>,
}

impl LocalServer {
    pub async fn stop(self) -> anyhow::Result<()> {
        let _ = self.tx.send(());
        self.task.await?
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn median_of_odd_and_even_samples() {
        assert_eq!(super::median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(super::median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(super::median(vec![]).is_nan());
    }
}

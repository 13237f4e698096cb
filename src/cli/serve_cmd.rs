//! `wedge serve`: the gRPC server with the limits given on the command line.
use super::ServeArgs;
use crate::api::request::Limits;
use crate::server::{serve, shutdown_signal, ServerConfig};

pub fn run(a: ServeArgs) -> anyhow::Result<()> {
    let config = ServerConfig {
        addr: a.addr,
        limits: Limits {
            max_pixels: a.max_pixels,
            max_triangles: a.max_triangles,
            max_passes: a.max_passes,
            max_mean_spp: a.max_spp,
            max_time_budget_seconds: a.max_time,
            mesh_root: None,
        },
        max_concurrent_renders: a.max_concurrent.max(1),
        max_chunk_bytes: a.max_chunk_bytes,
        max_request_bytes: a.max_request_bytes,
        shutdown_grace: seconds("--shutdown-grace", a.shutdown_grace)?,
        stall_timeout: seconds("--stall-timeout", a.stall_timeout)?,
    };
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    let result = runtime.block_on(serve(config, shutdown_signal()));
    // Renders were cancelled when the grace period ended; do not wait on a stuck thread.
    runtime.shutdown_timeout(std::time::Duration::from_secs(2));
    result
}

/// A duration option in seconds: finite and not negative.
fn seconds(option: &str, value: f64) -> anyhow::Result<std::time::Duration> {
    if !(value >= 0.0) {
        anyhow::bail!("{option} {value}: must be a number of seconds, at least 0");
    }
    std::time::Duration::try_from_secs_f64(value).map_err(|e| anyhow::anyhow!("{option} {value}: {e}"))
}

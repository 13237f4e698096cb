//! `wedge serve`: the gRPC server with the limits given on the command line.
use super::ServeArgs;
use crate::api::request::Limits;
use crate::server::auth::Tokens;
use crate::server::exposure::{check_exposure, TlsIdentity};
use crate::server::{serve, shutdown_signal, ServerConfig};
use std::path::Path;

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
            max_environment_texels: a.max_environment_texels,
        },
        max_concurrent_renders: a.max_concurrent.max(1),
        max_chunk_bytes: a.max_chunk_bytes,
        max_request_bytes: a.max_request_bytes,
        shutdown_grace: seconds("--shutdown-grace", a.shutdown_grace)?,
        stall_timeout: seconds("--stall-timeout", a.stall_timeout)?,
        tls: tls_identity(&a)?,
        tokens: tokens(&a)?,
        reflection: !a.no_reflection,
        metrics_addr: a.metrics_addr,
        health_addr: a.health_addr,
        session_idle_timeout: seconds("--session-idle-timeout", a.session_idle_timeout)?,
        scene_cache_bytes: a.scene_cache_bytes,
        scene_cache_triangles: a.scene_cache_triangles,
        web: a.web,
        web_session_queue: a.web_session_queue,
        max_connection_age: Some(seconds("--max-connection-age", a.max_connection_age)?).filter(|d| !d.is_zero()),
    };
    check_exposure(config.addr, config.tls.is_some(), !config.tokens.is_empty(), a.insecure)
        .map_err(|e| anyhow::anyhow!(e))?;
    if a.insecure && !config.addr.ip().is_loopback() {
        tracing::warn!(addr = %config.addr, "--insecure: serving beyond loopback without TLS or a token");
    }
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    let result = runtime.block_on(serve(config, shutdown_signal()));
    // Renders were cancelled when the grace period ended; do not wait on a stuck thread.
    runtime.shutdown_timeout(std::time::Duration::from_secs(2));
    result
}

/// The environment variable holding one more bearer token.
pub const TOKEN_ENV: &str = "WEDGE_TOKEN";

fn read(option: &str, path: &Path) -> anyhow::Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| anyhow::anyhow!("{option} {}: {e}", path.display()))
}

fn tls_identity(a: &ServeArgs) -> anyhow::Result<Option<TlsIdentity>> {
    let (Some(cert), Some(key)) = (&a.tls_cert, &a.tls_key) else { return Ok(None) };
    let identity = TlsIdentity { cert_pem: read("--tls-cert", cert)?, key_pem: read("--tls-key", key)? };
    if !identity.cert_pem.starts_with(b"-----BEGIN") {
        anyhow::bail!("--tls-cert {}: not a PEM file (expected -----BEGIN CERTIFICATE-----)", cert.display());
    }
    if !identity.key_pem.starts_with(b"-----BEGIN") {
        anyhow::bail!("--tls-key {}: not a PEM file (expected -----BEGIN PRIVATE KEY-----)", key.display());
    }
    Ok(Some(identity))
}

fn tokens(a: &ServeArgs) -> anyhow::Result<Tokens> {
    let mut tokens = match &a.token_file {
        Some(path) => {
            let text = String::from_utf8(read("--token-file", path)?)
                .map_err(|_| anyhow::anyhow!("--token-file {}: not UTF-8 text", path.display()))?;
            let tokens = Tokens::parse(&text).map_err(|e| anyhow::anyhow!("--token-file {}: {e}", path.display()))?;
            if tokens.is_empty() {
                anyhow::bail!("--token-file {}: no token in the file", path.display());
            }
            tokens
        }
        None => Tokens::default(),
    };
    if let Ok(token) = std::env::var(TOKEN_ENV) {
        tokens.add(token.trim()).map_err(|e| anyhow::anyhow!("{TOKEN_ENV}: {e}"))?;
    }
    Ok(tokens)
}

/// A duration option in seconds: finite and not negative.
fn seconds(option: &str, value: f64) -> anyhow::Result<std::time::Duration> {
    if !(value >= 0.0) {
        anyhow::bail!("{option} {value}: must be a number of seconds, at least 0");
    }
    std::time::Duration::try_from_secs_f64(value).map_err(|e| anyhow::anyhow!("{option} {value}: {e}"))
}

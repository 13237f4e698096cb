//! gRPC layer: a thin tonic server around the render core. `frames` puts frames on the wire,
//! `render_service` is the `Renderer` service, `catalog` answers `ListScenes`, `state` holds
//! the counters; health and reflection are registered here.
pub mod catalog;
pub mod log_text;
pub mod render_service;
pub mod state;

pub use crate::api::wire::{FrameAssembler, DEFAULT_MAX_CHUNK_BYTES};
pub use render_service::RenderService;
pub use state::ServerState;

use crate::proto::renderer_server::RendererServer;
use anyhow::Context;
use std::future::Future;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;
use tonic::transport::server::TcpIncoming;
use tonic::transport::Server;
use tonic_health::ServingStatus;

/// Where and how `wedge serve` listens.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    pub addr: SocketAddr,
    pub limits: crate::api::request::Limits,
    /// Renders running at once; more are refused with `RESOURCE_EXHAUSTED`.
    pub max_concurrent_renders: usize,
    /// Cap on the pixel bytes of one streamed chunk (at least one row is always sent).
    pub max_chunk_bytes: usize,
    /// Largest request (inline scene) accepted, in bytes.
    pub max_request_bytes: usize,
    /// After a shutdown signal, how long in-flight renders may run on before they are
    /// cancelled (their clients get UNAVAILABLE).
    pub shutdown_grace: Duration,
}

impl Default for ServerConfig {
    fn default() -> Self {
        ServerConfig {
            addr: SocketAddr::from(([127, 0, 0, 1], 50051)),
            limits: crate::api::request::Limits::default(),
            max_concurrent_renders: 2,
            max_chunk_bytes: DEFAULT_MAX_CHUNK_BYTES,
            max_request_bytes: 256 << 20,
            shutdown_grace: Duration::from_secs(10),
        }
    }
}

/// Binds `config.addr` and serves until `shutdown` resolves.
pub async fn serve(config: ServerConfig, shutdown: impl Future<Output = ()>) -> anyhow::Result<()> {
    let listener = tokio::net::TcpListener::bind(config.addr)
        .await
        .with_context(|| format!("cannot listen on {}", config.addr))?;
    serve_on(listener, config, ServerState::new(), shutdown).await
}

/// Serves on an already bound listener (tests bind port 0) until `shutdown` resolves; then
/// reports NOT_SERVING, stops accepting, and lets in-flight streams finish. `config.addr` is
/// ignored.
pub async fn serve_on(
    listener: tokio::net::TcpListener,
    config: ServerConfig,
    state: Arc<ServerState>,
    shutdown: impl Future<Output = ()>,
) -> anyhow::Result<()> {
    let local = listener.local_addr().context("listener has no address")?;
    let drain_state = Arc::clone(&state);
    let service = {
        let config = config.clone();
        tokio::task::spawn_blocking(move || RenderService::new(&config, state))
            .await
            .context("building the render service")?
    };

    let (health, health_service) = tonic_health::server::health_reporter();
    health.set_serving::<RendererServer<RenderService>>().await;
    let reflection = tonic_reflection::server::Builder::configure()
        .register_encoded_file_descriptor_set(crate::proto::FILE_DESCRIPTOR_SET)
        .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
        .build_v1()
        .context("building the reflection service")?;

    let grace = config.shutdown_grace;
    let signal = async move {
        shutdown.await;
        tracing::info!(
            grace_seconds = grace.as_secs_f64(),
            "shutting down: refusing new calls, finishing in-flight renders"
        );
        health.set_not_serving::<RendererServer<RenderService>>().await;
        health.set_service_status("", ServingStatus::NotServing).await;
        // Renders still running when the grace period ends are cancelled, so shutdown never
        // waits for a long time budget.
        tokio::spawn(async move {
            tokio::time::sleep(grace).await;
            if drain_state.active_renders() > 0 {
                tracing::warn!(renders = drain_state.active_renders(), "grace period over: cancelling renders");
            }
            drain_state.begin_drain();
        });
    };
    let incoming = TcpIncoming::from(listener).with_nodelay(Some(true)).with_keepalive(Some(Duration::from_secs(60)));

    tracing::info!(
        addr = %local,
        max_concurrent_renders = config.max_concurrent_renders,
        max_chunk_bytes = config.max_chunk_bytes,
        limits = ?config.limits,
        "serving wedge.v1.Renderer"
    );
    Server::builder()
        // Notice clients that vanished without closing the connection, so their renders stop.
        .http2_keepalive_interval(Some(Duration::from_secs(30)))
        .http2_keepalive_timeout(Some(Duration::from_secs(20)))
        .add_service(health_service)
        .add_service(reflection)
        // Inline scenes can be large: accept requests up to the configured size (replies are
        // chunked, so the 4 MiB default of clients is never an issue in that direction).
        .add_service(RendererServer::new(service).max_decoding_message_size(config.max_request_bytes))
        .serve_with_incoming_shutdown(incoming, signal)
        .await
        .context("gRPC server failed")?;
    tracing::info!("server stopped");
    Ok(())
}

/// Resolves on SIGINT (Ctrl-C) or, on Unix, SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        if let Err(e) = tokio::signal::ctrl_c().await {
            tracing::warn!("cannot listen for Ctrl-C: {e}");
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        use tokio::signal::unix::{signal, SignalKind};
        match signal(SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(e) => {
                tracing::warn!("cannot listen for SIGTERM: {e}");
                std::future::pending::<()>().await;
            }
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => tracing::info!("received SIGINT"),
        () = term => tracing::info!("received SIGTERM"),
    }
}

//! Starts the real server in-process on 127.0.0.1 with an OS-chosen port.
#![allow(dead_code)]

use std::future::Future;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::oneshot;
use tokio::task::JoinHandle;
use tonic::transport::{Channel, Endpoint};
use wedge::pipeline::frame::Frame;
use wedge::proto::renderer_client::RendererClient;
use wedge::proto::{
    render_request::SceneSource, render_update, Method, OutputSelection, RenderRequest, RenderSettings, RenderStarted,
    RenderUpdate,
};
use wedge::server::{FrameAssembler, ServerConfig, ServerState};

pub struct TestServer {
    pub addr: SocketAddr,
    pub state: Arc<ServerState>,
    shutdown: Option<oneshot::Sender<()>>,
    task: Option<JoinHandle<anyhow::Result<()>>>,
}

impl TestServer {
    pub async fn start() -> TestServer {
        Self::with_config(ServerConfig::default()).await
    }

    pub async fn with_config(config: ServerConfig) -> TestServer {
        init_tracing();
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind 127.0.0.1:0");
        let addr = listener.local_addr().expect("local addr");
        let state = ServerState::new();
        let (tx, rx) = oneshot::channel::<()>();
        let shutdown = async move {
            let _ = rx.await;
        };
        let task = tokio::spawn(wedge::server::serve_on(listener, config, Arc::clone(&state), shutdown));
        TestServer { addr, state, shutdown: Some(tx), task: Some(task) }
    }

    /// `host:port`, as `client::render_remote` takes it.
    pub fn addr_str(&self) -> String {
        self.addr.to_string()
    }

    pub async fn channel(&self) -> Channel {
        Endpoint::from_shared(format!("http://{}", self.addr))
            .expect("endpoint")
            .connect()
            .await
            .expect("connect to the test server")
    }

    pub async fn client(&self) -> RendererClient<Channel> {
        RendererClient::new(self.channel().await)
    }

    /// Starts the graceful shutdown without waiting for it.
    pub fn begin_shutdown(&mut self) {
        if let Some(tx) = self.shutdown.take() {
            let _ = tx.send(());
        }
    }

    /// Shuts down and waits (at most `timeout`) for `serve_on` to return.
    pub async fn stop(mut self, timeout: Duration) -> anyhow::Result<()> {
        self.begin_shutdown();
        let task = self.task.take().expect("server task");
        tokio::time::timeout(timeout, task)
            .await
            .map_err(|_| anyhow::anyhow!("server did not stop within {timeout:?}"))??
    }
}

impl Drop for TestServer {
    fn drop(&mut self) {
        self.begin_shutdown();
        if let Some(task) = self.task.take() {
            task.abort();
        }
    }
}

fn init_tracing() {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("wedge=info")),
        )
        .with_test_writer()
        .try_init();
}

/// The built-in Cornell box at a tiny size with the uniform method and a fixed seed.
pub fn cornell(width: u32, height: u32, max_passes: u32, seed: u64) -> RenderRequest {
    RenderRequest {
        scene_source: Some(SceneSource::Builtin("cornell".into())),
        width,
        height,
        settings: Some(RenderSettings {
            method: Method::Uniform as i32,
            max_passes,
            initial_spp: 1,
            bounces: Some(1),
            ..Default::default()
        }),
        seed,
        outputs: Some(OutputSelection { color: true, spp: true, ..Default::default() }),
        ..Default::default()
    }
}

/// A render that runs far longer than any test: cancel it.
pub fn long_render(seed: u64) -> RenderRequest {
    let mut req = cornell(48, 36, 64, seed);
    if let Some(s) = req.settings.as_mut() {
        s.time_budget_seconds = 600.0;
        s.max_mean_spp = 60000.0;
    }
    req
}

/// Everything a render stream carried, assembled, plus the number of chunks per frame.
pub struct Collected {
    pub started: RenderStarted,
    pub frames: Vec<Frame>,
    pub chunks_per_frame: Vec<usize>,
}

/// Reads a whole render stream with the raw client.
pub async fn collect(client: &mut RendererClient<Channel>, req: RenderRequest) -> Result<Collected, tonic::Status> {
    let mut stream = client.render(req).await?.into_inner();
    let mut asm = FrameAssembler::new();
    let mut frames = Vec::new();
    let mut chunks_per_frame = Vec::new();
    let mut chunks = 0;
    while let Some(update) = stream.message().await? {
        if matches!(update.kind, Some(render_update::Kind::Chunk(_))) {
            chunks += 1;
        }
        if let Some(frame) = asm.push(update).expect("well-formed stream") {
            frames.push(frame);
            chunks_per_frame.push(chunks);
            chunks = 0;
        }
    }
    assert!(!asm.in_frame(), "stream ended inside a frame");
    let started = asm.started().expect("RenderStarted").clone();
    Ok(Collected { started, frames, chunks_per_frame })
}

/// The next update whose kind is `FrameComplete` (skipping chunks); panics at end of stream.
pub async fn next_frame_complete(stream: &mut tonic::Streaming<RenderUpdate>) {
    loop {
        let update = stream.message().await.expect("stream ok").expect("stream not ended");
        if let Some(render_update::Kind::FrameComplete(_)) = update.kind {
            return;
        }
    }
}

/// Polls `cond` every 10 ms until it holds or `timeout` passes; returns whether it held.
pub async fn wait_until(timeout: Duration, mut cond: impl FnMut() -> bool) -> bool {
    let deadline = tokio::time::Instant::now() + timeout;
    loop {
        if cond() {
            return true;
        }
        if tokio::time::Instant::now() >= deadline {
            return false;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

/// Fails the test if `fut` takes longer than `secs` seconds.
pub async fn within<T>(secs: u64, what: &str, fut: impl Future<Output = T>) -> T {
    tokio::time::timeout(Duration::from_secs(secs), fut)
        .await
        .unwrap_or_else(|_| panic!("{what} took longer than {secs} s"))
}

/// The bit patterns of a frame's layers, for exact comparisons.
pub fn color_bits(frame: &Frame) -> Vec<u32> {
    frame.color.iter().flatten().map(|v| v.to_bits()).collect()
}

pub fn spp_bits(frame: &Frame) -> Vec<u32> {
    frame.spp.iter().map(|v| v.to_bits()).collect()
}

/// Reads a render stream to its end and returns its final status; panics if it ends with OK.
pub async fn final_status(stream: &mut tonic::Streaming<RenderUpdate>) -> tonic::Status {
    loop {
        match stream.message().await {
            Ok(Some(_)) => continue,
            Ok(None) => panic!("the stream ended with OK"),
            Err(s) => return s,
        }
    }
}

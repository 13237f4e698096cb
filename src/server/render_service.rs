//! The `Renderer` gRPC service: each handler takes a slot, maps the request through
//! `api::request::prepare`, and hands the job to `runner` with a sink that puts frames on the
//! wire (`api::wire`).
use super::admission::{RenderSlot, RequestId};
use super::log_text::Escaped;
use super::metrics::RejectReason;
use super::scene_cache::{self, SceneCache, StoredScene};
use super::session::{self, Inbound};
use super::state::{RenderOutcome, ServerState};
use super::web_sessions::WebSessions;
use super::ServerConfig;
use crate::api::request::{self, Limits, PreparedJob};
use crate::api::wire;
use crate::pipeline::frame::Frame;
use crate::pipeline::job::CancelToken;
use crate::pipeline::registry::component_names;
use crate::proto::{
    render_request::SceneSource, render_update, renderer_server::Renderer, FrameComplete, ListScenesRequest,
    ListScenesResponse, OutputSelection, PixelFormat, PutSceneRequest, PutSceneResponse, RenderRequest, RenderStarted,
    RenderUpdate, SessionRequest, UpdateSessionRequest, UpdateSessionResponse, WatchSessionRequest,
};
use crate::runner::{self, RunError, RunSummary, Slots};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::{Request, Response, Status};
use tracing::{info, warn};

/// Messages buffered between the render thread and the client: a slow client holds the render
/// back instead of letting frames pile up in memory. One more place is reserved up front for
/// the final status, so that it can always be queued behind the frames.
const CHANNEL_CAPACITY: usize = 4;

type UpdateResult = Result<RenderUpdate, Status>;

pub struct RenderService {
    limits: Arc<Limits>,
    max_chunk_bytes: usize,
    stall_timeout: Duration,
    session_idle_timeout: Duration,
    slots: Slots,
    state: Arc<ServerState>,
    /// Scenes stored by `PutScene`, named by digest.
    cache: Arc<SceneCache>,
    scenes: Arc<ListScenesResponse>,
    /// Sessions opened by `WatchSession`, which `UpdateSession` names.
    web_sessions: Arc<WebSessions>,
}

impl RenderService {
    /// Builds the service; compiles the built-in scenes for `ListScenes` (blocking: call it
    /// off the async runtime).
    pub fn new(config: &ServerConfig, state: Arc<ServerState>) -> Self {
        RenderService {
            limits: Arc::new(config.limits.clone()),
            max_chunk_bytes: config.max_chunk_bytes.max(1),
            stall_timeout: config.stall_timeout,
            session_idle_timeout: config.session_idle_timeout,
            cache: Arc::new(SceneCache::new(config.scene_cache_bytes, config.scene_cache_triangles)),
            slots: Slots::new(config.max_concurrent_renders),
            state,
            scenes: Arc::new(super::catalog::builtin_catalog(&config.limits)),
            web_sessions: Arc::new(WebSessions::new(config.web_session_queue)),
        }
    }

    /// The render slots; `admission` takes them before a request is read.
    pub fn slots(&self) -> Slots {
        self.slots.clone()
    }

    /// Validates the request and compiles its scene, off the async workers (compiling builds
    /// the BVH); a stored scene named by digest is not compiled again.
    async fn prepare(&self, req: RenderRequest, label: &str, peer: &str, rid: u64) -> Result<PreparedJob, Status> {
        if let Some(SceneSource::SceneDigest(digest)) = &req.scene_source {
            let stored = self.stored(digest)?;
            return request::prepare_compiled(&req, &stored.header, Arc::clone(&stored.compiled), &self.limits, label)
                .map_err(|e| {
                    warn!(request = rid, %peer, scene = %Escaped(label), "rejected render: {}", Escaped(&e.to_string()));
                    self.state.metrics.reject(RejectReason::Invalid);
                    Status::invalid_argument(e.to_string())
                });
        }
        let limits = Arc::clone(&self.limits);
        let prep_label = label.to_string();
        tokio::task::spawn_blocking(move || request::prepare(&req, &limits, limits.mesh_root.as_deref(), &prep_label))
            .await
            .map_err(|e| {
                warn!(request = rid, %peer, scene = %Escaped(label), "scene preparation failed: {e}");
                Status::internal("scene preparation failed")
            })?
            .map_err(|e| {
                warn!(request = rid, %peer, scene = %Escaped(label), "rejected render: {}", Escaped(&e.to_string()));
                self.state.metrics.reject(RejectReason::Invalid);
                Status::invalid_argument(e.to_string())
            })
    }
}

impl RenderService {
    /// The stored scene of `digest`: INVALID_ARGUMENT when it is not a digest, FAILED_PRECONDITION
    /// when the store does not have it (the client uploads it again).
    fn stored(&self, digest: &str) -> Result<Arc<StoredScene>, Status> {
        if !scene_cache::is_digest(digest) {
            self.state.metrics.reject(RejectReason::Invalid);
            return Err(Status::invalid_argument(format!(
                "scene_digest: {:?} is not a digest (\"sha256:\" and 64 hex digits)",
                digest.chars().take(80).collect::<String>()
            )));
        }
        self.cache.get(digest).ok_or_else(|| {
            Status::failed_precondition(format!(
                "scene_digest: no scene {digest} on this server (it was never stored or was evicted): upload it with PutScene"
            ))
        })
    }
}

/// What a session call carries besides its message.
struct CallInfo {
    rid: u64,
    peer: String,
    /// Taken by `admission` before the request was read.
    slot: Option<RenderSlot>,
}

impl CallInfo {
    fn of<T>(request: &mut Request<T>) -> CallInfo {
        CallInfo {
            rid: request.extensions().get::<RequestId>().map_or(0, |id| id.0),
            peer: request.remote_addr().map_or_else(|| "unknown".to_string(), |a| a.to_string()),
            slot: request.extensions_mut().remove::<RenderSlot>(),
        }
    }
}

impl RenderService {
    /// The render slot a session holds until it ends: the one `admission` took, or one taken
    /// here; RESOURCE_EXHAUSTED when none is free.
    fn session_slot(&self, slot: Option<RenderSlot>) -> Result<impl Send + 'static, Status> {
        slot.map(|s| s.0).or_else(|| self.slots.try_acquire().map(Arc::new)).ok_or_else(|| {
            self.state.metrics.reject(RejectReason::Busy);
            super::admission::busy(&self.slots)
        })
    }

    /// Prepares a session's first job and starts it; `held` (its slot) lives as long as it.
    async fn open_session(
        &self,
        call: &CallInfo,
        held: impl Send + 'static,
        inbound: Inbound,
        open: RenderRequest,
        session_id: String,
    ) -> Result<session::SessionStream, Status> {
        let label = scene_label(&open);
        let prepared = self.prepare(open.clone(), &label, &call.peer, call.rid).await?;
        let cx = session::SessionContext {
            limits: Arc::clone(&self.limits),
            state: Arc::clone(&self.state),
            max_chunk_bytes: self.max_chunk_bytes,
            stall_timeout: self.stall_timeout,
            idle_timeout: self.session_idle_timeout,
            request_id: call.rid,
            label,
            session_id,
        };
        session::start(cx, held, inbound, open, prepared).await
    }
}

/// The scene of a PutScene call: sent as a message or as a scene file's text.
fn put_scene_source(req: PutSceneRequest) -> Result<crate::proto::Scene, Status> {
    match (req.scene, req.scene_json.is_empty()) {
        (Some(scene), true) => Ok(scene),
        (None, false) => crate::scene::json::parse_scene(&req.scene_json, "scene_json")
            .map_err(|e| Status::invalid_argument(e.to_string())),
        (Some(_), false) => Err(Status::invalid_argument("scene_json: set either scene or scene_json, not both")),
        (None, true) => Err(Status::invalid_argument("scene: is required (or scene_json, a scene file's text)")),
    }
}

/// How logs name a request's scene.
fn scene_label(req: &RenderRequest) -> String {
    match &req.scene_source {
        Some(SceneSource::Builtin(name)) => name.clone(),
        Some(SceneSource::SceneDigest(d)) => d.clone(),
        Some(SceneSource::Scene(_)) | None => "inline".to_string(),
    }
}

fn update(kind: render_update::Kind) -> UpdateResult {
    Ok(RenderUpdate { kind: Some(kind) })
}

#[tonic::async_trait]
impl Renderer for RenderService {
    type RenderStream = ReceiverStream<UpdateResult>;

    async fn render(&self, mut request: Request<RenderRequest>) -> Result<Response<Self::RenderStream>, Status> {
        let peer = request.remote_addr().map_or_else(|| "unknown".to_string(), |a| a.to_string());
        // Every log line of this call carries its id, rejections included.
        let rid = request.extensions().get::<RequestId>().map_or(0, |id| id.0);
        // Taken by `admission` before the request was read; without that layer, taken here.
        let slot = request.extensions_mut().remove::<RenderSlot>();
        let req = request.into_inner();
        let label = scene_label(&req);
        let (outputs, frame_every) = (req.outputs.unwrap_or_default(), req.frame_every.max(1));
        if PixelFormat::try_from(outputs.format).is_err() {
            let msg = format!("outputs.format: unknown pixel format {}", outputs.format);
            warn!(request = rid, %peer, scene = %Escaped(&label), "rejected render: {msg}");
            self.state.metrics.reject(RejectReason::Invalid);
            return Err(Status::invalid_argument(msg));
        }
        let Some(permit) = slot.map(|s| s.0).or_else(|| self.slots.try_acquire().map(Arc::new)) else {
            warn!(request = rid, %peer, scene = %Escaped(&label), "rejected render: server busy");
            self.state.metrics.reject(RejectReason::Busy);
            return Err(super::admission::busy(&self.slots));
        };
        let prepared = self.prepare(req, &label, &peer, rid).await?;
        let sink = WireSink::new(&prepared, outputs, self);
        let job = prepared.job;
        let (tx, rx) = mpsc::channel::<UpdateResult>(CHANNEL_CAPACITY + 1);
        // The channel is new and empty: neither can wait.
        let gone = || Status::cancelled("client went away");
        let final_status = tx.clone().reserve_owned().await.map_err(|_| gone())?;
        tx.send(update(render_update::Kind::Started(sink.started.clone()))).await.map_err(|_| gone())?;
        let mut active = self.state.begin_render();
        let id = active.id();
        let h = &job.halt;
        info!(
            render = id, request = rid, %peer, scene = %Escaped(&label), width = job.width(), height = job.height(),
            method = job.method.name(), seed = job.seed, triangles = job.scene.triangle_count(),
            max_passes = h.max_passes, max_mean_spp = h.max_mean_spp, time_budget = ?h.time_budget,
            target_error = ?h.target_error, bounces = job.bounces, layers = ?sink.started.layers,
            frame_every, "render started"
        );
        // The render thread sends the frames; the supervisor stops it when the client goes away
        // or the shutdown grace period ends, and sends the final status.
        let state = Arc::clone(&self.state);
        tokio::spawn(async move {
            let cancel = CancelToken::new();
            let (render_tx, c) = (tx.clone(), cancel.clone());
            // Resolves to whether the server is draining (else the client went away).
            let stop = async {
                tokio::select! {
                    () = tx.closed() => false,
                    () = state.drained() => true,
                }
            };
            let (result, stopped) = runner::spawn(permit, cancel, stop, move || {
                let t0 = Instant::now();
                let r = runner::run(&job, &c, frame_every, &mut |frame| sink.send(frame, &render_tx));
                (r, t0.elapsed().as_secs_f64())
            })
            .await;
            let drained = stopped == Some(true);
            if let Some(status) = finish(id, &mut active, result, drained) {
                // Queued behind the frames without waiting (its place was reserved), so a
                // stalled client cannot hold this task either.
                final_status.send(Err(status));
            }
        });
        Ok(Response::new(ReceiverStream::new(rx)))
    }

    async fn list_scenes(&self, _request: Request<ListScenesRequest>) -> Result<Response<ListScenesResponse>, Status> {
        Ok(Response::new(ListScenesResponse::clone(&self.scenes)))
    }

    type SessionStream = session::SessionStream;

    async fn session(
        &self,
        mut request: Request<tonic::Streaming<SessionRequest>>,
    ) -> Result<Response<Self::SessionStream>, Status> {
        let mut call = CallInfo::of(&mut request);
        let permit = self.session_slot(call.slot.take())?;
        let mut inbound = request.into_inner();
        let open = session::first_message(&mut inbound, self.session_idle_timeout).await.inspect_err(|s| {
            if s.code() == tonic::Code::InvalidArgument {
                self.state.metrics.reject(RejectReason::Invalid);
            }
        })?;
        let stream = self.open_session(&call, permit, Box::pin(inbound), open, String::new()).await?;
        Ok(Response::new(stream))
    }

    type WatchSessionStream = session::SessionStream;

    async fn watch_session(
        &self,
        mut request: Request<WatchSessionRequest>,
    ) -> Result<Response<Self::WatchSessionStream>, Status> {
        let mut call = CallInfo::of(&mut request);
        let permit = self.session_slot(call.slot.take())?;
        let Some(open) = request.into_inner().open else {
            self.state.metrics.reject(RejectReason::Invalid);
            return Err(Status::invalid_argument("open: is required (the render request that opens the session)"));
        };
        let (id, inbound, registration) = self.web_sessions.open()?;
        let stream = self.open_session(&call, (permit, registration), inbound, open, id).await?;
        Ok(Response::new(stream))
    }

    async fn update_session(
        &self,
        request: Request<UpdateSessionRequest>,
    ) -> Result<Response<UpdateSessionResponse>, Status> {
        let UpdateSessionRequest { session_id, update } = request.into_inner();
        let update = update.ok_or_else(|| Status::invalid_argument("update: is required"))?;
        let number = self.web_sessions.update(&session_id, update)?;
        Ok(Response::new(UpdateSessionResponse { update: number }))
    }

    async fn put_scene(&self, mut request: Request<PutSceneRequest>) -> Result<Response<PutSceneResponse>, Status> {
        let rid = request.extensions().get::<RequestId>().map_or(0, |id| id.0);
        // Compiling is a render's worth of work: it holds a slot (taken by `admission`).
        let _slot = request.extensions_mut().remove::<RenderSlot>();
        // Parsing a scene file's text and hashing a large scene are a compile's kind of work:
        // off the async workers.
        let req = request.into_inner();
        let parsed = tokio::task::spawn_blocking(move || {
            put_scene_source(req).map(|scene| {
                let digest = scene_cache::digest(&scene);
                (scene, digest)
            })
        })
        .await
        .map_err(|_| Status::internal("scene parsing failed"))?;
        let (scene, digest) = parsed.inspect_err(|_| self.state.metrics.reject(RejectReason::Invalid))?;
        let reply = |s: &StoredScene| {
            Response::new(PutSceneResponse { digest: s.digest.clone(), bytes: s.bytes, triangles: s.triangles })
        };
        if let Some(stored) = self.cache.get(&digest) {
            return Ok(reply(&stored));
        }
        let bytes = prost::Message::encoded_len(&scene) as u64;
        let limits = Arc::clone(&self.limits);
        let compiled = tokio::task::spawn_blocking(move || {
            request::compile_scene(&scene, &limits, None).map(|c| (c, request::header(&scene)))
        })
        .await
        .map_err(|_| Status::internal("scene compilation failed"))?;
        let (compiled, header) = compiled.map_err(|e| {
            warn!(request = rid, "rejected scene: {}", Escaped(&e.to_string()));
            self.state.metrics.reject(RejectReason::Invalid);
            Status::invalid_argument(e.to_string())
        })?;
        let triangles = compiled.triangle_count() as u64;
        let stored = StoredScene { digest, header, compiled: Arc::new(compiled), bytes, triangles };
        let stored = self.cache.insert(stored).map_err(Status::resource_exhausted)?;
        info!(request = rid, digest = %stored.digest, bytes, triangles, "scene stored");
        Ok(reply(&stored))
    }
}

type TaskResult = (Result<RunSummary, RunError<SinkError>>, f64);

/// Logs how a render ended and records its outcome; the status to end the stream with, if any.
fn finish(
    id: u64,
    active: &mut super::state::ActiveRender,
    result: Result<TaskResult, tokio::task::JoinError>,
    drained: bool,
) -> Option<Status> {
    let (result, secs) = match result {
        Ok(r) => r,
        Err(e) => {
            warn!(render = id, "render task failed: {e}");
            return Some(Status::internal("render task failed"));
        }
    };
    match result {
        Ok(r) => {
            active.set_outcome(RenderOutcome::Finished);
            info!(
                render = id, passes = r.passes, frames_sent = r.frames_sent, mean_spp = r.mean_spp,
                halt = ?r.halt, seconds = secs, "render finished"
            );
            None
        }
        Err(RunError::Cancelled | RunError::Sink(SinkError::ClientGone)) => {
            active.set_outcome(RenderOutcome::Cancelled);
            info!(render = id, seconds = secs, drained, "render cancelled");
            drained.then(|| Status::unavailable("the server is shutting down"))
        }
        Err(RunError::Sink(SinkError::Stalled(after))) => {
            active.set_outcome(RenderOutcome::Cancelled);
            warn!(
                render = id,
                seconds = secs,
                stall_timeout = after.as_secs_f64(),
                "client stopped reading: render cancelled, slot freed"
            );
            Some(Status::deadline_exceeded(format!(
                "the client accepted no message for {} s (stall timeout): render cancelled",
                after.as_secs_f64()
            )))
        }
        Err(RunError::Sink(SinkError::Status(s))) => {
            warn!(render = id, seconds = secs, "render failed: {}", Escaped(s.message()));
            Some(s)
        }
    }
}

#[derive(Debug)]
enum SinkError {
    ClientGone,
    /// The client accepted no message for this long.
    Stalled(Duration),
    Status(Status),
}

/// Puts a render's frames on the wire: rows of at most `max_chunk_bytes`, then FrameComplete.
struct WireSink {
    started: RenderStarted,
    outputs: OutputSelection,
    /// The job's `component_names`, as announced in `RenderStarted.layers`.
    components: Vec<&'static str>,
    max_chunk_bytes: usize,
    stall_timeout: Duration,
    /// Draining ends the wait for a slow client at once.
    state: Arc<ServerState>,
    /// The server's runtime: the render thread waits for channel space on its timer.
    runtime: tokio::runtime::Handle,
    /// When the render was accepted, when the last frame went out, and its ray count (for
    /// the frame latency and ray metrics).
    accepted: Instant,
    last_frame: std::cell::Cell<Option<Instant>>,
    last_rays: std::cell::Cell<u64>,
}

impl WireSink {
    /// A sink for `job` with the service's chunk size and stall timeout; call it on the runtime.
    fn new(prepared: &PreparedJob, outputs: OutputSelection, service: &RenderService) -> WireSink {
        // Known before rendering, so that `RenderStarted` can announce every layer.
        let components = component_names(&prepared.job);
        let started = wire::render_started(&prepared.job, prepared.header.camera, &outputs, &components);
        WireSink {
            started,
            outputs,
            components,
            max_chunk_bytes: service.max_chunk_bytes,
            stall_timeout: service.stall_timeout,
            state: Arc::clone(&service.state),
            runtime: tokio::runtime::Handle::current(),
            accepted: Instant::now(),
            last_frame: std::cell::Cell::new(None),
            last_rays: std::cell::Cell::new(0),
        }
    }

    /// Queues one message, waiting while the channel is full: at most the stall timeout, and
    /// not at all once the server drains (the client may never read again).
    fn push(&self, tx: &mpsc::Sender<UpdateResult>, kind: render_update::Kind) -> Result<(), SinkError> {
        self.runtime.block_on(async {
            tokio::select! {
                space = tokio::time::timeout(self.stall_timeout, tx.reserve()) => match space {
                    Ok(Ok(permit)) => {
                        permit.send(update(kind));
                        Ok(())
                    }
                    Ok(Err(_)) => Err(SinkError::ClientGone),
                    Err(_) => Err(SinkError::Stalled(self.stall_timeout)),
                },
                () = self.state.drained() => Err(SinkError::ClientGone),
            }
        })
    }

    /// Streams one frame: its chunks, then `FrameComplete`. Blocks while the channel is full.
    fn send(&self, frame: &Frame, tx: &mpsc::Sender<UpdateResult>) -> Result<(), SinkError> {
        let (w, h) = (self.started.width, self.started.height);
        if (frame.width, frame.height) != (w, h) {
            return Err(SinkError::Status(Status::internal(format!(
                "render produced a {}x{} frame for a {w}x{h} image",
                frame.width, frame.height
            ))));
        }
        let (sel, components) = (&self.outputs, self.components.as_slice());
        wire::check_frame(frame, sel, components)
            .map_err(|e| SinkError::Status(Status::internal(format!("render produced {e}"))))?;
        let rows = wire::rows_per_chunk(frame.width, sel, components, self.max_chunk_bytes);
        for (y0, n) in wire::chunk_bands(frame.height, rows) {
            let chunk = wire::encode_rows(frame, sel, components, y0, n);
            self.push(tx, render_update::Kind::Chunk(chunk))?;
        }
        self.push(tx, render_update::Kind::FrameComplete(FrameComplete::from(&frame.stats)))?;
        let now = Instant::now();
        let rays = frame.stats.rays_traced.saturating_sub(self.last_rays.replace(frame.stats.rays_traced));
        let since_previous = self.last_frame.replace(Some(now)).map(|t| (now - t).as_secs_f64());
        self.state.metrics.frame_sent((now - self.accepted).as_secs_f64(), since_previous, rays);
        Ok(())
    }
}

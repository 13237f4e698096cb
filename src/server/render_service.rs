//! The `Renderer` gRPC service: maps requests through `job::prepare`, runs
//! `pipeline::progressive::render` on a blocking thread and streams its frames as chunks.
use super::state::{RenderOutcome, ServerState};
use super::ServerConfig;
use crate::api::request::{self, Limits};
use crate::api::wire::frame_complete;
use crate::pipeline::frame::Frame;
use crate::pipeline::job::{CancelToken, RenderError, RenderJob};
use crate::pipeline::progressive;
use crate::pipeline::registry::component_names;
use crate::proto::{
    render_request::SceneSource, render_update, renderer_server::Renderer, ListScenesRequest, ListScenesResponse,
    OutputSelection, PixelFormat, RenderRequest, RenderStarted, RenderUpdate,
};
use std::sync::Arc;
use std::time::Instant;
use tokio::sync::{mpsc, Semaphore};
use tokio_stream::wrappers::ReceiverStream;
use tonic::{Request, Response, Status};
use tracing::{info, warn};

/// Messages buffered between the render thread and the client: a slow client holds the render
/// back instead of letting frames pile up in memory.
const CHANNEL_CAPACITY: usize = 4;

type UpdateResult = Result<RenderUpdate, Status>;

pub struct RenderService {
    limits: Arc<Limits>,
    max_chunk_bytes: usize,
    max_concurrent_renders: usize,
    permits: Arc<Semaphore>,
    state: Arc<ServerState>,
    scenes: Arc<ListScenesResponse>,
}

impl RenderService {
    /// Builds the service; compiles the built-in scenes for `ListScenes` (blocking: call it
    /// off the async runtime).
    pub fn new(config: &ServerConfig, state: Arc<ServerState>) -> Self {
        let scenes = super::catalog::builtin_catalog(&config.limits);
        let max_concurrent_renders = config.max_concurrent_renders.max(1);
        RenderService {
            limits: Arc::new(config.limits.clone()),
            max_chunk_bytes: config.max_chunk_bytes.max(1),
            max_concurrent_renders,
            permits: Arc::new(Semaphore::new(max_concurrent_renders)),
            state,
            scenes: Arc::new(scenes),
        }
    }
}

fn scene_label(req: &RenderRequest) -> String {
    match &req.scene_source {
        Some(SceneSource::Builtin(name)) => name.clone(),
        Some(SceneSource::Scene(_)) | None => "inline".to_string(),
    }
}

fn update(kind: render_update::Kind) -> UpdateResult {
    Ok(RenderUpdate { kind: Some(kind) })
}

#[tonic::async_trait]
impl Renderer for RenderService {
    type RenderStream = ReceiverStream<UpdateResult>;

    async fn render(&self, request: Request<RenderRequest>) -> Result<Response<Self::RenderStream>, Status> {
        let peer = request.remote_addr().map_or_else(|| "unknown".to_string(), |a| a.to_string());
        let req = request.into_inner();
        let label = scene_label(&req);
        let outputs = req.outputs.unwrap_or_default();
        let frame_every = req.frame_every.max(1);

        if PixelFormat::try_from(outputs.format).is_err() {
            let msg = format!("outputs.format: unknown pixel format {}", outputs.format);
            warn!(%peer, scene = %label, "rejected render: {msg}");
            return Err(Status::invalid_argument(msg));
        }
        let Ok(permit) = Arc::clone(&self.permits).try_acquire_owned() else {
            warn!(%peer, scene = %label, "rejected render: server busy");
            return Err(Status::resource_exhausted(format!(
                "server busy: all {} render slots are in use (max_concurrent_renders)",
                self.max_concurrent_renders
            )));
        };

        // Compiling a scene builds its BVH: keep it off the async workers.
        let limits = Arc::clone(&self.limits);
        let prep_label = label.clone();
        let prepared = tokio::task::spawn_blocking(move || {
            request::prepare(&req, &limits, limits.mesh_root.as_deref(), &prep_label)
        })
        .await
        .map_err(|e| {
            warn!(%peer, scene = %label, "scene preparation failed: {e}");
            Status::internal("scene preparation failed")
        })?
        .map_err(|e| {
            warn!(%peer, scene = %label, "rejected render: {e}");
            Status::invalid_argument(e.to_string())
        })?;
        let job = prepared.job;
        // Known before rendering, so that `RenderStarted` can announce every layer.
        let components = component_names(&job);

        let started = RenderStarted {
            width: job.width(),
            height: job.height(),
            method: job.method.to_proto() as i32,
            seed: job.seed,
            triangles: u32::try_from(job.scene.triangle_count()).unwrap_or(u32::MAX),
            layers: crate::api::wire::layer_names(&outputs, &components),
            format: outputs.format,
        };
        let (tx, rx) = mpsc::channel::<UpdateResult>(CHANNEL_CAPACITY);
        // The channel is new and empty: this cannot wait.
        tx.send(update(render_update::Kind::Started(started.clone())))
            .await
            .map_err(|_| Status::cancelled("client went away"))?;

        let mut active = self.state.begin_render();
        let id = active.id();
        info!(
            render = id, %peer, scene = %label,
            width = job.width(), height = job.height(),
            method = job.method.name(), seed = job.seed, triangles = job.scene.triangle_count(),
            max_passes = job.halt.max_passes, max_mean_spp = job.halt.max_mean_spp,
            time_budget = ?job.halt.time_budget, bounces = job.bounces,
            layers = ?started.layers, format = ?PixelFormat::try_from(outputs.format).unwrap_or(PixelFormat::F32),
            frame_every, "render started"
        );

        let cancel = CancelToken::new();
        let task = RenderTask {
            job,
            outputs,
            components,
            frame_every,
            max_chunk_bytes: self.max_chunk_bytes,
            tx: tx.clone(),
            cancel: cancel.clone(),
        };
        let mut handle = tokio::task::spawn_blocking(move || {
            let _permit = permit;
            let t0 = Instant::now();
            let result = task.run();
            let secs = t0.elapsed().as_secs_f64();
            match &result {
                Ok(r) => {
                    active.set_outcome(RenderOutcome::Finished);
                    info!(
                        render = id, passes = r.passes, frames_sent = r.frames_sent,
                        mean_spp = r.mean_spp, halt = ?r.halt, seconds = secs, "render finished"
                    );
                }
                Err(TaskError::ClientGone) => {
                    active.set_outcome(RenderOutcome::Cancelled);
                    info!(render = id, seconds = secs, "render cancelled by the client");
                }
                Err(TaskError::Status(s)) => {
                    warn!(render = id, seconds = secs, "render failed: {}", s.message());
                }
            }
            // `active` and `_permit` drop here: the render no longer counts or holds memory.
            result.err().and_then(|e| match e {
                TaskError::Status(s) => Some(s),
                TaskError::ClientGone => None,
            })
        });

        // Supervisor: stops the render when the client goes away or the server's shutdown
        // grace period ends, reports a failed render task, and holds the last sender so the
        // stream ends only after that.
        let state = Arc::clone(&self.state);
        tokio::spawn(async move {
            let mut drained = false;
            let outcome = tokio::select! {
                r = &mut handle => r,
                () = tx.closed() => {
                    cancel.cancel();
                    handle.await
                }
                () = state.drained() => {
                    drained = true;
                    cancel.cancel();
                    handle.await
                }
            };
            let status = match outcome {
                Ok(_) if drained => Some(Status::unavailable("the server is shutting down")),
                Ok(status) => status,
                Err(e) => {
                    warn!(render = id, "render task failed: {e}");
                    Some(Status::internal("render task failed"))
                }
            };
            if let Some(status) = status {
                // Fails only when the client is gone already.
                let _ = tx.send(Err(status)).await;
            }
        });

        Ok(Response::new(ReceiverStream::new(rx)))
    }

    async fn list_scenes(&self, _request: Request<ListScenesRequest>) -> Result<Response<ListScenesResponse>, Status> {
        Ok(Response::new(ListScenesResponse::clone(&self.scenes)))
    }
}

/// One render on its blocking thread.
struct RenderTask {
    job: RenderJob,
    outputs: OutputSelection,
    /// The job's `component_names`, as announced in `RenderStarted.layers`.
    components: Vec<&'static str>,
    frame_every: u32,
    max_chunk_bytes: usize,
    tx: mpsc::Sender<UpdateResult>,
    cancel: CancelToken,
}

struct RenderSummary {
    passes: u32,
    frames_sent: u32,
    mean_spp: f64,
    halt: crate::pipeline::frame::HaltReason,
}

enum TaskError {
    ClientGone,
    Status(Status),
}

impl RenderTask {
    fn run(self) -> Result<RenderSummary, TaskError> {
        let mut frames_sent = 0u32;
        let mut failure: Option<TaskError> = None;
        let mut on_frame = |frame: &Frame| -> bool {
            let stats = &frame.stats;
            if !stats.is_final && !(stats.pass + 1).is_multiple_of(self.frame_every) {
                return true;
            }
            match self.send_frame(frame) {
                Ok(()) => {
                    frames_sent += 1;
                    true
                }
                Err(e) => {
                    failure = Some(e);
                    false
                }
            }
        };
        let result = progressive::render(&self.job, &self.cancel, &mut on_frame);
        if let Some(e) = failure {
            return Err(e);
        }
        match result {
            Ok(stats) => Ok(RenderSummary {
                passes: stats.pass + 1,
                frames_sent,
                mean_spp: stats.mean_spp,
                halt: stats.halt_reason,
            }),
            Err(RenderError::Cancelled) if self.cancel.is_cancelled() || self.tx.is_closed() => {
                Err(TaskError::ClientGone)
            }
            Err(e) => Err(TaskError::Status(Status::internal(format!("render stopped: {e}")))),
        }
    }

    /// Streams one frame: its chunks, then `FrameComplete`. Blocks while the channel is full.
    fn send_frame(&self, frame: &Frame) -> Result<(), TaskError> {
        let (w, h) = (self.job.width(), self.job.height());
        if (frame.width, frame.height) != (w, h) {
            return Err(TaskError::Status(Status::internal(format!(
                "render produced a {}x{} frame for a {w}x{h} image",
                frame.width, frame.height
            ))));
        }
        let (sel, components) = (&self.outputs, self.components.as_slice());
        crate::api::wire::check_frame(frame, sel, components)
            .map_err(|e| TaskError::Status(Status::internal(format!("render produced {e}"))))?;
        let rows = crate::api::wire::rows_per_chunk(frame.width, sel, components, self.max_chunk_bytes);
        for (y0, n) in crate::api::wire::chunk_bands(frame.height, rows) {
            let chunk = crate::api::wire::encode_rows(frame, sel, components, y0, n);
            self.tx.blocking_send(update(render_update::Kind::Chunk(chunk))).map_err(|_| TaskError::ClientGone)?;
        }
        let complete = frame_complete(&frame.stats);
        self.tx.blocking_send(update(render_update::Kind::FrameComplete(complete))).map_err(|_| TaskError::ClientGone)
    }
}

//! The `Session` call: one compiled scene, rendered again for every accepted change (view,
//! settings, outputs, pause, resume; material and light edits, which share or refit its BVH)
//! without compiling it again. Three tasks share a session:
//! - control reads the client's messages, validates each change against the compiled scene,
//!   queues its acknowledgement (or an in-band error) and publishes the new job;
//! - the render loop renders the newest job, cancelling the running render (within a row of
//!   work) when a newer one is published, and leaves each frame in a one-frame mailbox;
//! - the sender is the only writer to the client: acknowledgements first, then the mailbox's
//!   frame, checking between chunks that no newer change has been acknowledged.
//!
//! A slow client therefore gets the newest frame and skips the others (counted as dropped):
//! memory per session is one frame being sent and one waiting.
use super::log_text::Escaped;
use super::state::{RenderOutcome, ServerState};
use crate::api::request::{self, PreparedJob};
use crate::api::wire;
use crate::pipeline::frame::Frame;
use crate::pipeline::job::CancelToken;
use crate::pipeline::registry::component_names;
use crate::proto::{
    session_event, session_request, FrameComplete, OutputSelection, RenderRequest, RenderStarted, SessionAck,
    SessionError, SessionEvent, SessionRequest, SessionUpdate,
};
use crate::runner;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::{mpsc, watch, Notify};
use tokio_stream::wrappers::ReceiverStream;
use tokio_stream::StreamExt;
use tonic::{Status, Streaming};
use tracing::info;

pub type EventResult = Result<SessionEvent, Status>;
pub type SessionStream = ReceiverStream<EventResult>;
/// A session's changes: a `Session` call's request stream, or a `WatchSession` session's queue
/// of `UpdateSession` changes (`web_sessions`).
pub type Inbound = std::pin::Pin<Box<dyn tokio_stream::Stream<Item = Result<SessionRequest, Status>> + Send>>;

/// Events buffered towards the client (plus one place reserved for the final status).
const EVENT_CAPACITY: usize = 4;
/// Acknowledgements and errors waiting for the sender; a client that sends changes much
/// faster than it reads is slowed down here.
const CONTROL_CAPACITY: usize = 64;

/// Most pixels of a quick first frame: the divider is the smallest power of two that brings
/// the image under it (320x240 previews at 80x60).
const PREVIEW_PIXELS: u64 = 16_384;

/// A render of one generation: the job, and what the wire needs to send its frames.
struct Pass {
    prepared: PreparedJob,
    outputs: OutputSelection,
    components: Vec<&'static str>,
    started: RenderStarted,
}

impl Pass {
    fn new(prepared: PreparedJob, outputs: OutputSelection) -> Pass {
        let job = &prepared.job;
        let components = component_names(job);
        let started = wire::render_started(job, prepared.header.camera, &outputs, &components);
        Pass { prepared, outputs, components, started }
    }
}

/// What a generation renders: an optional quick preview, then its job.
struct GenerationJob {
    generation: u64,
    /// The divider and render of the reduced-resolution first frame, when the image is large
    /// enough to need one.
    preview: Option<(u32, Pass)>,
    main: Pass,
    frame_every: u32,
}

impl GenerationJob {
    /// `req` must be the request `prepared` was made from; the preview is prepared from it on
    /// the same compiled scene.
    fn new(generation: u64, prepared: PreparedJob, req: &RenderRequest, limits: &request::Limits) -> GenerationJob {
        let outputs = req.outputs.unwrap_or_default();
        let preview = preview_divider(prepared.job.width(), prepared.job.height()).and_then(|d| {
            let job = &prepared.job;
            let mut small = req.clone();
            small.width = (job.width() / d).max(1);
            small.height = (job.height() / d).max(1);
            let settings = small.settings.get_or_insert_with(Default::default);
            settings.method = crate::proto::Method::Uniform as i32;
            (settings.max_passes, settings.max_mean_spp, settings.time_budget_seconds, settings.target_error) =
                (1, 0.0, 0.0, 0.0);
            settings.initial_spp = 1;
            let p = request::prepare_compiled(&small, &prepared.header, Arc::clone(&job.scene), limits, "preview");
            // Only colour: a preview is for looking at, its maps would mean nothing.
            let colour = OutputSelection { color: true, format: outputs.format, ..Default::default() };
            p.ok().map(|p| (d, Pass::new(p, colour)))
        });
        GenerationJob { generation, preview, main: Pass::new(prepared, outputs), frame_every: req.frame_every.max(1) }
    }
}

/// The preview divider of a `width` x `height` image: None when it is small already.
fn preview_divider(width: u32, height: u32) -> Option<u32> {
    let pixels = u64::from(width) * u64::from(height);
    let mut d = 1u32;
    while pixels / u64::from(d * d) > PREVIEW_PIXELS && d < 64 {
        d *= 2;
    }
    (d > 1).then_some(d)
}

/// What control tells the sender.
enum Control {
    Ack { update: u64, generation: u64 },
    Error { update: u64, generation: u64, field: String, message: String },
}

/// A frame, the generation it belongs to, and whether it is the preview.
type JobFrame = (Arc<GenerationJob>, bool, Frame);

/// The one-frame mailbox between the render loop and the sender: the waiting frame, and the
/// frames dropped so far.
#[derive(Default)]
struct Mailbox {
    frame: Mutex<(Option<JobFrame>, u64)>,
    ready: Notify,
}

impl Mailbox {
    /// Leaves `frame` for the sender; a frame still waiting is replaced and counted as dropped.
    fn put(&self, job: &Arc<GenerationJob>, preview: bool, frame: &Frame) {
        let mut frame = frame.clone();
        // Only full-resolution frames can be final.
        frame.stats.is_final &= !preview;
        let mut slot = self.frame.lock().unwrap_or_else(|p| p.into_inner());
        if slot.0.replace((Arc::clone(job), preview, frame)).is_some() {
            slot.1 += 1;
        }
        drop(slot);
        self.ready.notify_one();
    }

    /// The waiting frame, if any, and the frames dropped so far.
    fn take(&self) -> (Option<JobFrame>, u64) {
        let mut slot = self.frame.lock().unwrap_or_else(|p| p.into_inner());
        (slot.0.take(), slot.1)
    }

    fn count_dropped(&self) {
        self.frame.lock().unwrap_or_else(|p| p.into_inner()).1 += 1;
    }
}

/// Why a session ended.
enum Ending {
    /// The client closed its side.
    ClientDone,
    ClientGone,
    Idle(Duration),
    Stalled(Duration),
    Drained,
}

/// The first message of a session, which must open it.
pub async fn first_message(inbound: &mut Streaming<SessionRequest>, idle: Duration) -> Result<RenderRequest, Status> {
    let first = tokio::time::timeout(idle, inbound.message())
        .await
        .map_err(|_| Status::deadline_exceeded("no open message within the session idle timeout"))??;
    match first {
        Some(SessionRequest { kind: Some(session_request::Kind::Open(open)) }) => Ok(open),
        _ => Err(Status::invalid_argument("open: the first message of a session must open it (SessionRequest.open)")),
    }
}

/// What a session needs of the server.
pub struct SessionContext {
    pub limits: Arc<request::Limits>,
    pub state: Arc<ServerState>,
    pub max_chunk_bytes: usize,
    pub stall_timeout: Duration,
    pub idle_timeout: Duration,
    /// The call's id and scene label, for logs.
    pub request_id: u64,
    pub label: String,
    /// The id `UpdateSession` names, sent with the first event; empty for a `Session` call.
    pub session_id: String,
}

/// Starts an opened session on its prepared first job; `slot` (a render slot) is held until
/// the session ends.
pub async fn start(
    cx: SessionContext,
    slot: impl Send + 'static,
    inbound: Inbound,
    open: RenderRequest,
    prepared: PreparedJob,
) -> Result<SessionStream, Status> {
    let (rid, label) = (cx.request_id, cx.label.clone());
    let scene = SessionScene {
        header: prepared.header.clone(),
        compiled: Arc::clone(&prepared.job.scene),
        label: label.clone(),
        base: RenderRequest { scene_source: None, ..open.clone() },
    };
    let first_job = Arc::new(GenerationJob::new(1, prepared, &open, &cx.limits));

    let (out_tx, out_rx) = mpsc::channel::<EventResult>(EVENT_CAPACITY + 1);
    let final_status = out_tx.clone().reserve_owned().await.map_err(|_| Status::cancelled("client went away"))?;
    let (ctrl_tx, ctrl_rx) = mpsc::channel::<Control>(CONTROL_CAPACITY);
    let _ = ctrl_tx.send(Control::Ack { update: 1, generation: 1 }).await;
    let (job_tx, job_rx) = watch::channel(Some(Arc::clone(&first_job)));
    let mailbox = Arc::new(Mailbox::default());
    let state = Arc::clone(&cx.state);
    let session_guard = state.metrics.begin_session();
    info!(request = rid, scene = %Escaped(&label), "session opened");

    let (limits, idle) = (cx.limits, cx.idle_timeout);
    let sender = Sender {
        out: out_tx,
        max_chunk_bytes: cx.max_chunk_bytes,
        stall_timeout: cx.stall_timeout,
        state: Arc::clone(&state),
        clock: Mutex::new(FrameClock::new()),
        session_id: cx.session_id,
    };
    let render = tokio::spawn(render_loop(job_rx, Arc::clone(&mailbox), Arc::clone(&state)));
    tokio::spawn(async move {
        // The slot and the active-session count last as long as the session.
        let _held = (slot, session_guard);
        let control = control(inbound, scene, limits, job_tx, ctrl_tx, idle);
        let ending = tokio::select! {
            e = control => e,
            // The client dropped the event stream (a WatchSession client has no other side
            // to close), even while nothing is being sent.
            () = sender.out.closed() => Ending::ClientGone,
            e = sender.run(ctrl_rx, &mailbox) => e,
            () = state.drained() => Ending::Drained,
        };
        // The job channel is closed now (control is gone): the render loop stops its render.
        let _ = tokio::time::timeout(Duration::from_secs(10), render).await;
        let status = match ending {
            Ending::ClientDone | Ending::ClientGone => None,
            Ending::Idle(d) => Some(Status::deadline_exceeded(format!(
                "session idle: no message for {} s (session idle timeout)",
                d.as_secs_f64()
            ))),
            Ending::Stalled(d) => Some(Status::deadline_exceeded(format!(
                "the client accepted no message for {} s (stall timeout): session ended",
                d.as_secs_f64()
            ))),
            Ending::Drained => Some(Status::unavailable(super::shutdown::DRAINED_MESSAGE)),
        };
        info!(request = rid, status = ?status.as_ref().map(|s| s.code()), "session ended");
        if let Some(status) = status {
            final_status.send(Err(status));
        }
    });
    Ok(ReceiverStream::new(out_rx))
}

/// The compiled scene of a session and the request it was opened with (the base that updates
/// change).
struct SessionScene {
    header: crate::proto::Scene,
    compiled: Arc<crate::render::scene::Scene>,
    label: String,
    base: RenderRequest,
}

/// Applies a change to the session's request: set fields replace the current ones.
fn apply_update(current: &RenderRequest, u: &SessionUpdate) -> RenderRequest {
    let mut next = current.clone();
    if let Some(c) = &u.camera {
        let cam = next.camera.get_or_insert_with(Default::default);
        if c.position.is_some() {
            cam.position = c.position;
        }
        if c.look_at.is_some() {
            cam.look_at = c.look_at;
        }
        if c.up.is_some() {
            cam.up = c.up;
        }
        if c.vertical_fov_deg.is_some() {
            cam.vertical_fov_deg = c.vertical_fov_deg;
        }
    }
    if u.width != 0 {
        next.width = u.width;
    }
    if u.height != 0 {
        next.height = u.height;
    }
    if u.settings.is_some() {
        next.settings = u.settings;
    }
    if u.outputs.is_some() {
        next.outputs = u.outputs;
    }
    next
}

/// Reads the client's changes until it closes its side, goes away or idles.
async fn control(
    mut inbound: Inbound,
    mut scene: SessionScene,
    limits: Arc<request::Limits>,
    jobs: watch::Sender<Option<Arc<GenerationJob>>>,
    ctrl: mpsc::Sender<Control>,
    idle: Duration,
) -> Ending {
    let (mut generation, mut update, mut paused) = (1u64, 1u64, false);
    loop {
        let message = match tokio::time::timeout(idle, inbound.next()).await {
            Err(_) => return Ending::Idle(idle),
            Ok(None) => return Ending::ClientDone,
            Ok(Some(Err(_))) => return Ending::ClientGone,
            Ok(Some(Ok(m))) => m,
        };
        update += 1;
        let refuse = |field: &str, message: String| Control::Error { update, generation, field: field.into(), message };
        let change = match message.kind {
            Some(session_request::Kind::Update(u)) => u,
            Some(session_request::Kind::Open(_)) => {
                let _ = ctrl.send(refuse("open", "the session is open already".into())).await;
                continue;
            }
            None => {
                let _ = ctrl.send(refuse("kind", "a message must hold an update".into())).await;
                continue;
            }
        };
        let next = apply_update(&scene.base, &change);
        // Material and light edits make a new compiled scene on the same (or a refitted) BVH:
        // a refit copies the geometry, so it runs off the async workers.
        let edited = match change.edit.clone() {
            None => Ok((scene.header.clone(), Arc::clone(&scene.compiled))),
            Some(edit) => {
                let (header, compiled) = (scene.header.clone(), Arc::clone(&scene.compiled));
                let scene_limits = request::scene_limits(&limits);
                let apply = move || crate::scene::edit::apply(&header, &compiled, &edit, &scene_limits);
                match tokio::task::spawn_blocking(apply).await {
                    Ok(result) => result.map(|(h, c)| (h, Arc::new(c))),
                    Err(_) => Err(crate::scene::FieldError { field: "edit".into(), message: "the edit failed".into() }),
                }
            }
        };
        let prepared = edited.and_then(|(header, compiled)| {
            let p = request::prepare_compiled(&next, &header, Arc::clone(&compiled), &limits, &scene.label)?;
            Ok((header, compiled, p))
        });
        let prepared = match prepared {
            Ok((header, compiled, p)) => {
                (scene.header, scene.compiled) = (header, compiled);
                p
            }
            Err(e) => {
                let _ = ctrl.send(refuse(&e.field, e.message)).await;
                continue;
            }
        };
        generation += 1;
        scene.base = next;
        paused = (paused || change.pause) && !change.resume;
        // The acknowledgement is queued before the job is published, so that it precedes every
        // frame of the new generation.
        if ctrl.send(Control::Ack { update, generation }).await.is_err() {
            return Ending::ClientGone;
        }
        let job = (!paused).then(|| Arc::new(GenerationJob::new(generation, prepared, &scene.base, &limits)));
        if jobs.send(job).is_err() {
            return Ending::ClientGone;
        }
    }
}

/// Renders the newest published job; a newer one cancels the running render.
async fn render_loop(
    mut jobs: watch::Receiver<Option<Arc<GenerationJob>>>,
    mailbox: Arc<Mailbox>,
    state: Arc<ServerState>,
) {
    loop {
        let current = jobs.borrow_and_update().clone();
        if let Some(gen_job) = current {
            let cancel = CancelToken::new();
            let (c, m, g) = (cancel.clone(), Arc::clone(&mailbox), Arc::clone(&gen_job));
            let mut active = state.begin_render();
            let (result, changed) = runner::spawn((), cancel, jobs.changed(), move || {
                if let Some((_, preview)) = &g.preview {
                    runner::run(&preview.prepared.job, &c, 1, &mut |frame| {
                        m.put(&g, true, frame);
                        Ok::<(), ()>(())
                    })?;
                }
                runner::run(&g.main.prepared.job, &c, g.frame_every, &mut |frame| {
                    m.put(&g, false, frame);
                    Ok::<(), ()>(())
                })
            })
            .await;
            active.set_outcome(match result {
                Ok(Ok(_)) => RenderOutcome::Finished,
                Ok(Err(_)) => RenderOutcome::Cancelled,
                Err(_) => RenderOutcome::Failed,
            });
            match changed {
                Some(Ok(())) => continue,
                Some(Err(_)) => return,
                None => {}
            }
        }
        // Finished or paused: wait for the next change.
        if jobs.changed().await.is_err() {
            return;
        }
    }
}

/// The only writer of the session's events.
struct Sender {
    out: mpsc::Sender<EventResult>,
    max_chunk_bytes: usize,
    stall_timeout: Duration,
    /// The server's metrics, and what they need to time a session's frames.
    state: Arc<ServerState>,
    clock: Mutex<FrameClock>,
    session_id: String,
}

/// When the newest change was acknowledged, when its last frame went out, and the rays of the
/// render (preview or main) that frame came from.
struct FrameClock {
    generation: u64,
    preview: bool,
    accepted: std::time::Instant,
    last: Option<std::time::Instant>,
    rays: u64,
}

impl FrameClock {
    fn new() -> FrameClock {
        FrameClock { generation: 0, preview: false, accepted: std::time::Instant::now(), last: None, rays: 0 }
    }
}

fn event(generation: u64, kind: session_event::Kind) -> SessionEvent {
    SessionEvent { generation, kind: Some(kind), ..Default::default() }
}

impl Sender {
    async fn send(&self, e: SessionEvent) -> Result<(), Ending> {
        match tokio::time::timeout(self.stall_timeout, self.out.send(Ok(e))).await {
            Ok(Ok(())) => Ok(()),
            Ok(Err(_)) => Err(Ending::ClientGone),
            Err(_) => Err(Ending::Stalled(self.stall_timeout)),
        }
    }

    /// Sends a queued acknowledgement or error; returns the generation acknowledged.
    async fn control(&self, c: Control, acked: &mut u64) -> Result<(), Ending> {
        match c {
            Control::Ack { update, generation } => {
                *acked = generation;
                self.clock.lock().unwrap_or_else(|p| p.into_inner()).accepted = std::time::Instant::now();
                let mut e = event(generation, session_event::Kind::Ack(SessionAck { update }));
                if update == 1 {
                    e.session_id.clone_from(&self.session_id);
                }
                self.send(e).await
            }
            Control::Error { update, generation, field, message } => {
                let e = SessionError { update, field, message };
                self.send(event(generation, session_event::Kind::Error(e))).await
            }
        }
    }

    async fn run(&self, mut ctrl: mpsc::Receiver<Control>, mailbox: &Mailbox) -> Ending {
        // The generation and preview flag whose `started` was sent last.
        let (mut acked, mut announced) = (0u64, (0u64, false));
        loop {
            let result = tokio::select! {
                biased;
                c = ctrl.recv() => match c {
                    Some(c) => self.control(c, &mut acked).await,
                    None => return Ending::ClientDone,
                },
                () = mailbox.ready.notified() => {
                    self.frame(&mut ctrl, mailbox, &mut acked, &mut announced).await
                }
            };
            if let Err(ending) = result {
                return ending;
            }
        }
    }

    /// Sends the mailbox's frame, unless a newer change is acknowledged before or while it goes.
    async fn frame(
        &self,
        ctrl: &mut mpsc::Receiver<Control>,
        mailbox: &Mailbox,
        acked: &mut u64,
        announced: &mut (u64, bool),
    ) -> Result<(), Ending> {
        let (Some((job, preview, frame)), dropped) = mailbox.take() else { return Ok(()) };
        let g = job.generation;
        let (divider, pass) = match (&job.preview, preview) {
            (Some((d, p)), true) => (*d, p),
            _ => (0, &job.main),
        };
        if wire::check_frame(&frame, &pass.outputs, &pass.components).is_err() || g < *acked {
            mailbox.count_dropped();
            return Ok(());
        }
        if *announced != (g, preview) {
            let mut e = event(g, session_event::Kind::Started(pass.started.clone()));
            e.preview_divider = divider;
            self.send(e).await?;
            *announced = (g, preview);
        }
        let rows = wire::rows_per_chunk(frame.width, &pass.outputs, &pass.components, self.max_chunk_bytes);
        for (y0, n) in wire::chunk_bands(frame.height, rows) {
            // Acknowledgements go first; a frame they make stale stops here.
            while let Ok(c) = ctrl.try_recv() {
                self.control(c, acked).await?;
            }
            if g < *acked {
                mailbox.count_dropped();
                return Ok(());
            }
            let chunk = wire::encode_rows(&frame, &pass.outputs, &pass.components, y0, n);
            self.send(event(g, session_event::Kind::Chunk(chunk))).await?;
        }
        let complete = FrameComplete::from(&frame.stats);
        let mut e = event(g, session_event::Kind::FrameComplete(complete));
        e.frames_dropped = dropped;
        e.preview_divider = divider;
        self.send(e).await?;
        self.count(g, preview, &frame);
        Ok(())
    }

    /// Records a frame sent in the server's metrics: the first of a generation as the latency
    /// from its acknowledgement, later ones as intervals; the rays since the previous frame.
    fn count(&self, generation: u64, preview: bool, frame: &Frame) {
        let now = std::time::Instant::now();
        let mut c = self.clock.lock().unwrap_or_else(|p| p.into_inner());
        let first = c.generation != generation;
        if first {
            (c.generation, c.last) = (generation, None);
        }
        if first || c.preview != preview {
            (c.preview, c.rays) = (preview, 0);
        }
        let rays = frame.stats.rays_traced.saturating_sub(c.rays);
        c.rays = frame.stats.rays_traced;
        let since_previous = c.last.replace(now).map(|t| (now - t).as_secs_f64());
        self.state.metrics.frame_sent((now - c.accepted).as_secs_f64(), since_previous, rays);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::{CameraOverride, RenderSettings, Vec3};

    #[test]
    fn updates_replace_only_what_they_set() {
        let base = RenderRequest {
            width: 32,
            height: 24,
            camera: Some(CameraOverride { vertical_fov_deg: Some(40.0), ..Default::default() }),
            settings: Some(RenderSettings { max_passes: 3, ..Default::default() }),
            ..Default::default()
        };
        let u = SessionUpdate {
            camera: Some(CameraOverride { position: Some(Vec3 { x: 1.0, y: 2.0, z: 3.0 }), ..Default::default() }),
            height: 30,
            ..Default::default()
        };
        let next = apply_update(&base, &u);
        assert_eq!((next.width, next.height), (32, 30));
        let cam = next.camera.unwrap();
        assert_eq!(cam.vertical_fov_deg, Some(40.0));
        assert_eq!(cam.position, Some(Vec3 { x: 1.0, y: 2.0, z: 3.0 }));
        assert_eq!(next.settings.unwrap().max_passes, 3);
    }

    #[test]
    fn a_waiting_frame_replaced_counts_as_dropped() {
        let mailbox = Mailbox::default();
        let (frame, job) = (Frame::default(), test_job());
        mailbox.put(&job, false, &frame);
        mailbox.put(&job, false, &frame);
        mailbox.put(&job, false, &frame);
        let (taken, dropped) = mailbox.take();
        assert!(taken.is_some());
        assert_eq!(dropped, 2);
        assert!(mailbox.take().0.is_none());
    }

    fn test_job() -> Arc<GenerationJob> {
        let req = RenderRequest {
            scene_source: Some(crate::proto::render_request::SceneSource::Builtin("cornell".into())),
            width: 8,
            height: 6,
            ..Default::default()
        };
        let limits = request::Limits::default();
        let prepared = request::prepare(&req, &limits, None, "cornell").unwrap();
        Arc::new(GenerationJob::new(1, prepared, &req, &limits))
    }

    #[test]
    fn previews_stay_under_their_pixel_budget() {
        assert_eq!(preview_divider(64, 48), None);
        assert_eq!(preview_divider(320, 240), Some(4));
        assert_eq!(preview_divider(1920, 1080), Some(16));
        for (w, h) in [(128, 128), (129, 128), (4096, 4096), (10_000, 1)] {
            let d = preview_divider(w, h).unwrap_or(1);
            assert!(u64::from(w) * u64::from(h) / u64::from(d * d) <= PREVIEW_PIXELS, "{w}x{h}: {d}");
        }
    }
}

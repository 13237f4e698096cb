//! Editing sessions and stored scenes against a real server on 127.0.0.1: open, orbit, pause,
//! in-band errors, no frame of an older generation after an acknowledgement, a slow reader
//! skipping frames, cancellation, idle timeout, slots; scenes stored by digest.
mod common;

use common::*;
use std::time::Duration;
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::Code;
use wedge::pipeline::frame::Frame;
use wedge::proto::{
    render_request::SceneSource, render_update, session_event::Kind, session_request, CameraOverride, LightEdit,
    PutSceneRequest, RenderRequest, RenderSettings, RenderUpdate, SceneEdit, SessionEvent, SessionRequest,
    SessionUpdate, Vec3,
};
use wedge::server::{FrameAssembler, ServerConfig};

struct Session {
    tx: mpsc::Sender<SessionRequest>,
    events: tonic::Streaming<SessionEvent>,
    /// Every frame event goes through it as it arrives (`next`), whoever reads the event, so
    /// that it never sees a frame's chunks without the render's start.
    asm: FrameAssembler,
    /// The frame the last event completed.
    completed: Option<Frame>,
}

impl Session {
    async fn open(server: &TestServer, req: RenderRequest) -> Result<Session, tonic::Status> {
        let (tx, rx) = mpsc::channel(16);
        tx.send(SessionRequest { kind: Some(session_request::Kind::Open(req)) }).await.unwrap();
        let events = server.client().await.session(ReceiverStream::new(rx)).await?.into_inner();
        Ok(Session { tx, events, asm: FrameAssembler::new(), completed: None })
    }

    async fn update(&self, u: SessionUpdate) {
        self.tx.send(SessionRequest { kind: Some(session_request::Kind::Update(u)) }).await.expect("session open");
    }

    async fn next(&mut self) -> Result<Option<SessionEvent>, tonic::Status> {
        let e = within(60, "a session event", self.events.message()).await?;
        self.completed = e.as_ref().and_then(|e| self.assemble(e));
        Ok(e)
    }

    /// Feeds a frame event to the assembler; the frame it completes, if any.
    fn assemble(&mut self, e: &SessionEvent) -> Option<Frame> {
        let kind = match e.kind.clone().expect("an event kind") {
            Kind::Started(s) => {
                self.asm = FrameAssembler::new();
                render_update::Kind::Started(s)
            }
            Kind::Chunk(c) => render_update::Kind::Chunk(c),
            Kind::FrameComplete(f) => render_update::Kind::FrameComplete(f),
            Kind::Ack(_) | Kind::Error(_) => return None,
        };
        self.asm.push(RenderUpdate { kind: Some(kind) }).expect("well-formed")
    }

    /// Events until the final frame of `generation`; the frames (each with its generation) and
    /// every event seen.
    async fn until_final(&mut self, generation: u64) -> (Vec<(u64, Frame)>, Vec<SessionEvent>) {
        let (mut frames, mut seen) = (Vec::new(), Vec::new());
        loop {
            let e = self.next().await.expect("session ok").expect("session open");
            seen.push(e.clone());
            if let Some(frame) = self.completed.take() {
                let is_final = frame.stats.is_final;
                frames.push((e.generation, frame));
                if is_final && e.generation == generation {
                    return (frames, seen);
                }
            }
        }
    }
}

fn open_req(passes: u32, seed: u64) -> RenderRequest {
    let mut req = cornell(24, 18, passes, seed);
    req.frame_every = 0;
    req
}

fn moved_camera() -> CameraOverride {
    CameraOverride { position: Some(Vec3 { x: 200.0, y: 300.0, z: -700.0 }), ..Default::default() }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_camera_change_renders_the_new_view_exactly_as_a_fresh_render() {
    let server = TestServer::start().await;
    let mut s = Session::open(&server, open_req(2, 7)).await.expect("session opens");
    let (first, _) = s.until_final(1).await;
    s.update(SessionUpdate { camera: Some(moved_camera()), ..Default::default() }).await;
    let (frames, seen) = s.until_final(2).await;

    // The acknowledgement comes first, and nothing of generation 1 follows it.
    let ack = seen.iter().position(|e| matches!(e.kind, Some(Kind::Ack(_)))).expect("an ack");
    assert_eq!(seen[ack].generation, 2);
    assert!(matches!(seen[ack].kind, Some(Kind::Ack(ref a)) if a.update == 2));
    assert!(seen[ack..].iter().all(|e| e.generation >= 2), "a generation-1 event after the ack");
    let last = &frames.last().unwrap().1;
    assert_ne!(color_bits(last), color_bits(&first.last().unwrap().1), "the view changed");

    // The same request as a plain Render: bit-identical.
    let mut fresh = open_req(2, 7);
    fresh.camera = Some(moved_camera());
    let expected = collect(&mut server.client().await, fresh).await.expect("render");
    assert_eq!(color_bits(last), color_bits(expected.frames.last().unwrap()));
    assert_eq!(server.state.metrics.active_sessions(), 1);
    // Session frames count in the metrics: a first frame for each of the two generations, and
    // the plain render's.
    let text = server.state.metrics.encode();
    let first_frames = text.lines().find_map(|l| l.strip_prefix("wedge_first_frame_seconds_count "));
    assert_eq!(first_frames, Some("3"), "{text}");
    drop(s);
    assert!(wait_until(Duration::from_secs(30), || server.state.metrics.active_sessions() == 0).await);
}

/// Cornell's red wall made glossy, and its light moved 60 units along x at a third of its
/// radiance: the edit, and the scene it describes.
fn edited_cornell() -> (SceneEdit, wedge::proto::Scene) {
    let mut scene = wedge::scene::builtin::get("cornell").expect("built-in cornell");
    let json = r#"{"materials": [{"name": "red", "glossy": {"diffuse": {"constant": {"r": 0.4, "g": 0.05, "b": 0.05}},
        "specular": {"constant": {"r": 0.5, "g": 0.5, "b": 0.5}}, "exponent": {"constant": 300}}}]}"#;
    let red = wedge::scene::json::parse_scene(json, "edit").unwrap().materials.remove(0);
    let mut light = scene.lights[0].clone();
    if let Some(wedge::proto::light::Kind::Rect(r)) = light.kind.as_mut() {
        r.corner.as_mut().unwrap().x -= 60.0;
        r.radiance = r.radiance.map(|c| wedge::proto::Rgb { r: c.r / 3.0, g: c.g / 3.0, b: c.b / 3.0 });
    }
    let i = scene.materials.iter().position(|m| m.name == "red").unwrap();
    scene.materials[i] = red.clone();
    scene.lights[0] = light.clone();
    let edit = SceneEdit { materials: vec![red], lights: vec![LightEdit { index: 0, light: Some(light) }] };
    (edit, scene)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_material_and_light_edit_renders_exactly_as_a_fresh_render_of_the_edited_scene() {
    let server = TestServer::start().await;
    let mut s = Session::open(&server, open_req(2, 5)).await.expect("session opens");
    let (first, _) = s.until_final(1).await;
    let (edit, edited) = edited_cornell();
    s.update(SessionUpdate { edit: Some(edit), ..Default::default() }).await;
    let (frames, seen) = s.until_final(2).await;
    let ack = seen.iter().position(|e| matches!(e.kind, Some(Kind::Ack(_)))).expect("an ack");
    assert!(seen[ack..].iter().all(|e| e.generation >= 2), "a generation-1 event after the ack");
    let last = &frames.last().unwrap().1;
    assert_ne!(color_bits(last), color_bits(&first.last().unwrap().1), "the edit shows");

    let mut fresh = open_req(2, 5);
    fresh.scene_source = Some(SceneSource::Scene(edited));
    let expected = collect(&mut server.client().await, fresh).await.expect("render");
    assert_eq!(color_bits(last), color_bits(expected.frames.last().unwrap()));

    // A bad edit is refused in band, naming its field, and the next one still applies.
    let mut bad = edited_cornell().0;
    bad.materials[0].name = "chrome".into();
    s.update(SessionUpdate { edit: Some(bad), ..Default::default() }).await;
    let e = s.next().await.unwrap().unwrap();
    let Some(Kind::Error(err)) = e.kind else { panic!("expected an error, got {e:?}") };
    assert_eq!((e.generation, err.field.as_str()), (2, "edit.materials[0].name"), "{err:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bad_change_is_refused_in_band_and_the_session_goes_on() {
    let server = TestServer::start().await;
    let mut s = Session::open(&server, open_req(1, 1)).await.expect("session opens");
    s.until_final(1).await;
    let bad = CameraOverride { vertical_fov_deg: Some(200.0), ..Default::default() };
    s.update(SessionUpdate { camera: Some(bad), ..Default::default() }).await;
    let e = s.next().await.unwrap().unwrap();
    let Some(Kind::Error(err)) = e.kind else { panic!("expected an error, got {e:?}") };
    assert_eq!((e.generation, err.update), (1, 2));
    assert_eq!(err.field, "camera.vertical_fov_deg", "{err:?}");
    // Still open: a good change is applied.
    s.update(SessionUpdate { width: 16, height: 12, ..Default::default() }).await;
    let (frames, _) = s.until_final(2).await;
    let f = &frames.last().unwrap().1;
    assert_eq!((f.width, f.height), (16, 12));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pause_stops_frames_until_resume() {
    let server = TestServer::start().await;
    let mut req = open_req(60, 2);
    if let Some(s) = req.settings.as_mut() {
        s.time_budget_seconds = 600.0;
        s.max_mean_spp = 60000.0;
    }
    let mut s = Session::open(&server, req).await.expect("session opens");
    // Some frames of generation 1, then pause.
    loop {
        let e = s.next().await.unwrap().unwrap();
        if matches!(e.kind, Some(Kind::FrameComplete(_))) {
            break;
        }
    }
    s.update(SessionUpdate { pause: true, ..Default::default() }).await;
    loop {
        let e = s.next().await.unwrap().unwrap();
        if let Some(Kind::Ack(_)) = e.kind {
            assert_eq!(e.generation, 2);
            break;
        }
    }
    assert!(
        wait_until(Duration::from_secs(30), || server.state.active_renders() == 0).await,
        "paused: nothing renders"
    );
    let quiet = tokio::time::timeout(Duration::from_millis(300), s.events.message()).await;
    assert!(quiet.is_err(), "an event while paused: {quiet:?}");
    s.update(SessionUpdate { resume: true, ..Default::default() }).await;
    let e = s.next().await.unwrap().unwrap();
    assert!(matches!(e.kind, Some(Kind::Ack(_))) && e.generation == 3, "{e:?}");
    let e = s.next().await.unwrap().unwrap();
    assert!(matches!(e.kind, Some(Kind::Started(_))) && e.generation == 3, "{e:?}");
}

/// Changes that pile up while nothing renders (here: paused) are coalesced: each is
/// acknowledged, but only the newest view renders, once, exactly as a fresh render of it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pending_changes_are_coalesced_into_the_newest() {
    let server = TestServer::start().await;
    let mut s = Session::open(&server, open_req(2, 9)).await.expect("session opens");
    s.until_final(1).await;
    s.update(SessionUpdate { pause: true, ..Default::default() }).await;
    let camera = |i: u32| CameraOverride {
        position: Some(Vec3 { x: -40.0 * i as f32, y: 280.0, z: -700.0 }),
        ..Default::default()
    };
    for i in 1..=4 {
        s.update(SessionUpdate { camera: Some(camera(i)), ..Default::default() }).await;
    }
    s.update(SessionUpdate { resume: true, ..Default::default() }).await;
    // Generations: 2 the pause, 3-6 the cameras, 7 the resume.
    let (frames, seen) = s.until_final(7).await;
    let acked: Vec<u64> = seen.iter().filter(|e| matches!(e.kind, Some(Kind::Ack(_)))).map(|e| e.generation).collect();
    assert_eq!(acked, (2..=7).collect::<Vec<_>>());
    let started: Vec<u64> =
        seen.iter().filter(|e| matches!(e.kind, Some(Kind::Started(_)))).map(|e| e.generation).collect();
    assert_eq!(started, [7], "only the newest view renders");
    assert!(frames.iter().all(|(g, _)| *g == 7));
    let mut fresh = open_req(2, 9);
    fresh.camera = Some(camera(4));
    let expected = collect(&mut server.client().await, fresh).await.expect("render");
    assert_eq!(color_bits(&frames.last().unwrap().1), color_bits(expected.frames.last().unwrap()));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_slow_reader_gets_the_newest_frames_and_skips_the_rest() {
    let server = TestServer::start().await;
    // Frames of every layer at 320x240 (2.4 MB each) fill the transport's buffers within a
    // frame or two.
    let mut req = open_req(40, 3);
    req.width = 320;
    req.height = 240;
    req.outputs = Some(wedge::proto::OutputSelection {
        color: true,
        spp: true,
        filter_width: true,
        unfiltered: true,
        ..Default::default()
    });
    if let Some(s) = req.settings.as_mut() {
        s.max_mean_spp = 64.0;
        s.bounces = Some(0);
    }
    let mut s = Session::open(&server, req).await.expect("session opens");
    // Do not read while the render runs its passes.
    assert!(wait_until(Duration::from_secs(60), || server.state.renders_finished() == 1).await);
    let (frames, seen) = s.until_final(1).await;
    let dropped = seen.iter().map(|e| e.frames_dropped).max().unwrap();
    let passes = u64::from(frames.last().unwrap().1.stats.pass) + 1;
    assert!(dropped > 0, "nothing was skipped ({} frames of {passes} passes)", frames.len());
    // Every pass, and the quick preview before them, is sent or counted as dropped.
    assert_eq!(frames.len() as u64 + dropped, passes + 1);
    // Full-resolution frames go out in order, the newest each time.
    let full: Vec<&Frame> = frames.iter().map(|(_, f)| f).filter(|f| f.width == 320).collect();
    assert!(full.windows(2).all(|w| w[0].stats.pass < w[1].stats.pass));
}

/// A burst of camera changes sent while a long render streams its frames: each change is
/// acknowledged in order, no event of an older generation follows an acknowledgement, the
/// generations of the frames never go back, no superseded view reaches its final frame (its
/// render stops, however many of them started), and the last view renders exactly as a fresh
/// render of it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_burst_of_changes_mid_render_never_goes_back_a_generation() {
    let server = TestServer::start().await;
    let mut open = long_render(5);
    open.frame_every = 0;
    let mut s = Session::open(&server, open.clone()).await.expect("session opens");
    // Generation 1 is rendering once its first frame is out.
    loop {
        let e = s.next().await.unwrap().unwrap();
        if matches!(e.kind, Some(Kind::FrameComplete(_))) {
            break;
        }
    }
    let changes = 8u64;
    let camera = |i: u64| CameraOverride {
        position: Some(Vec3 { x: 30.0 * i as f32, y: 300.0, z: -700.0 }),
        ..Default::default()
    };
    // The last change also makes its render short, so that it ends.
    let short = open_req(2, 5).settings;
    for i in 1..=changes {
        let settings = if i == changes { short } else { None };
        s.update(SessionUpdate { camera: Some(camera(i)), settings, ..Default::default() }).await;
    }
    let last_generation = 1 + changes;
    let (frames, seen) = s.until_final(last_generation).await;

    let acks: Vec<(usize, u64)> = (seen.iter().enumerate())
        .filter(|(_, e)| matches!(e.kind, Some(Kind::Ack(_))))
        .map(|(i, e)| (i, e.generation))
        .collect();
    assert_eq!(acks.iter().map(|a| a.1).collect::<Vec<_>>(), (2..=last_generation).collect::<Vec<_>>());
    for &(at, generation) in &acks {
        assert!(
            seen[at..].iter().all(|e| e.generation >= generation),
            "an event older than generation {generation} after its acknowledgement"
        );
    }
    assert!(frames.windows(2).all(|w| w[0].0 <= w[1].0), "frame generations went back");
    let finals: Vec<u64> = frames.iter().filter(|(_, f)| f.stats.is_final).map(|(g, _)| *g).collect();
    assert_eq!(finals, [last_generation], "only the last view ends");

    let mut fresh = open;
    fresh.settings = short;
    fresh.camera = Some(camera(changes));
    let expected = collect(&mut server.client().await, fresh).await.expect("render");
    assert_eq!(color_bits(&frames.last().unwrap().1), color_bits(expected.frames.last().unwrap()));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cancelling_a_session_stops_its_render_and_frees_its_slot() {
    let server = TestServer::with_config(ServerConfig { max_concurrent_renders: 1, ..Default::default() }).await;
    let mut s = Session::open(&server, {
        let mut r = long_render(4);
        r.frame_every = 0;
        r
    })
    .await
    .expect("opens");
    s.next().await.unwrap().unwrap();
    // A session holds its slot.
    let busy = server.client().await.render(cornell(8, 6, 1, 1)).await.expect_err("no slot left");
    assert_eq!(busy.code(), Code::ResourceExhausted);
    assert_eq!(server.state.active_renders(), 1);
    drop(s);
    assert!(wait_until(Duration::from_secs(30), || server.state.active_renders() == 0).await, "the render still runs");
    assert!(wait_until(Duration::from_secs(30), || server.state.metrics.active_sessions() == 0).await);
    collect(&mut server.client().await, cornell(8, 6, 1, 1)).await.expect("the slot is free again");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_session_must_open_first_and_ends_when_idle() {
    let config = ServerConfig { session_idle_timeout: Duration::from_millis(300), ..Default::default() };
    let server = TestServer::with_config(config).await;
    let (tx, rx) = mpsc::channel(4);
    tx.send(SessionRequest { kind: Some(session_request::Kind::Update(SessionUpdate::default())) }).await.unwrap();
    let err = server.client().await.session(ReceiverStream::new(rx)).await.expect_err("not opened");
    assert_eq!(err.code(), Code::InvalidArgument);
    assert!(err.message().starts_with("open:"), "{}", err.message());

    let mut s = Session::open(&server, open_req(1, 1)).await.expect("opens");
    s.until_final(1).await;
    let end = loop {
        match s.next().await {
            Ok(Some(_)) => continue,
            Ok(None) => panic!("ended with OK"),
            Err(status) => break status,
        }
    };
    assert_eq!(end.code(), Code::DeadlineExceeded, "{end:?}");
    assert!(end.message().contains("idle"), "{}", end.message());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stored_scenes_are_named_by_digest() {
    let server = TestServer::start().await;
    let scene = wedge::scene::builtin::get("cornell").unwrap();
    let mut client = server.client().await;
    let put = client
        .put_scene(PutSceneRequest { scene: Some(scene.clone()), ..Default::default() })
        .await
        .expect("stored")
        .into_inner();
    assert_eq!(put.digest, wedge::server::scene_cache::digest(&scene));
    assert_eq!(
        put.triangles,
        u64::try_from(wedge::scene::compile(&scene, &Default::default(), None).unwrap().triangle_count()).unwrap()
    );

    // By digest, the same pixels as inline.
    let mut by_digest = cornell(16, 12, 2, 5);
    by_digest.scene_source = Some(SceneSource::SceneDigest(put.digest.clone()));
    let mut inline = cornell(16, 12, 2, 5);
    inline.scene_source = Some(SceneSource::Scene(scene));
    let a = collect(&mut client, by_digest.clone()).await.expect("render by digest");
    let b = collect(&mut client, inline).await.expect("render inline");
    assert_eq!(color_bits(a.frames.last().unwrap()), color_bits(b.frames.last().unwrap()));

    // A session by digest.
    let mut s = Session::open(&server, by_digest).await.expect("session by digest");
    let (frames, _) = s.until_final(1).await;
    assert_eq!(color_bits(&frames.last().unwrap().1), color_bits(a.frames.last().unwrap()));
    drop(s);

    // Unknown and malformed digests.
    let unknown = format!("sha256:{}", "0".repeat(64));
    let mut req = cornell(8, 6, 1, 1);
    req.scene_source = Some(SceneSource::SceneDigest(unknown.clone()));
    let err = client.render(req.clone()).await.expect_err("unknown digest");
    assert_eq!(err.code(), Code::FailedPrecondition);
    assert!(err.message().contains(&unknown) && err.message().contains("PutScene"), "{}", err.message());
    let err = Session::open(&server, req).await.err().expect("unknown digest");
    assert_eq!(err.code(), Code::FailedPrecondition);
    let mut req = cornell(8, 6, 1, 1);
    req.scene_source = Some(SceneSource::SceneDigest("sha256:nope".into()));
    assert_eq!(client.render(req).await.expect_err("malformed").code(), Code::InvalidArgument);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_scene_store_evicts_and_the_client_uploads_again() {
    // Room for one Cornell box (by triangles): storing a second scene evicts the first.
    let cornell_triangles = 32;
    let config = ServerConfig { scene_cache_triangles: cornell_triangles + 8, ..Default::default() };
    let server = TestServer::with_config(config).await;
    let mut client = server.client().await;
    let a = wedge::scene::builtin::get("cornell").unwrap();
    let mut b = a.clone();
    b.description = "another".into();
    let da =
        client.put_scene(PutSceneRequest { scene: Some(a.clone()), ..Default::default() }).await.unwrap().into_inner();
    assert_eq!(da.triangles, cornell_triangles);
    client.put_scene(PutSceneRequest { scene: Some(b), ..Default::default() }).await.unwrap();
    let mut req = cornell(8, 6, 1, 1);
    req.scene_source = Some(SceneSource::SceneDigest(da.digest.clone()));
    assert_eq!(client.render(req.clone()).await.expect_err("evicted").code(), Code::FailedPrecondition);
    client.put_scene(PutSceneRequest { scene: Some(a), ..Default::default() }).await.unwrap();
    collect(&mut client, req).await.expect("stored again");
    // A scene larger than the whole store is refused.
    let big = wedge::scene::builtin::get("interior").unwrap();
    let err =
        client.put_scene(PutSceneRequest { scene: Some(big), ..Default::default() }).await.expect_err("too large");
    assert_eq!(err.code(), Code::ResourceExhausted);
    assert!(err.message().contains("scene_cache_triangles"), "{}", err.message());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn settings_changes_apply_without_a_new_compile() {
    let server = TestServer::start().await;
    let mut s = Session::open(&server, open_req(1, 9)).await.expect("opens");
    s.until_final(1).await;
    let settings = RenderSettings {
        method: wedge::proto::Method::Uniform as i32,
        max_passes: 2,
        bounces: Some(0),
        ..Default::default()
    };
    s.update(SessionUpdate { settings: Some(settings), ..Default::default() }).await;
    let (frames, _) = s.until_final(2).await;
    let mut fresh = open_req(1, 9);
    fresh.settings = Some(settings);
    let expected = collect(&mut server.client().await, fresh).await.expect("render");
    assert_eq!(color_bits(&frames.last().unwrap().1), color_bits(expected.frames.last().unwrap()));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn closing_the_request_side_ends_the_session_with_ok() {
    let server = TestServer::start().await;
    let mut s = Session::open(&server, open_req(1, 1)).await.expect("opens");
    s.until_final(1).await;
    let Session { tx, mut events, .. } = s;
    drop(tx);
    let end = within(10, "the end of the session", async {
        loop {
            match events.message().await {
                Ok(Some(_)) => continue,
                other => return other,
            }
        }
    })
    .await;
    assert!(matches!(end, Ok(None)), "{end:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_large_view_shows_a_quick_preview_first() {
    let server = TestServer::start().await;
    let mut req = open_req(2, 3);
    req.width = 320;
    req.height = 240;
    let mut s = Session::open(&server, req).await.expect("opens");
    s.until_final(1).await;
    s.update(SessionUpdate { camera: Some(moved_camera()), ..Default::default() }).await;
    let (frames, seen) = s.until_final(2).await;
    let started: Vec<&SessionEvent> =
        seen.iter().filter(|e| e.generation == 2 && matches!(e.kind, Some(Kind::Started(_)))).collect();
    assert_eq!(started.len(), 2, "a preview's started, then the full resolution's");
    assert_eq!((started[0].preview_divider, started[1].preview_divider), (4, 0));
    let gen2: Vec<&Frame> = frames.iter().filter(|(g, _)| *g == 2).map(|(_, f)| f).collect();
    assert_eq!((gen2[0].width, gen2[0].height), (80, 60));
    assert!(!gen2[0].stats.is_final, "a preview is never final");
    let last = gen2.last().unwrap();
    assert_eq!((last.width, last.height), (320, 240));
    let previews = seen.iter().filter(|e| matches!(e.kind, Some(Kind::FrameComplete(_))) && e.preview_divider == 4);
    assert_eq!(previews.count(), 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_watched_session_takes_its_changes_by_update_session() {
    use wedge::proto::{UpdateSessionRequest, WatchSessionRequest};
    let server = TestServer::start().await;
    let mut client = server.client().await;
    let mut events =
        client.watch_session(WatchSessionRequest { open: Some(open_req(2, 7)) }).await.unwrap().into_inner();
    let first = within(60, "the first event", events.message()).await.unwrap().unwrap();
    assert!(matches!(first.kind, Some(Kind::Ack(ref a)) if a.update == 1), "{first:?}");
    let id = first.session_id.clone();
    assert_eq!(id.len(), 32, "a 128-bit hex id: {id:?}");

    // A change, numbered as the reply says, acknowledged in the stream; then an in-band error.
    let update = |u: SessionUpdate| UpdateSessionRequest { session_id: id.clone(), update: Some(u) };
    let camera = SessionUpdate { camera: Some(moved_camera()), ..Default::default() };
    let n = client.update_session(update(camera)).await.unwrap().into_inner().update;
    assert_eq!(n, 2);
    let bad = SessionUpdate { width: 1 << 20, ..Default::default() };
    assert_eq!(client.update_session(update(bad)).await.unwrap().into_inner().update, 3);
    let mut s = Session { tx: mpsc::channel(1).0, events, asm: FrameAssembler::new(), completed: None };
    let (frames, seen) = s.until_final(2).await;
    let ack = seen.iter().position(|e| matches!(e.kind, Some(Kind::Ack(ref a)) if a.update == 2)).expect("ack");
    assert_eq!(seen[ack].generation, 2);
    assert!(seen[ack..].iter().all(|e| e.generation >= 2), "a generation-1 event after the ack");
    assert!(seen.iter().all(|e| e.session_id.is_empty() || e.session_id == id));

    // The new view is exactly a fresh render of it.
    let mut fresh = open_req(2, 7);
    fresh.camera = Some(moved_camera());
    let expected = collect(&mut client, fresh).await.unwrap();
    assert_eq!(color_bits(&frames.last().unwrap().1), color_bits(expected.frames.last().unwrap()));
    let error_in = |e: &SessionEvent| match &e.kind {
        Some(Kind::Error(err)) => Some(err.clone()),
        _ => None,
    };
    let error = match seen.iter().find_map(error_in) {
        Some(err) => err,
        None => loop {
            if let Some(err) = error_in(&s.next().await.unwrap().expect("session open")) {
                break err;
            }
        },
    };
    assert_eq!((error.update, error.field.as_str()), (3, "width"), "{error:?}");

    // Unknown ids, and the id of a session whose watch ended, are NOT_FOUND.
    let unknown = UpdateSessionRequest { session_id: "0".repeat(32), update: Some(SessionUpdate::default()) };
    let err = client.update_session(unknown).await.unwrap_err();
    assert_eq!(err.code(), Code::NotFound);
    assert!(err.message().starts_with("session_id:"), "{}", err.message());
    let missing = UpdateSessionRequest { session_id: id.clone(), update: None };
    assert_eq!(client.update_session(missing).await.unwrap_err().code(), Code::InvalidArgument);
    drop(s);
    assert!(wait_until(Duration::from_secs(30), || server.state.metrics.active_sessions() == 0).await);
    let err = client.update_session(update(SessionUpdate::default())).await.unwrap_err();
    assert_eq!(err.code(), Code::NotFound, "{err:?}");

    // A watch without its open is refused.
    let err = client.watch_session(WatchSessionRequest { open: None }).await.unwrap_err();
    assert_eq!(err.code(), Code::InvalidArgument);
    assert!(err.message().starts_with("open:"), "{}", err.message());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_scene_file_text_is_stored_as_its_scene() {
    let server = TestServer::start().await;
    let mut client = server.client().await;
    let scene = wedge::scene::builtin::get("cornell").unwrap();
    let text = wedge::scene::json::to_json(&scene);
    let put = client.put_scene(PutSceneRequest { scene_json: text, ..Default::default() }).await.unwrap().into_inner();
    assert_eq!(put.digest, wedge::server::scene_cache::digest(&scene));

    let bad = "{\n  \"lights\": [\n    {\"rect\": 3}\n  ]\n}";
    let err = client.put_scene(PutSceneRequest { scene_json: bad.into(), ..Default::default() }).await.unwrap_err();
    assert_eq!(err.code(), Code::InvalidArgument);
    assert!(err.message().starts_with("scene_json:3:"), "{}", err.message());
    let both = PutSceneRequest { scene: Some(scene), scene_json: "{}".into() };
    let err = client.put_scene(both).await.unwrap_err();
    assert!(err.message().starts_with("scene_json: set either"), "{}", err.message());
}

//! The render service over real gRPC, against an in-process server on 127.0.0.1.
mod common;

use common::*;
use std::time::Duration;
use tonic::Code;
use wedge::api::request::{self, Limits};
use wedge::pipeline::frame::{Frame, HaltReason};
use wedge::pipeline::job::CancelToken;
use wedge::pipeline::progressive;
use wedge::proto::{
    light, render_request::SceneSource, Camera, ListScenesRequest, Method, OutputSelection, PixelFormat, RenderRequest,
    Scene, Vec3,
};
use wedge::server::ServerConfig;

/// Renders `req` in-process, without the server, and returns its final frame.
fn render_locally(req: &RenderRequest, label: &str) -> Frame {
    let prepared = request::prepare(req, &Limits::default(), None, label).expect("prepare");
    let mut last = None;
    progressive::render(&prepared.job, &CancelToken::new(), &mut |f: &Frame| {
        last = Some(f.clone());
        true
    })
    .expect("local render");
    last.expect("a frame")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn progressive_frames_refine() {
    let server = TestServer::start().await;
    let req = cornell(48, 36, 4, 7);
    let mut frames = Vec::new();
    let mut headers = Vec::new();
    let last = within(
        120,
        "render",
        wedge::client::render_remote(&server.addr_str(), req, |started, frame| {
            headers.push(started.clone());
            frames.push(frame.clone());
        }),
    )
    .await
    .expect("render_remote")
    .expect("a final frame");

    assert!(frames.len() >= 3, "only {} frames", frames.len());
    let started = &headers[0];
    assert_eq!((started.width, started.height), (48, 36));
    assert_eq!(started.method, Method::Uniform as i32);
    assert_eq!(started.seed, 7);
    assert!(started.triangles > 0);
    assert_eq!(started.layers, vec!["color", "spp"]);
    assert_eq!(started.format, PixelFormat::F32 as i32);

    for (i, pair) in frames.windows(2).enumerate() {
        let (a, b) = (&pair[0], &pair[1]);
        assert_eq!(b.stats.pass, a.stats.pass + 1, "frames {i} and {}", i + 1);
        assert!(
            b.stats.mean_spp >= a.stats.mean_spp,
            "mean spp fell from {} to {}",
            a.stats.mean_spp,
            b.stats.mean_spp
        );
        assert!(
            a.spp.iter().zip(&b.spp).all(|(x, y)| y >= x),
            "a pixel's spp fell between passes {} and {}",
            a.stats.pass,
            b.stats.pass
        );
        assert!(!a.stats.is_final);
    }
    assert!(frames[0].stats.mean_spp > 0.0);
    assert!(last.stats.is_final);
    assert_eq!(last.stats.halt_reason, HaltReason::MaxPasses);
    assert_eq!(last.stats.pass, 3);
    assert!(last.stats.rays_traced > 0);
    assert!(last.color.iter().flatten().all(|v| v.is_finite()));
    assert!(last.color.iter().flatten().any(|&v| v > 0.0), "a black image");
    assert_eq!(color_bits(&last), color_bits(frames.last().expect("frames")));
    assert_eq!(server.state.renders_started(), 1);
    assert!(wait_until(Duration::from_secs(2), || server.state.active_renders() == 0).await);
    assert_eq!(server.state.renders_finished(), 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tiny_chunks_reassemble_bit_exact() {
    let mut req = cornell(48, 36, 3, 11);
    req.outputs = Some(OutputSelection {
        color: true,
        spp: true,
        filter_width: true,
        unfiltered: true,
        components: true,
        format: PixelFormat::F32 as i32,
        ..Default::default()
    });
    let tiled = TestServer::with_config(ServerConfig { max_chunk_bytes: 1, ..Default::default() }).await;
    let whole = TestServer::start().await;

    let a = within(120, "tiled render", async { collect(&mut tiled.client().await, req.clone()).await })
        .await
        .expect("tiled render");
    let b = within(120, "untiled render", async { collect(&mut whole.client().await, req.clone()).await })
        .await
        .expect("untiled render");

    // One row per chunk versus the whole 48x36 frame in one chunk.
    assert!(a.chunks_per_frame.iter().all(|&n| n == 36), "{:?}", a.chunks_per_frame);
    assert!(b.chunks_per_frame.iter().all(|&n| n == 1), "{:?}", b.chunks_per_frame);
    assert_eq!(a.started.layers, vec!["color", "spp", "filter_width", "unfiltered"]);
    assert_eq!(a.frames.len(), 3);
    assert_eq!(b.frames.len(), 3);

    let local = render_locally(&req, "cornell");
    for (fa, fb) in a.frames.iter().zip(&b.frames) {
        assert_eq!(color_bits(fa), color_bits(fb), "pass {}", fa.stats.pass);
        assert_eq!(spp_bits(fa), spp_bits(fb), "pass {}", fa.stats.pass);
    }
    let (fa, fb) = (&a.frames[2], &b.frames[2]);
    assert_eq!(color_bits(fa), color_bits(&local), "gRPC frame differs from a local render");
    assert_eq!(spp_bits(fa), spp_bits(&local));
    // The uniform method does not filter: widths are zero, unfiltered equals colour.
    assert!(fa.filter_width.as_ref().expect("widths").iter().all(|&w| w == 0.0));
    let unfiltered: Vec<u32> =
        fa.unfiltered.as_ref().expect("unfiltered").iter().flatten().map(|v| v.to_bits()).collect();
    assert_eq!(unfiltered, color_bits(fa));
    // Same stats but for the timings.
    for other in [fb, &local] {
        let (x, y) = (&fa.stats, &other.stats);
        assert_eq!(
            (x.pass, x.rays_traced, x.is_final, x.halt_reason, x.dropped_samples),
            (y.pass, y.rays_traced, y.is_final, y.halt_reason, y.dropped_samples)
        );
        assert!((x.mean_spp - y.mean_spp).abs() <= 1e-9 * y.mean_spp, "{x:?} vs {y:?}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn f16_frames_match_f32_within_precision() {
    let server = TestServer::start().await;
    let mut client = server.client().await;
    let req32 = cornell(24, 18, 2, 5);
    let mut req16 = req32.clone();
    req16.outputs =
        Some(OutputSelection { color: true, spp: true, format: PixelFormat::F16 as i32, ..Default::default() });
    let a = within(60, "f32 render", collect(&mut client, req32)).await.expect("f32");
    let b = within(60, "f16 render", collect(&mut client, req16)).await.expect("f16");
    assert_eq!(b.started.format, PixelFormat::F16 as i32);
    let (fa, fb) = (&a.frames[1], &b.frames[1]);
    for (x, y) in fa.color.iter().flatten().zip(fb.color.iter().flatten()) {
        let tol = x.abs() * 2f32.powi(-11) + 6e-8;
        assert!((x - y).abs() <= tol, "{x} vs {y}");
    }
    assert_eq!(fa.spp, fb.spp);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn frame_every_skips_frames_but_sends_the_final_one() {
    let server = TestServer::start().await;
    let mut req = cornell(16, 12, 5, 3);
    req.frame_every = 2;
    let got = within(60, "render", collect(&mut server.client().await, req)).await.expect("render");
    let passes: Vec<u32> = got.frames.iter().map(|f| f.stats.pass).collect();
    assert_eq!(passes, vec![1, 3, 4]);
    assert!(got.frames[2].stats.is_final);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cancelling_stops_the_render() {
    let server = TestServer::start().await;
    let mut client = server.client().await;
    let mut stream = client.render(long_render(1)).await.expect("render starts").into_inner();
    within(60, "first frame", next_frame_complete(&mut stream)).await;
    assert_eq!(server.state.active_renders(), 1);

    drop(stream);
    let stopped = wait_until(Duration::from_secs(3), || server.state.active_renders() == 0).await;
    assert!(stopped, "render still running 3 s after the client cancelled");
    assert_eq!(server.state.renders_cancelled(), 1);
    assert_eq!(server.state.renders_finished(), 0);

    // The slot is free again.
    let got = within(60, "render after cancel", collect(&mut client, cornell(8, 6, 1, 1)))
        .await
        .expect("render after cancel");
    assert_eq!(got.frames.len(), 1);
}

/// No frame is due for minutes, so the render can only notice the cancellation through its
/// cancel token (checked per tile), not through a failed send.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cancelling_between_frames_stops_the_render() {
    let server = TestServer::start().await;
    let mut client = server.client().await;
    let mut req = long_render(5);
    req.width = 96;
    req.height = 72;
    req.frame_every = 1_000_000;
    let mut stream = client.render(req).await.expect("render starts").into_inner();
    let started = stream.message().await.expect("stream").expect("RenderStarted");
    assert!(matches!(started.kind, Some(wedge::proto::render_update::Kind::Started(_))));
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(server.state.active_renders(), 1, "the render should still be running");

    drop(stream);
    let stopped = wait_until(Duration::from_secs(3), || server.state.active_renders() == 0).await;
    assert!(stopped, "render still running 3 s after the client cancelled");
    assert_eq!(server.state.renders_cancelled(), 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn disconnecting_stops_the_render() {
    let server = TestServer::start().await;
    let mut client = server.client().await;
    let mut stream = client.render(long_render(2)).await.expect("render starts").into_inner();
    within(60, "first frame", next_frame_complete(&mut stream)).await;
    // Stop reading, then drop the whole connection.
    drop(client);
    drop(stream);
    let stopped = wait_until(Duration::from_secs(3), || server.state.active_renders() == 0).await;
    assert!(stopped, "render still running 3 s after the client went away");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn busy_server_refuses_with_resource_exhausted() {
    let server = TestServer::with_config(ServerConfig { max_concurrent_renders: 1, ..Default::default() }).await;
    let mut client = server.client().await;
    let mut first = client.render(long_render(3)).await.expect("first render starts").into_inner();
    within(60, "first frame", next_frame_complete(&mut first)).await;

    let err = client.render(cornell(8, 6, 1, 1)).await.expect_err("second render must be refused");
    assert_eq!(err.code(), Code::ResourceExhausted, "{err:?}");
    assert!(err.message().contains("max_concurrent_renders"), "{}", err.message());

    drop(first);
    assert!(wait_until(Duration::from_secs(3), || server.state.active_renders() == 0).await);
    let got = within(60, "render after the first ended", collect(&mut client, cornell(8, 6, 1, 1)))
        .await
        .expect("a slot is free again");
    assert_eq!(got.frames.len(), 1);
}

async fn expect_invalid(server: &TestServer, req: RenderRequest, needle: &str) {
    let mut client = server.client().await;
    let err = match client.render(req).await {
        Ok(_) => panic!("request accepted; expected INVALID_ARGUMENT naming {needle}"),
        Err(e) => e,
    };
    assert_eq!(err.code(), Code::InvalidArgument, "{err:?}");
    assert!(err.message().contains(needle), "message {:?} does not name {needle:?}", err.message());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn invalid_requests_name_the_field() {
    let server = TestServer::start().await;

    // A zero-size inline camera and no resolution override.
    let inline = Scene {
        camera: Some(Camera {
            position: Some(Vec3 { x: 0.0, y: 1.0, z: 3.0 }),
            look_at: Some(Vec3 { x: 0.0, y: 1.0, z: 0.0 }),
            vertical_fov_deg: 40.0,
            width: 0,
            height: 0,
            ..Default::default()
        }),
        ..Default::default()
    };
    let mut req = cornell(0, 0, 1, 1);
    req.scene_source = Some(SceneSource::Scene(inline));
    expect_invalid(&server, req, "width").await;

    // An unknown built-in scene.
    let mut req = cornell(8, 6, 1, 1);
    req.scene_source = Some(SceneSource::Builtin("no-such-scene".into()));
    expect_invalid(&server, req, "builtin").await;

    // A NaN in a light.
    let mut scene = wedge::scene::builtin::get("cornell").expect("cornell");
    let index = scene
        .lights
        .iter()
        .position(|l| matches!(l.kind, Some(light::Kind::Rect(_))))
        .expect("cornell has a rect light");
    if let Some(light::Kind::Rect(rect)) = scene.lights[index].kind.as_mut() {
        let radiance = rect.radiance.get_or_insert_with(Default::default);
        radiance.g = f32::NAN;
    }
    let mut req = cornell(8, 6, 1, 1);
    req.scene_source = Some(SceneSource::Scene(scene));
    expect_invalid(&server, req, &format!("lights[{index}]")).await;

    // An unknown pixel format.
    let mut req = cornell(8, 6, 1, 1);
    req.outputs = Some(OutputSelection { color: true, format: 9, ..Default::default() });
    expect_invalid(&server, req, "outputs.format").await;

    assert_eq!(server.state.renders_started(), 0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn list_scenes_has_the_builtins() {
    let server = TestServer::start().await;
    let scenes = server.client().await.list_scenes(ListScenesRequest {}).await.expect("ListScenes").into_inner().scenes;
    let names: Vec<&str> = scenes.iter().map(|s| s.name.as_str()).collect();
    for want in ["cornell", "grids", "curved", "cornell-glossy", "interior"] {
        assert!(names.contains(&want), "{want} missing from {names:?}");
    }
    for s in &scenes {
        assert!(s.width > 0 && s.height > 0, "{s:?}");
        assert!(s.triangles > 0, "{s:?}");
        assert!(s.lights > 0, "{s:?}");
        assert!(!s.description.is_empty(), "{s:?}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn health_reports_serving() {
    use tonic_health::pb::{health_check_response::ServingStatus, health_client::HealthClient, HealthCheckRequest};
    let server = TestServer::start().await;
    let mut health = HealthClient::new(server.channel().await);
    for service in ["wedge.v1.Renderer", ""] {
        let status = health
            .check(HealthCheckRequest { service: service.into() })
            .await
            .expect("health check")
            .into_inner()
            .status;
        assert_eq!(status, ServingStatus::Serving as i32, "service {service:?}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reflection_lists_the_services() {
    use tonic_reflection::pb::v1::{
        server_reflection_client::ServerReflectionClient, server_reflection_request::MessageRequest,
        server_reflection_response::MessageResponse, ServerReflectionRequest,
    };
    let server = TestServer::start().await;
    let mut reflection = ServerReflectionClient::new(server.channel().await);
    let request = ServerReflectionRequest {
        host: String::new(),
        message_request: Some(MessageRequest::ListServices(String::new())),
    };
    let mut responses =
        reflection.server_reflection_info(tokio_stream::iter(vec![request])).await.expect("reflection").into_inner();
    let response = responses.message().await.expect("reflection stream").expect("a response");
    let Some(MessageResponse::ListServicesResponse(list)) = response.message_response else {
        panic!("unexpected reflection response {response:?}");
    };
    let names: Vec<&str> = list.service.iter().map(|s| s.name.as_str()).collect();
    assert!(names.contains(&"wedge.v1.Renderer"), "{names:?}");
    assert!(names.contains(&"grpc.health.v1.Health"), "{names:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_reports_not_serving_and_finishes_streams() {
    use tonic_health::pb::{health_check_response::ServingStatus, health_client::HealthClient, HealthCheckRequest};
    let mut server = TestServer::start().await;
    let channel = server.channel().await;
    let mut health = HealthClient::new(channel.clone());
    let mut watch =
        health.watch(HealthCheckRequest { service: "wedge.v1.Renderer".into() }).await.expect("watch").into_inner();
    let first = watch.message().await.expect("watch").expect("status");
    assert_eq!(first.status, ServingStatus::Serving as i32);

    // A render in flight when the shutdown starts still runs to its final frame.
    let mut client = wedge::proto::renderer_client::RendererClient::new(channel);
    let mut stream = client.render(cornell(16, 12, 3, 4)).await.expect("render starts").into_inner();
    let started = stream.message().await.expect("stream").expect("RenderStarted");
    server.begin_shutdown();

    let next = within(10, "health update", watch.message()).await.expect("watch").expect("status");
    assert_eq!(next.status, ServingStatus::NotServing as i32);
    drop(watch);

    let mut asm = wedge::server::FrameAssembler::new();
    asm.push(started).expect("RenderStarted");
    let mut last = None;
    while let Some(update) =
        within(60, "render stream", stream.message()).await.expect("stream continues through the shutdown")
    {
        if let Some(frame) = asm.push(update).expect("well-formed") {
            last = Some(frame);
        }
    }
    let last = last.expect("frames after the shutdown began");
    assert!(last.stats.is_final);
    server.stop(Duration::from_secs(10)).await.expect("server stops cleanly");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn render_remote_reports_status_errors() {
    let server = TestServer::start().await;
    let mut req = cornell(8, 6, 1, 1);
    req.scene_source = Some(SceneSource::Builtin("no-such-scene".into()));
    let err = wedge::client::render_remote(&server.addr_str(), req, |_, _| {}).await.expect_err("unknown scene");
    let remote = err.downcast_ref::<wedge::client::RemoteError>().expect("a RemoteError");
    assert_eq!(remote.code, Code::InvalidArgument);
    let text = err.to_string();
    assert!(text.contains("INVALID_ARGUMENT") && text.contains("builtin"), "{text}");

    // Nothing listens on the port of a stopped server.
    let addr = server.addr_str();
    server.stop(Duration::from_secs(10)).await.expect("stop");
    let err = wedge::client::render_remote(&addr, cornell(8, 6, 1, 1), |_, _| {}).await.expect_err("no server");
    assert!(format!("{err:#}").contains(&addr), "{err:#}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn renders_past_the_shutdown_grace_period_are_cancelled() {
    let config = ServerConfig { shutdown_grace: Duration::from_millis(200), ..Default::default() };
    let mut server = TestServer::with_config(config).await;
    let mut client = server.client().await;
    let mut stream = client.render(long_render(3)).await.expect("render starts").into_inner();
    within(60, "first frame", next_frame_complete(&mut stream)).await;
    server.begin_shutdown();
    // The render would run for minutes; the grace period ends it with UNAVAILABLE.
    let status = within(30, "stream end", final_status(&mut stream)).await;
    assert_eq!(status.code(), Code::Unavailable, "{status:?}");
    assert!(status.message().contains("shutting down"), "{}", status.message());
    let state = std::sync::Arc::clone(&server.state);
    server.stop(Duration::from_secs(10)).await.expect("server stops cleanly");
    assert_eq!(state.active_renders(), 0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stock_client_receives_1080p_frames_with_every_layer() {
    // tonic's client keeps its default 4 MiB receive limit here; every layer in f32 is 32 bytes
    // a pixel, 66 MB a frame, which arrives as row chunks under the limit.
    let server = TestServer::start().await;
    let mut req = cornell(1920, 1080, 1, 3);
    if let Some(s) = req.settings.as_mut() {
        s.bounces = Some(0);
    }
    req.outputs = Some(OutputSelection {
        color: true,
        spp: true,
        filter_width: true,
        unfiltered: true,
        components: true,
        format: 0,
        ..Default::default()
    });
    let mut chunks = 0usize;
    let mut client = server.client().await;
    let mut stream = client.render(req).await.expect("render starts").into_inner();
    let mut asm = wedge::server::FrameAssembler::new();
    let mut frame = None;
    while let Some(update) = within(300, "1080p stream", stream.message()).await.expect("no message over the limit") {
        if matches!(update.kind, Some(wedge::proto::render_update::Kind::Chunk(_))) {
            chunks += 1;
        }
        if let Some(f) = asm.push(update).expect("well-formed") {
            frame = Some(f);
        }
    }
    let frame = frame.expect("the frame");
    assert_eq!((frame.width, frame.height), (1920, 1080));
    assert!(frame.spp.iter().all(|&s| s == 1.0));
    assert!(chunks >= 64, "{chunks} chunks");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn aaf_streams_the_component_maps() {
    let server = TestServer::start().await;
    let mut req = cornell(32, 32, 2, 9);
    if let Some(s) = req.settings.as_mut() {
        s.method = Method::Aaf as i32;
        s.bounces = Some(1);
    }
    req.outputs = Some(OutputSelection { color: true, spp: true, components: true, ..Default::default() });
    let got = within(300, "AAF render", async { collect(&mut server.client().await, req.clone()).await })
        .await
        .expect("AAF render");

    let layers = &got.started.layers;
    for name in ["spp.shadow", "filter_width.shadow", "spp.diffuse", "filter_width.diffuse"] {
        assert!(layers.iter().any(|l| l == name), "{name} not in {layers:?}");
    }
    let last = got.frames.last().expect("a final frame");
    assert!(last.stats.is_final);
    let names: Vec<&str> = last.components.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names[..2], ["shadow", "diffuse"]);
    let n = last.spp.len();
    assert_eq!(n, 32 * 32);
    for c in &last.components {
        assert_eq!(c.spp.len(), n, "{}", c.name);
        for (p, (&own, &total)) in c.spp.iter().zip(&last.spp).enumerate() {
            // The total adds up the parts' camera samples; each component is one part's.
            assert!(own <= total, "{} spp {own} > total {total} at pixel {p}", c.name);
            assert!(total <= 0.0 || own > 0.0, "{} spp 0 where the total is {total}, pixel {p}", c.name);
        }
    }
    // Shadow and indirect light are separate parts: their samples add up to at most the total.
    for p in 0..n {
        let sum: f32 = last.components.iter().map(|c| c.spp[p]).sum();
        assert!(sum <= last.spp[p], "components {sum} > total {} at pixel {p}", last.spp[p]);
    }
    // AAF filters both: some pixel has a width.
    for c in &last.components[..2] {
        let widths = c.filter_width.as_ref().unwrap_or_else(|| panic!("{} widths", c.name));
        assert!(widths.iter().all(|w| w.is_finite() && *w >= 0.0), "{}", c.name);
    }
}

/// `settings.upsample_factor` reaches the lobe-aware method: its diffuse samples are traced
/// at the half-resolution grid's sites and a few re-rendered pixels only, while every pixel
/// takes its camera samples; the remote frame equals the local render; and a method that does
/// not upsample refuses the field.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn upsampling_crosses_the_wire() {
    let server = TestServer::start().await;
    let mut req = cornell(32, 24, 2, 4);
    if let Some(s) = req.settings.as_mut() {
        s.method = Method::LobeAware as i32;
        s.upsample_factor = 2;
    }
    req.outputs = Some(OutputSelection { color: true, spp: true, components: true, ..Default::default() });
    let got = within(300, "upsampled render", async { collect(&mut server.client().await, req.clone()).await })
        .await
        .expect("upsampled render");
    let last = got.frames.last().expect("a final frame");
    assert_eq!(color_bits(last), color_bits(&render_locally(&req, "upsampled")));
    let diffuse = &last.components.iter().find(|c| c.name == "diffuse").expect("a diffuse map").spp;
    let site = |p: usize| (p % 32).is_multiple_of(2) && (p / 32).is_multiple_of(2);
    let off_sites = (0..diffuse.len()).filter(|&p| !site(p) && diffuse[p] > 0.0).count();
    let upsampled = (0..diffuse.len()).filter(|&p| diffuse[p] == 0.0 && last.spp[p] > 0.0).count();
    assert!(off_sites > 0 && off_sites < upsampled, "{off_sites} re-rendered, {upsampled} upsampled");
    assert!(last.spp.iter().all(|&n| n == last.spp[0] && n > 0.0));

    let mut req = cornell(8, 6, 1, 1);
    if let Some(s) = req.settings.as_mut() {
        s.upsample_factor = 2;
    }
    expect_invalid(&server, req, "settings.upsample_factor").await;
}

/// The noise target, the error estimate and whether a pass was complete cross the wire as
/// they are computed: the remote stream equals the local render, field for field.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_noise_target_and_error_estimates_cross_the_wire() {
    let server = TestServer::start().await;
    let mut req = cornell(40, 30, 0, 3);
    let s = req.settings.as_mut().unwrap();
    (s.method, s.target_error, s.max_passes) = (Method::Aaf as i32, 0.15, 0);
    let mut remote = Vec::new();
    let last = within(
        120,
        "render",
        wedge::client::render_remote(&server.addr_str(), req.clone(), |_, frame| remote.push(frame.clone())),
    )
    .await
    .expect("render_remote")
    .expect("a final frame");
    assert_eq!(last.stats.halt_reason, HaltReason::NoiseTarget);
    let e = last.stats.estimated_error.expect("an estimate");
    assert!(e > 0.0 && e <= 0.15, "{e}");
    assert_eq!(remote[0].stats.estimated_error, None, "the first frame has no estimate");
    assert!(remote.iter().all(|f| f.stats.pass_complete));
    let local = render_locally(&req, "cornell");
    assert_eq!(local.stats.estimated_error, last.stats.estimated_error);
    assert_eq!(local.color, last.color);
}

/// Denoiser inputs over the wire: the layers follow the others, every frame carries the same
/// values, and they are right on the Cornell box (albedos of its materials, unit normals where
/// the pixel sees one surface, positive depths).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn denoiser_inputs_stream_with_every_frame() {
    let server = TestServer::start().await;
    let mut req = cornell(32, 24, 2, 5);
    req.outputs = Some(OutputSelection { color: true, albedo: true, normal: true, depth: true, ..Default::default() });
    let got = within(120, "render with AOVs", async { collect(&mut server.client().await, req.clone()).await })
        .await
        .expect("render");
    assert_eq!(got.started.layers, vec!["color", "albedo", "normal", "depth"]);
    assert_eq!(got.frames.len(), 2);
    let (a, b) = (got.frames[0].aovs.as_deref().unwrap(), got.frames[1].aovs.as_deref().unwrap());
    assert_eq!(a, b, "the inputs change between frames");
    let local = render_locally(&req, "cornell");
    assert_eq!(local.aovs.as_deref(), Some(a), "gRPC inputs differ from a local render's");
    assert_eq!(a.albedo.len(), 32 * 24);
    let mut unit = 0;
    for i in 0..a.albedo.len() {
        assert!(a.albedo[i].iter().all(|&c| (0.0..=1.0).contains(&c)), "albedo {:?}", a.albedo[i]);
        let len = a.normal[i].iter().map(|c| c * c).sum::<f32>().sqrt();
        assert!(len <= 1.0 + 1e-5, "normal {:?}", a.normal[i]);
        unit += usize::from((len - 1.0).abs() < 1e-4);
        assert!(a.depth[i] > 0.0, "depth {}", a.depth[i]);
    }
    // Many pixels see one flat wall with all four rays (at 32x24 many others straddle edges).
    assert!(unit > a.albedo.len() / 3, "{unit} unit normals");
    // Without the request, none are traced or sent.
    assert!(render_locally(&cornell(32, 24, 1, 5), "cornell").aovs.is_none());
}

/// The `bandwidth` method's maps over the wire: the layers follow the others and equal a local
/// render's bit for bit, the shaded and full-resolution sample counts cross with each frame,
/// and another method's stream, asked for the same layers, assembles into frames without them.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bandwidth_maps_stream_with_every_frame() {
    let server = TestServer::start().await;
    let mut req = cornell(32, 24, 2, 3);
    req.scene_source = Some(SceneSource::Builtin("sky-spheres".into()));
    req.settings.as_mut().unwrap().method = Method::Bandwidth as i32;
    req.outputs = Some(OutputSelection { color: true, spp: true, bandwidth: true, level: true, ..Default::default() });
    let got = within(120, "bandwidth render", async { collect(&mut server.client().await, req.clone()).await })
        .await
        .expect("render");
    assert_eq!(got.started.layers, vec!["color", "spp", "bandwidth", "level"]);
    assert_eq!(got.frames.len(), 2);
    let last = got.frames.last().unwrap();
    let local = render_locally(&req, "sky-spheres");
    let (remote_maps, local_maps) = (last.shading.as_ref().unwrap(), local.shading.as_ref().unwrap());
    assert_eq!(remote_maps.bandwidth, local_maps.bandwidth);
    assert_eq!(remote_maps.level, local_maps.level);
    assert_eq!(last.color, local.color);
    let stats = (last.stats.shaded_points, last.stats.full_resolution_points);
    assert_eq!(stats, (local.stats.shaded_points, local.stats.full_resolution_points));
    // Pass 1 traces one camera sample per pixel, as `uniform`'s second pass.
    assert!(stats.0 > 0 && stats.0 <= stats.1 && stats.1 == 32 * 24, "{stats:?}");
    // `uniform` has no such maps: zeros on the wire, none in the assembled frames.
    req.settings.as_mut().unwrap().method = Method::Uniform as i32;
    let got = within(120, "uniform render", async { collect(&mut server.client().await, req.clone()).await })
        .await
        .expect("render");
    assert!(got.frames.iter().all(|f| f.shading.is_none() && f.stats.full_resolution_points == 0));
}

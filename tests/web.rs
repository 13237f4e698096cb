//! The browser viewer in a real browser: headless Chromium, driven by chromedriver over the W3C
//! WebDriver protocol (HTTP and JSON, spoken here with a few lines of std networking), loads the
//! page from a test server started with `web: true`, waits for the first frames, drags on the
//! image with the pointer, and checks that frames of a newer generation arrived and show a
//! different image, both in the page's state and in screenshots.
//!
//! Needs Debian's `chromium` and `chromium-driver`; `.ci/run` installs them and sets
//! WEDGE_TEST_BROWSER=1, which makes this test mandatory. Without that variable it is skipped
//! (a plain `cargo test` on a machine without a browser). WEDGE_CHROMIUM and WEDGE_CHROMEDRIVER
//! override the binaries' paths.
mod common;

use base64::Engine;
use common::*;
use serde_json::{json, Value};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use wedge::server::ServerConfig;

fn browser_enabled() -> bool {
    std::env::var("WEDGE_TEST_BROWSER").is_ok_and(|v| v == "1")
}

fn env_or(var: &str, default: &str) -> String {
    std::env::var(var).unwrap_or_else(|_| default.to_string())
}

/// One HTTP/1.1 exchange with JSON bodies; the reply's body as JSON. chromedriver keeps the
/// connection open, so the body is read by its Content-Length.
fn http(addr: &str, method: &str, path: &str, body: Option<&Value>) -> std::io::Result<Value> {
    let mut s = TcpStream::connect(addr)?;
    s.set_read_timeout(Some(Duration::from_secs(60)))?;
    let body = body.map(Value::to_string).unwrap_or_default();
    write!(
        s,
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )?;
    let mut reply = Vec::new();
    let mut buf = [0u8; 65536];
    let (head_end, length) = loop {
        let n = s.read(&mut buf)?;
        if n == 0 {
            return Err(std::io::Error::other("connection closed before the reply's headers"));
        }
        reply.extend_from_slice(&buf[..n]);
        if let Some(i) = reply.windows(4).position(|w| w == b"\r\n\r\n") {
            let head = String::from_utf8_lossy(&reply[..i]).to_ascii_lowercase();
            let length = head
                .lines()
                .find_map(|l| l.strip_prefix("content-length:"))
                .and_then(|v| v.trim().parse::<usize>().ok())
                .ok_or_else(|| std::io::Error::other(format!("no content-length in {head}")))?;
            break (i + 4, length);
        }
    };
    while reply.len() < head_end + length {
        let n = s.read(&mut buf)?;
        if n == 0 {
            break;
        }
        reply.extend_from_slice(&buf[..n]);
    }
    let body = String::from_utf8_lossy(&reply[head_end..]);
    serde_json::from_str(&body).map_err(|e| std::io::Error::other(format!("{e}: {body}")))
}

/// chromedriver and one browser session; both end when dropped.
struct Browser {
    driver: Child,
    addr: String,
    session: String,
    profile: std::path::PathBuf,
}

impl Browser {
    fn start() -> Browser {
        let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let chromedriver = env_or("WEDGE_CHROMEDRIVER", "/usr/bin/chromedriver");
        let driver = Command::new(&chromedriver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("{chromedriver}: {e} (install chromium-driver)"));
        let addr = format!("127.0.0.1:{port}");
        let t0 = Instant::now();
        while !http(&addr, "GET", "/status", None).is_ok_and(|v| v["value"]["ready"] == json!(true)) {
            assert!(t0.elapsed() < Duration::from_secs(20), "chromedriver did not start");
            std::thread::sleep(Duration::from_millis(100));
        }
        let profile = std::env::temp_dir().join(format!("wedge-chromium-{}-{port}", std::process::id()));
        // As Debian's Chromium needs it in a container, and without reaching for the network.
        let args = [
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--window-size=900,900",
        ];
        let mut args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        args.push(format!("--user-data-dir={}", profile.display()));
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {"binary": env_or("WEDGE_CHROMIUM", "/usr/bin/chromium"), "args": args},
        }}});
        let mut browser = Browser { driver, addr, session: String::new(), profile };
        let reply = browser.call("POST", "/session", Some(&caps));
        browser.session = reply["sessionId"].as_str().unwrap_or_else(|| panic!("no browser session: {reply}")).into();
        browser
    }

    fn call(&self, method: &str, path: &str, body: Option<&Value>) -> Value {
        let reply = http(&self.addr, method, path, body).unwrap_or_else(|e| panic!("{method} {path}: {e}"));
        assert!(reply["value"].get("error").is_none(), "{method} {path}: {reply}");
        reply["value"].clone()
    }

    fn session_call(&self, method: &str, path: &str, body: Option<&Value>) -> Value {
        self.call(method, &format!("/session/{}{path}", self.session), body)
    }

    fn script(&self, script: &str) -> Value {
        self.session_call("POST", "/execute/sync", Some(&json!({"script": script, "args": []})))
    }

    /// The page's `wedgeViewer.status()`.
    fn viewer(&self) -> Value {
        self.script("return window.wedgeViewer ? window.wedgeViewer.status() : null;")
    }

    /// Waits for the viewer's status to satisfy `cond`, and returns it.
    fn wait_for(&self, what: &str, secs: u64, cond: impl Fn(&Value) -> bool) -> Value {
        let t0 = Instant::now();
        loop {
            let status = self.viewer();
            if cond(&status) {
                return status;
            }
            assert!(t0.elapsed() < Duration::from_secs(secs), "{what}: not within {secs} s; viewer: {status}");
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// The page as a PNG, decoded.
    fn screenshot(&self) -> image::RgbaImage {
        let b64 = self.session_call("GET", "/screenshot", None);
        let png = base64::engine::general_purpose::STANDARD.decode(b64.as_str().unwrap()).unwrap();
        image::load_from_memory(&png).expect("a PNG").to_rgba8()
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if !self.session.is_empty() {
            let _ = http(&self.addr, "DELETE", &format!("/session/{}", self.session), None);
        }
        let _ = self.driver.kill();
        let _ = self.driver.wait();
        let _ = std::fs::remove_dir_all(&self.profile);
    }
}

/// Frames of generations after the first that the viewer received at full resolution.
fn later_frames(status: &Value) -> u64 {
    let frames = status["frames"].as_object().cloned().unwrap_or_default();
    frames.iter().filter(|(g, _)| g.parse::<u64>().unwrap_or(0) > 1).map(|(_, n)| n.as_u64().unwrap_or(0)).sum()
}

/// Pass `pass` of a native Render with the request the page opens its session with.
async fn native_frame(server: &TestServer, pass: u64) -> wedge::pipeline::frame::Frame {
    use wedge::proto::{render_request::SceneSource, OutputSelection, PixelFormat, RenderRequest, RenderSettings};
    let req = RenderRequest {
        scene_source: Some(SceneSource::Builtin("cornell".into())),
        width: 320,
        height: 240,
        seed: 1,
        settings: Some(RenderSettings::default()),
        outputs: Some(OutputSelection {
            color: true,
            spp: true,
            filter_width: true,
            components: true,
            format: PixelFormat::F16 as i32,
            ..Default::default()
        }),
        ..Default::default()
    };
    let mut stream = server.client().await.render(req).await.unwrap().into_inner();
    let mut asm = wedge::server::FrameAssembler::new();
    while let Some(update) = stream.message().await.unwrap() {
        if let Some(frame) = asm.push(update).unwrap() {
            if u64::from(frame.stats.pass) == pass {
                return frame;
            }
        }
    }
    panic!("the native render ended before pass {pass}");
}

/// A server with the web viewer on, and a browser showing it on `cornell` with its first
/// full-resolution frame; None (the test skipped) unless WEDGE_TEST_BROWSER=1.
fn open_viewer() -> Option<(tokio::runtime::Runtime, TestServer, Browser, Value)> {
    if !browser_enabled() {
        eprintln!("skipped: set WEDGE_TEST_BROWSER=1 with chromium and chromium-driver installed");
        return None;
    }
    let runtime = tokio::runtime::Runtime::new().unwrap();
    let server = runtime.block_on(TestServer::with_config(ServerConfig { web: true, ..Default::default() }));
    let browser = Browser::start();
    browser.session_call("POST", "/url", Some(&json!({"url": format!("http://{}/?scene=cornell", server.addr)})));
    let first = browser.wait_for("the first full-resolution frame", 60, |s| s["frames"]["1"].as_u64() >= Some(1));
    Some((runtime, server, browser, first))
}

#[test]
fn the_viewer_shows_frames_and_a_drag_moves_the_camera() {
    let Some((runtime, server, browser, first)) = open_viewer() else { return };
    assert!(first["session_id"].as_str().is_some_and(|id| id.len() == 32), "{first}");
    assert_eq!(first["shown"]["width"], json!(320), "{first}");
    for layer in ["color", "spp", "filter_width"] {
        assert!(first["layers"].as_array().unwrap().contains(&json!(layer)), "no {layer} layer: {first}");
    }
    let before = browser.screenshot();

    // What the page decoded is what a native client gets: row sums of the shown frame equal
    // those of the same pass of a Render with the page's request (rows out of place or a
    // misread format would not).
    let shown = browser.script("return window.wedgeViewer.rowSums();");
    assert_eq!((shown["generation"].as_u64(), shown["preview"].as_bool()), (Some(1), Some(false)), "{shown}");
    let pass = shown["pass"].as_u64().unwrap();
    let native = runtime.block_on(native_frame(&server, pass));
    let sums: Vec<f64> = shown["sums"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(sums.len(), native.height as usize);
    for (y, (got, row)) in sums.iter().zip(native.color.chunks(native.width as usize)).enumerate() {
        let want: f64 = row.iter().flatten().map(|&v| f64::from(v)).sum();
        assert!((got - want).abs() <= 1e-9 * want.abs().max(1.0), "row {y}: page {got}, native {want}");
    }

    // Drag across the image: the camera orbits.
    let canvas = browser.session_call("POST", "/element", Some(&json!({"using": "css selector", "value": "#view"})));
    let pointer = json!({"actions": [{
        "type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"},
        "actions": [
            {"type": "pointerMove", "duration": 0, "origin": canvas, "x": 0, "y": 0},
            {"type": "pointerDown", "button": 0},
            {"type": "pointerMove", "duration": 200, "origin": "pointer", "x": 60, "y": 10},
            {"type": "pointerMove", "duration": 200, "origin": "pointer", "x": 60, "y": 10},
            {"type": "pointerUp", "button": 0},
        ],
    }]});
    browser.session_call("POST", "/actions", Some(&pointer));

    let after = browser.wait_for("a full-resolution frame of a new generation that differs", 60, |s| {
        later_frames(s) >= 1 && s["difference_from_first"].as_f64().is_some_and(|d| d > 0.05)
    });
    assert!(after["generation"].as_u64() >= Some(2), "{after}");
    assert!(after["shown"]["generation"].as_u64() >= Some(2), "{after}");
    assert_eq!(after["errors"], json!([]), "{after}");
    assert_eq!(after["ended"], Value::Null, "{after}");

    // The screenshots agree: the image region changed.
    let now = browser.screenshot();
    // Kept for a look: target/tmp/viewer-{before,after}-drag.png.
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    before.save(dir.join("viewer-before-drag.png")).unwrap();
    now.save(dir.join("viewer-after-drag.png")).unwrap();
    assert_eq!(before.dimensions(), now.dimensions());
    let changed =
        before.pixels().zip(now.pixels()).filter(|(a, b)| a.0.iter().zip(b.0).any(|(x, y)| x.abs_diff(y) > 24));
    let fraction = changed.count() as f64 / f64::from(before.width() * before.height());
    assert!(fraction > 0.05, "only {:.1}% of the screenshot changed", 100.0 * fraction);

    // The maps: choosing one shows it in false colour with its legend.
    let legend = browser.script(
        "const s = document.getElementById('layer'); s.value = 'spp'; s.dispatchEvent(new Event('change'));
         return !document.getElementById('legend').hidden;",
    );
    assert_eq!(legend, json!(true));
    browser.screenshot().save(dir.join("viewer-spp-map.png")).unwrap();
    drop(browser);
    runtime.block_on(server.stop(Duration::from_secs(10))).unwrap();
}

/// The rest of the page: every map in the layer menu shows with its legend and the status line
/// names generation, pass, spp and time; the mouse wheel zooms (a new generation); a scene file
/// chosen in the file input is uploaded and its session renders.
#[test]
fn the_viewer_shows_every_map_zooms_and_opens_an_uploaded_scene() {
    let Some((runtime, server, browser, first)) = open_viewer() else { return };

    // Every map in the menu, with its legend; the colour without one.
    let maps = browser.script(
        "const s = document.getElementById('layer'), legend = document.getElementById('legend');
         const out = [];
         for (const o of [...s.options]) {
           s.value = o.value; s.dispatchEvent(new Event('change'));
           out.push([o.value, !legend.hidden, document.getElementById('status').textContent]);
         }
         return out;",
    );
    let maps = maps.as_array().unwrap();
    let names: Vec<&str> = maps.iter().map(|m| m[0].as_str().unwrap()).collect();
    for wanted in ["color", "spp", "filter_width"] {
        assert!(names.contains(&wanted), "no {wanted} in the menu: {names:?}");
    }
    assert!(names.iter().any(|n| n.contains('.')), "no per-component map in the menu: {names:?} ({first})");
    for m in maps {
        let (name, legend, status) = (m[0].as_str().unwrap(), m[1].as_bool().unwrap(), m[2].as_str().unwrap());
        assert_eq!(legend, name != "color", "{name}: legend shown {legend}");
        let words: Vec<&str> = status.split(" · ").collect();
        assert!(words[0].starts_with("generation "), "{name}: status {status:?}");
        assert!(words.iter().any(|w| w.starts_with("pass ")), "{name}: status {status:?}");
        assert!(words.iter().any(|w| w.ends_with(" spp")) && words.iter().any(|w| w.ends_with(" s")), "{status:?}");
    }

    // The wheel zooms: a new generation renders.
    browser.script(
        "document.getElementById('view').dispatchEvent(new WheelEvent('wheel', {deltaY: 120, bubbles: true, cancelable: true}));
         return null;",
    );
    browser.wait_for("a frame of the zoomed view", 60, |s| later_frames(s) >= 1);

    // A scene file chosen in the page: uploaded, selected by its digest, rendered.
    let scene = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.json")).unwrap();
    let session = browser.viewer()["session_id"].clone();
    browser.session_call(
        "POST",
        "/execute/sync",
        Some(&json!({"script": "const input = document.getElementById('file'), t = new DataTransfer();
             t.items.add(new File([arguments[0]], 'box.json', {type: 'application/json'}));
             input.files = t.files; input.dispatchEvent(new Event('change')); return null;", "args": [scene]})),
    );
    let uploaded = browser.wait_for("a frame of the uploaded scene's session", 60, |s| {
        s["session_id"] != session && s["frames"]["1"].as_u64() >= Some(1)
    });
    assert_eq!(uploaded["errors"], json!([]), "{uploaded}");
    let chosen = browser.script("return document.getElementById('scene').value;");
    assert!(chosen.as_str().is_some_and(|v| v.starts_with("sha256:")), "{chosen}");
    drop(browser);
    runtime.block_on(server.stop(Duration::from_secs(10))).unwrap();
}

/// Sends `request` and reads the reply until the server closes the connection.
fn exchange(addr: std::net::SocketAddr, request: &[u8]) -> Vec<u8> {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    s.write_all(request).unwrap();
    let mut reply = Vec::new();
    let _ = s.read_to_end(&mut reply);
    reply
}

/// A gRPC-web call over HTTP/1.1: the request line, headers and one framed message.
fn grpc_web_request(path: &str, message: &[u8]) -> Vec<u8> {
    let mut body = vec![0u8];
    body.extend_from_slice(&u32::try_from(message.len()).unwrap().to_be_bytes());
    body.extend_from_slice(message);
    let mut req = format!(
        "POST {path} HTTP/1.1\r\nHost: x\r\ncontent-type: application/grpc-web+proto\r\nx-grpc-web: 1\r\ncontent-length: {}\r\nconnection: close\r\n\r\n",
        body.len()
    )
    .into_bytes();
    req.extend_from_slice(&body);
    req
}

#[test]
fn the_page_and_grpc_web_are_served_only_with_web_on() {
    use prost::Message;
    let runtime = tokio::runtime::Runtime::new().unwrap();
    let get = b"GET / HTTP/1.1\r\nHost: x\r\nconnection: close\r\n\r\n";

    let web = runtime.block_on(TestServer::with_config(ServerConfig { web: true, ..Default::default() }));
    let page = String::from_utf8(exchange(web.addr, get)).unwrap();
    assert!(page.starts_with("HTTP/1.1 200"), "{page}");
    assert!(page.contains("<title>wedge viewer</title>"), "{page}");
    let missing = String::from_utf8(exchange(web.addr, b"GET /secret HTTP/1.1\r\nconnection: close\r\n\r\n")).unwrap();
    assert!(missing.starts_with("HTTP/1.1 404"), "{missing}");

    // ListScenes over gRPC-web: one data frame, then the trailers frame with an OK status.
    let reply = exchange(web.addr, &grpc_web_request("/wedge.v1.Renderer/ListScenes", &[]));
    let at = reply.windows(4).position(|w| w == b"\r\n\r\n").expect("headers") + 4;
    let head = String::from_utf8_lossy(&reply[..at]).to_ascii_lowercase();
    assert!(head.starts_with("http/1.1 200") && head.contains("application/grpc-web"), "{head}");
    let body = dechunk_bytes(&reply[at..], head.contains("transfer-encoding: chunked"));
    assert_eq!(body[0], 0, "a data frame first");
    let n = u32::from_be_bytes(body[1..5].try_into().unwrap()) as usize;
    let scenes = wedge::proto::ListScenesResponse::decode(&body[5..5 + n]).unwrap();
    assert!(scenes.scenes.iter().any(|s| s.name == "cornell"), "{scenes:?}");
    assert_eq!(body[5 + n], 0x80, "then the trailers");
    let trailers = String::from_utf8_lossy(&body[5 + n + 5..]).to_ascii_lowercase();
    assert!(trailers.contains("grpc-status:0"), "{trailers}");
    runtime.block_on(web.stop(Duration::from_secs(10))).unwrap();

    // Off (the default): HTTP/1.1 is not spoken at all, so neither the page nor gRPC-web is.
    let plain = runtime.block_on(TestServer::start());
    let reply = exchange(plain.addr, get);
    assert!(!reply.starts_with(b"HTTP/1.1 200"), "{}", String::from_utf8_lossy(&reply));
    runtime.block_on(plain.stop(Duration::from_secs(10))).unwrap();
}

/// A body sent with chunked transfer encoding, joined.
fn dechunk_bytes(mut body: &[u8], chunked: bool) -> Vec<u8> {
    if !chunked {
        return body.to_vec();
    }
    let mut out = Vec::new();
    while let Some(eol) = body.windows(2).position(|w| w == b"\r\n") {
        let n = usize::from_str_radix(std::str::from_utf8(&body[..eol]).unwrap().trim(), 16).unwrap();
        if n == 0 {
            break;
        }
        out.extend_from_slice(&body[eol + 2..eol + 2 + n]);
        body = &body[eol + 2 + n + 2..];
    }
    out
}

//! The server's logs cannot be forged by what a client sends: a scene name holding a newline
//! and terminal escapes stays one escaped log field, and every line about a call carries its
//! request id. The log is captured from a real server on 127.0.0.1.
mod common;

use common::*;
use std::io::Write;
use std::sync::{Arc, Mutex};
use tonic::Code;
use wedge::proto::{render_request::SceneSource, RenderRequest};

/// A `MakeWriter` appending to a shared buffer.
#[derive(Clone, Default)]
struct Captured(Arc<Mutex<Vec<u8>>>);

impl Write for Captured {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn client_strings_cannot_forge_log_lines() {
    let log = Captured::default();
    let writer = log.clone();
    tracing_subscriber::fmt()
        .with_ansi(false)
        .with_max_level(tracing_subscriber::filter::LevelFilter::INFO)
        .with_writer(move || writer.clone())
        .init();

    let server = TestServer::start().await;
    let forged = "nope\nFORGED-LOG-LINE level=INFO \u{1b}[2Jcleared";
    let req = RenderRequest { scene_source: Some(SceneSource::Builtin(forged.into())), ..Default::default() };
    let status = server.client().await.render(req).await.expect_err("unknown scene");
    assert_eq!(status.code(), Code::InvalidArgument);
    // A render that starts logs its scene too.
    collect(&mut server.client().await, cornell(8, 8, 1, 1)).await.expect("render");

    let text = String::from_utf8(log.0.lock().unwrap().clone()).unwrap();
    assert!(!text.lines().any(|l| l.starts_with("FORGED")), "a forged line:\n{text}");
    assert!(!text.contains('\u{1b}'), "a raw escape sequence:\n{text}");
    let rejected: Vec<&str> = text.lines().filter(|l| l.contains("rejected render")).collect();
    assert_eq!(rejected.len(), 1, "{text}");
    assert!(rejected[0].contains("nope\\nFORGED-LOG-LINE"), "{}", rejected[0]);
    assert!(rejected[0].contains("request=1"), "{}", rejected[0]);
    let started: Vec<&str> = text.lines().filter(|l| l.contains("render started")).collect();
    assert!(started.len() == 1 && started[0].contains("request=2"), "{text}");
}

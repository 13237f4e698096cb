//! The Python client package (clients/python) against a real server: its own unittest suite
//! (renders and sessions as numpy arrays, the interactive example driven through its standard
//! input) runs with the server's address in WEDGE_ADDR.
//!
//! Needs the package installed (`python3 -m pip install clients/python`, which generates its
//! stubs from the proto); `.ci/run` installs it and sets WEDGE_TEST_GRPCIO=1, which makes this
//! test mandatory. Without that variable it is skipped.
mod common;

use common::*;
use std::process::Command;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_python_client_suite_passes() {
    if !std::env::var("WEDGE_TEST_GRPCIO").is_ok_and(|v| v == "1") {
        eprintln!("skipped: set WEDGE_TEST_GRPCIO=1 with clients/python installed");
        return;
    }
    let server = TestServer::start().await;
    let tests = concat!(env!("CARGO_MANIFEST_DIR"), "/clients/python/tests");
    let python = std::env::var("WEDGE_TEST_PYTHON").unwrap_or_else(|_| "python3".to_string());
    let addr = server.addr_str();
    let run = tokio::task::spawn_blocking(move || {
        Command::new(python)
            .args(["-m", "unittest", "discover", "-v", "-s", tests])
            // Not the package's source directory, whose wedge_client has no generated stubs.
            .current_dir(std::env::temp_dir())
            .env("WEDGE_ADDR", addr)
            .output()
    });
    let out = within(300, "the Python client's tests", run).await.expect("join").expect("run python");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    // unittest reports on stderr: every test ran, none was skipped.
    assert!(stderr.contains("\nRan ") && !stderr.contains("skipped="), "{stderr}");
    assert!(stderr.trim_end().ends_with("OK"), "{stderr}");
}

//! The `wedge` binary: `render` and `client` write identical files; bad input gets a clear
//! message naming the file and line, and a non-zero exit, never a panic.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use wedge::server::{serve_on, ServerConfig, ServerState};

fn wedge(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wedge")).args(args).env("RUST_LOG", "warn").output().expect("run wedge")
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("wedge-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

const ARGS: &[&str] = &["--width", "40", "--height", "30", "--seed", "11", "--max-passes", "3", "--reproducible"];

/// Runs `wedge render` and `wedge client` (against an in-process server) with `ARGS` and
/// `extra`, writing every pass; returns the temporary directory and the two output directories.
async fn render_and_client(name: &str, extra: &[&str]) -> (PathBuf, PathBuf, PathBuf) {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = format!("http://{}", listener.local_addr().unwrap());
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(serve_on(listener, ServerConfig::default(), ServerState::new(), async {
        let _ = rx.await;
    }));
    let dir = temp_dir(name);
    let (local, remote) = (dir.join("local"), dir.join("remote"));
    let (l, r) = (local.to_str().unwrap().to_string(), remote.to_str().unwrap().to_string());
    let extra: Vec<String> = extra.iter().map(|a| a.to_string()).collect();
    let out = tokio::task::spawn_blocking(move || {
        let mut a = vec!["render", "cornell", "--out", &l, "--every", "1"];
        a.extend(ARGS);
        a.extend(extra.iter().map(String::as_str));
        let o1 = wedge(&a);
        let mut b = vec!["client", "--addr", &addr, "cornell", "--out", &r, "--every", "1"];
        b.extend(ARGS);
        b.extend(extra.iter().map(String::as_str));
        (o1, wedge(&b))
    })
    .await
    .unwrap();
    assert!(out.0.status.success(), "render: {}", stderr(&out.0));
    assert!(out.1.status.success(), "client: {}", stderr(&out.1));
    let _ = tx.send(());
    server.await.unwrap().unwrap();
    (dir, local, remote)
}

fn assert_identical(local: &Path, remote: &Path, names: &[&str]) {
    for name in names {
        let a = std::fs::read(local.join(name)).unwrap();
        let b = std::fs::read(remote.join(name)).unwrap();
        assert!(a == b, "{name} differs between render and client");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn render_and_client_write_byte_identical_files() {
    let (dir, local, remote) = render_and_client("identical", &["--method", "uniform"]).await;
    assert_identical(&local, &remote, &["final.exr", "pass_000.exr", "pass_002.exr", "final.png", "final_spp.png"]);
    // The header says what produced it.
    let exr = wedge::output::read_exr(&local.join("final.exr")).unwrap();
    assert_eq!(exr.info.method, "uniform");
    assert_eq!(exr.info.seed, 11);
    assert_eq!(exr.info.scene, "cornell");
    assert_eq!(exr.frame.stats.mean_spp, 4.0);
    assert!(exr.frame.stats.is_final);
    assert!(exr.frame.components.is_empty());
    assert!(!local.join("final_spp.shadow.png").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn client_files_carry_the_component_maps() {
    let (dir, local, remote) = render_and_client("components", &["--method", "aaf", "--bounces", "1"]).await;
    let maps = ["final_spp.shadow.png", "final_filter_width.shadow.png", "final_spp.diffuse.png"];
    let files = ["final.exr", "pass_001.exr", "final_filter_width.diffuse.png"];
    assert_identical(&local, &remote, &[&maps[..], &files[..]].concat());
    let exr = wedge::output::read_exr(&remote.join("final.exr")).unwrap();
    let names: Vec<&str> = exr.frame.components.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names[..2], ["shadow", "diffuse"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn bad_scene_files_get_file_and_line() {
    let dir = temp_dir("errors");
    let syntax = write(&dir, "syntax.json", "{\n  \"camera\": {\n    \"widht\": 3\n  }\n}\n");
    let o = wedge(&["render", &syntax, "--out", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains(&format!("{syntax}:3:")) && e.contains("widht"), "{e}");

    let semantic = write(
        &dir,
        "semantic.json",
        r#"{
  "camera": {"position": {"z": 5}, "lookAt": {}, "verticalFovDeg": 40, "width": 8, "height": 8},
  "materials": [{"name": "m", "lambertian": {"albedo": {"constant": {"r": 0.5, "g": 0.5, "b": 0.5}}}}],
  "shapes": [{"material": "m", "sphere": {"center": {}, "radius": 1}}],
  "lights": [
    {"point": {"position": {"y": 3}, "intensity": {"r": "NaN", "g": 1, "b": 1}}}
  ]
}"#,
    );
    let o = wedge(&["render", &semantic, "--out", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains(&format!("{semantic}:6: scene.lights[0].point.intensity.r")), "{e}");
    assert!(!e.contains("panicked"), "{e}");

    let o = wedge(&["render", "no-such-scene"]);
    assert!(stderr(&o).contains("no such scene file") && stderr(&o).contains("cornell"), "{}", stderr(&o));
    let o = wedge(&["render", "cornell", "--method", "magic", "--out", dir.to_str().unwrap()]);
    assert!(stderr(&o).contains("--method magic: unknown method"), "{}", stderr(&o));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn scenes_lists_the_builtins() {
    let o = wedge(&["scenes"]);
    let out = String::from_utf8_lossy(&o.stdout);
    for name in ["cornell", "grids", "curved", "cornell-glossy", "interior"] {
        assert!(out.contains(name), "{out}");
    }
}

/// The noise bench's time limit: a target no render reaches stops at it and its row says so,
/// and a limit that is not a positive number of seconds is refused by name.
#[test]
fn the_noise_bench_stops_a_render_that_never_reaches_its_target() {
    let args = ["bench", "noise", "--scenes", "grids", "--width", "16", "--height", "12", "--methods", "uniform"];
    let quick = [&args[..], &["--reference-spp", "16", "--targets", "0.00001", "--max-seconds", "0.2"]].concat();
    let o = wedge(&quick);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("| grids | uniform | 0.00001 |") && out.contains("(not halted by the target)"), "{out}");
    let o = wedge(&[&args[..], &["--max-seconds", "0"]].concat());
    assert!(!o.status.success() && stderr(&o).contains("--max-seconds"), "{}", stderr(&o));
}

/// `wedge bench session` prints one line per method in the form scripts read.
#[test]
fn the_session_bench_prints_its_line_per_method() {
    let o = wedge(&[
        "bench",
        "session",
        "--scene",
        "cornell",
        "--width",
        "32",
        "--height",
        "24",
        "--method",
        "uniform",
        "--updates",
        "6",
        "--rate",
        "30",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let line = out.lines().find(|l| l.starts_with("uniform: ")).unwrap_or_else(|| panic!("no uniform line: {out}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    assert_eq!(words.len(), 11, "{line}");
    let (median, p95): (f64, f64) = (words[2].parse().unwrap(), words[5].parse().unwrap());
    let (dropped, total): (u64, u64) = (words[8].parse().unwrap(), words[10].parse().unwrap());
    assert_eq!(
        [words[1], words[3], words[4], words[6], words[7], words[9]],
        ["median", "ms,", "p95", "ms,", "dropped", "of"]
    );
    assert!(median <= p95 && dropped <= total && total >= 6, "{line}");
}

#[test]
fn ambient_occlusion_renders_an_open_fraction() {
    let dir = temp_dir("ao");
    let d = dir.to_str().unwrap();
    let size = ["--width", "24", "--height", "18", "--max-passes", "8"];
    let o = wedge(&[&["render", "interior", "--ao", "--method", "aaf", "--out", d][..], &size].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let exr = wedge::output::read_exr(&dir.join("final.exr")).unwrap();
    // A closed room: every hemisphere is covered. (The triangle test is not watertight: about
    // one ray in a million slips through an edge where two walls meet, and the filter spreads
    // it over a few pixels; AAF traces thousands of samples per pixel here.)
    let open: Vec<f32> = exr.frame.color.iter().map(|c| c[0]).collect();
    let mean = open.iter().map(|&v| v as f64).sum::<f64>() / open.len() as f64;
    assert!(mean < 1e-4 && open.iter().all(|&v| v < 1e-2), "open directions inside the closed room: mean {mean}");
    let o = wedge(&[&["render", "interior", "--ao", "--ao-distance", "0.5", "--out", d][..], &size].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let exr = wedge::output::read_exr(&dir.join("final.exr")).unwrap();
    let mean = exr.frame.color.iter().map(|c| c[0] as f64).sum::<f64>() / exr.frame.color.len() as f64;
    assert!(mean > 0.5 && mean < 1.0, "mean open fraction within 0.5 m: {mean}");
    // The distance needs --ao.
    let o = wedge(&["render", "interior", "--ao-distance", "0.5", "--out", d]);
    assert!(!o.status.success() && stderr(&o).contains("--ao"), "{}", stderr(&o));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn serve_refuses_an_exposed_address_without_tls_and_a_token() {
    let o = wedge(&["serve", "--addr", "0.0.0.0:0"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("refusing to serve on 0.0.0.0:0 without TLS and a bearer token") && e.contains("--insecure"),
        "{e}"
    );

    // A token alone is not enough; a token file with a bad token names the file and line.
    let dir = temp_dir("tokens");
    let good = dir.join("good");
    std::fs::write(&good, "# tokens\nthis-is-a-long-enough-token\n").unwrap();
    let o = wedge(&["serve", "--addr", "0.0.0.0:0", "--token-file", good.to_str().unwrap()]);
    assert!(stderr(&o).contains("without TLS:"), "{}", stderr(&o));
    let bad = dir.join("bad");
    std::fs::write(&bad, "this-is-a-long-enough-token\nshort\n").unwrap();
    let o = wedge(&["serve", "--token-file", bad.to_str().unwrap()]);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("bad: line 2: a token must have at least 16"), "{e}");
    let o = wedge(&["serve", "--tls-cert", good.to_str().unwrap(), "--tls-key", good.to_str().unwrap()]);
    assert!(stderr(&o).contains("not a PEM file"), "{}", stderr(&o));
}

/// `wedge bench --set`: a setting is applied to the methods and named in the report's heading;
/// a value outside its limits or an unknown name is refused before anything renders.
#[test]
fn bench_settings_are_applied_and_bad_ones_refused_by_name() {
    let dir = temp_dir("bench-set");
    let base = [
        "bench",
        "cornell",
        "--width",
        "16",
        "--height",
        "12",
        "--reference-spp",
        "16",
        "--uniform-passes",
        "2",
        "--passes",
        "2",
        "--repeats",
        "1",
        "--methods",
        "uniform,auto",
        "--out",
    ];
    let args = [&base[..], &[dir.to_str().unwrap(), "--set", "auto.narrow_scale=0.25"]].concat();
    let o = wedge(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("auto.narrow_scale=0.25;"), "{out}");
    for (bad, says) in [
        ("auto.narrow_scale=2", "auto.narrow_scale: \"2\" is not a number from 0 to 1"),
        ("auto.nope=1", "no such setting; auto has reference_spp"),
    ] {
        let o = wedge(&[&base[..], &[dir.to_str().unwrap(), "--set", bad]].concat());
        assert!(!o.status.success() && stderr(&o).contains(says), "{bad}: {}", stderr(&o));
    }
}

/// `wedge render --set` applies a setting (the output differs from the default's) and refuses
/// a bad one by name; `wedge client` refuses the flag, which a server would not honour.
#[test]
fn render_settings_are_applied_and_the_client_refuses_them() {
    let dir = temp_dir("render-set");
    let out = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let render = |name: &str, extra: &[&str]| {
        let o = out(name);
        let mut a = vec!["render", "cornell", "--bounces", "1", "--out", &o];
        a.extend(ARGS);
        a.extend(extra);
        wedge(&a)
    };
    let plain = render("plain", &[]);
    let set = render("set", &["--set", "auto.beta=2"]);
    assert!(plain.status.success() && set.status.success(), "{}{}", stderr(&plain), stderr(&set));
    let read = |name: &str| std::fs::read(dir.join(name).join("final.exr")).unwrap();
    assert_ne!(read("plain"), read("set"), "auto.beta=2 must change the filtered image");
    let bad = render("bad", &["--set", "auto.beta=-1"]);
    assert!(!bad.status.success() && stderr(&bad).contains("auto.beta"), "{}", stderr(&bad));
    let client = wedge(&["client", "cornell", "--addr", "http://127.0.0.1:9", "--set", "auto.beta=2"]);
    assert!(!client.status.success() && stderr(&client).contains("`wedge render` only"), "{}", stderr(&client));
}

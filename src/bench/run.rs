//! `wedge bench`: for each scene, a reference, then every method's progressive sweep over a
//! few seeds; medians per pass (RMSE, relative MSE, FLIP), equal-error speedups over uniform,
//! consistency; written as JSON, CSV, Markdown and log-log plots (SVG and PNG), and on request
//! each method's FLIP error map of its last frame.
use super::convergence::{consistent, relative_speedup, speedup, sweep, Point};
use super::plot::{self, Series};
use super::reference::{cached_reference, load_reference, ReferenceKey};
use super::{machine_description, median};
use crate::pipeline::job::Method;
use crate::proto;
use crate::scene::{compile, SceneLimits};
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub struct BenchConfig {
    pub width: u32,
    pub height: u32,
    pub reference_spp: f64,
    /// A given reference image instead of a rendered one (one scene only).
    pub reference: Option<PathBuf>,
    pub methods: Vec<Method>,
    /// Passes of the uniform sweep (1, 2, 4, ... spp) and of the other methods.
    pub uniform_passes: u32,
    pub passes: u32,
    pub repeats: u32,
    pub seed: u64,
    /// Indirect bounces for every scene (None: each scene's own setting).
    pub bounces: Option<u32>,
    /// Shade pixel centres (no antialiasing), the AAF papers' setting, in every render
    /// including the reference.
    pub pixel_centers: bool,
    /// Scale of the indirect filter's standard deviation (None: the paper's beta; 0.25: the
    /// authors' code).
    pub indirect_kernel_scale: Option<f64>,
    /// mu of the soft-shadow strategy's pass 1, doubled by each later pass; the first frame
    /// keeps `AafOptions::first_mu` (None: `AafOptions::default`).
    pub shadow_mu0: Option<f64>,
    /// The soft-shadow analysis takes a Gaussian light's profile sigma (`LightSigma::Profile`).
    pub shadow_profile_sigma: bool,
    /// Also write each method's FLIP error map of its last frame (first seed) as a PNG.
    pub flip_maps: bool,
    /// Glossy lobes as ASGs (Tokuyoshi's Eq. 13, `LobeShape::Asg`).
    pub asg_lobes: bool,
    /// The lobe- and normal-aware methods' upsampling factor.
    pub upsample: Option<u32>,
    /// Method options set by name (`RenderJob::set`), checked when parsed.
    pub settings: Vec<String>,
    /// Leave out of every error the pixels whose reference exceeds this in some channel and
    /// their neighbours (`convergence::kept_pixels`): a light in view.
    pub exclude_above: Option<f32>,
    pub out: PathBuf,
    pub name: String,
    /// The command line, recorded in the report.
    pub command: String,
}

/// One method's curve: the median over repeats at each pass.
pub struct Curve {
    pub method: Method,
    pub points: Vec<Point>,
}

pub struct SceneResult {
    pub name: String,
    pub bounces: u32,
    pub reference_note: String,
    pub runs: Vec<(u32, Point)>,
    pub curves: Vec<Curve>,
    /// Each method's last frame of its first seed, and the reference (for the FLIP maps).
    pub last_frames: Vec<(Method, crate::pipeline::frame::Frame)>,
    pub reference: crate::pipeline::frame::Frame,
    /// Pixels the errors count, and how many were left out.
    pub excluded: usize,
}

fn median_curve(method: Method, runs: &[Vec<Point>]) -> Curve {
    let passes = runs.iter().map(Vec::len).min().unwrap_or(0);
    let points = (0..passes)
        .map(|k| {
            let m = |f: &dyn Fn(&Point) -> f64| median(runs.iter().map(|r| f(&r[k])).collect());
            Point {
                method,
                pass: k as u32,
                mean_spp: m(&|p| p.mean_spp),
                seconds: m(&|p| p.seconds),
                method_seconds: m(&|p| p.method_seconds),
                cpu_seconds: runs
                    .iter()
                    .all(|r| r[k].cpu_seconds.is_some())
                    .then(|| m(&|p| p.cpu_seconds.unwrap_or(0.0))),
                rays: m(&|p| p.rays as f64) as u64,
                rmse: m(&|p| p.rmse),
                rel_mse: m(&|p| p.rel_mse),
                flip: m(&|p| p.flip),
            }
        })
        .collect();
    Curve { method, points }
}

/// Runs the benchmark on one scene (a built-in name or a scene file's message; `base_dir`, a
/// scene file's directory, is where the files it names are looked up and must lie).
pub fn bench_scene(
    name: &str,
    mut scene: proto::Scene,
    base_dir: Option<&Path>,
    cfg: &BenchConfig,
) -> anyhow::Result<SceneResult> {
    if let Some(c) = scene.camera.as_mut() {
        (c.width, c.height) = (cfg.width, cfg.height);
    }
    let bounces = cfg.bounces.unwrap_or_else(|| scene.settings.as_ref().and_then(|s| s.bounces).unwrap_or(0));
    // A scene file's mesh and map files must lie under its own directory, as for `wedge render`.
    let limits = SceneLimits { mesh_root: base_dir.map(Path::to_path_buf), ..SceneLimits::default() };
    let compiled = Arc::new(compile(&scene, &limits, base_dir)?);
    let t = std::time::Instant::now();
    let (reference, reference_note) = match &cfg.reference {
        Some(path) => (load_reference(path, cfg.width, cfg.height)?, format!("given: {}", path.display())),
        None => {
            let key = ReferenceKey {
                scene: &scene,
                bounces,
                spp: cfg.reference_spp,
                seed: cfg.seed + 1_000_003,
                pixel_centers: cfg.pixel_centers,
            };
            let (f, cached) = cached_reference(&cfg.out.join("cache"), &key, compiled.clone(), name)?;
            let how =
                if cached { "cached".to_string() } else { format!("rendered in {:.1} s", t.elapsed().as_secs_f64()) };
            let note = format!("uniform, {} spp, {how}", f_spp(f.stats.mean_spp));
            (f, note)
        }
    };
    let keep = super::convergence::kept_pixels(&reference, cfg.exclude_above);
    let excluded = keep.iter().filter(|k| !**k).count();
    let mut runs = Vec::new();
    let mut curves = Vec::new();
    let mut last_frames = Vec::new();
    for &method in &cfg.methods {
        let passes = if method == Method::Uniform { cfg.uniform_passes } else { cfg.passes };
        let mut per_seed = Vec::new();
        for r in 0..cfg.repeats.max(1) {
            let mut j = super::convergence::job(compiled.clone(), method, passes, 0.0, cfg.seed + r as u64, bounces);
            j.pixel_centers = cfg.pixel_centers;
            if let Some(k) = cfg.indirect_kernel_scale {
                j.indirect.kernel_scale = k;
            }
            if let Some(mu0) = cfg.shadow_mu0 {
                j.aaf.mu0 = mu0;
            }
            if cfg.shadow_profile_sigma {
                j.aaf.light_sigma = crate::methods::aaf_shadows::LightSigma::Profile;
            }
            if cfg.asg_lobes {
                j.lobe.lobe.shape = crate::methods::lobe_aware::options::LobeShape::Asg;
            }
            if let Some(f) = cfg.upsample.filter(|_| matches!(method, Method::LobeAware | Method::NormalAware)) {
                j.lobe.upsample.factor = f;
            }
            for assignment in &cfg.settings {
                j.set(assignment).map_err(|e| anyhow::anyhow!("--set: {e}"))?;
            }
            let (pts, last) = sweep(&j, &reference, &keep);
            if let Some(last) = last.filter(|_| r == 0) {
                last_frames.push((method, last));
            }
            runs.extend(pts.iter().cloned().map(|p| (r, p)));
            per_seed.push(pts);
        }
        curves.push(median_curve(method, &per_seed));
    }
    Ok(SceneResult { name: name.to_string(), bounces, reference_note, runs, curves, last_frames, reference, excluded })
}

/// The non-default options of a run, for the report's headings.
fn options_note(cfg: &BenchConfig) -> String {
    let mut s = String::new();
    if cfg.pixel_centers {
        s += ", pixel centres";
    }
    if let Some(k) = cfg.indirect_kernel_scale {
        let _ = write!(s, ", indirect kernel scale {k}");
    }
    if let Some(mu0) = cfg.shadow_mu0 {
        let _ = write!(s, ", shadow mu0 {mu0}");
    }
    if cfg.shadow_profile_sigma {
        s += ", shadows: the profile's sigma";
    }
    if cfg.asg_lobes {
        s += ", ASG lobes (Eq. 13)";
    }
    if let Some(f) = cfg.upsample {
        let _ = write!(s, ", lobe- and normal-aware upsampled from every {f}th pixel");
    }
    if let Some(t) = cfg.exclude_above {
        let _ = write!(s, ", errors without pixels whose reference exceeds {t} and their neighbours");
    }
    for assignment in &cfg.settings {
        let _ = write!(s, ", {assignment}");
    }
    s
}

fn f_spp(v: f64) -> String {
    format!("{}", (v * 10.0).round() / 10.0)
}

/// The Markdown report of all scenes.
pub fn markdown(results: &[SceneResult], cfg: &BenchConfig) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "Command: `{}`  \nMachine: {}  \n", cfg.command, machine_description());
    for r in results {
        let _ = writeln!(
            s,
            "### {} ({}x{}, {} bounces{}; reference: {}; medians of {} seeds)\n",
            r.name,
            cfg.width,
            cfg.height,
            r.bounces,
            options_note(cfg),
            r.reference_note,
            cfg.repeats
        );
        if r.excluded > 0 {
            let _ = writeln!(s, "{} pixels left out of the errors.\n", r.excluded);
        }
        let _ = writeln!(s, "| method | pass | mean spp | seconds | CPU s | method share | RMSE | rel. MSE | FLIP | speedup over uniform at equal error (samples, time) | time speedup at equal rel. MSE |");
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|");
        let base = r.curves.iter().find(|c| c.method == Method::Uniform).map(|c| c.points.as_slice()).unwrap_or(&[]);
        for c in &r.curves {
            for p in &c.points {
                let (ss, ts) = speedup(base, p);
                let x = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.1}x"));
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {:.3} | {} | {:.1}% | {:.5} | {:.2e} | {:.4} | {}, {} | {} |",
                    c.method.name(),
                    p.pass,
                    f_spp(p.mean_spp),
                    p.seconds,
                    p.cpu_seconds.map_or("-".into(), |c| format!("{c:.2}")),
                    100.0 * p.method_seconds / p.seconds.max(1e-9),
                    p.rmse,
                    p.rel_mse,
                    p.flip,
                    x(ss),
                    x(ts),
                    x(relative_speedup(base, p))
                );
            }
        }
        let _ = writeln!(s);
        for c in &r.curves {
            let later = c.points.get(1..).unwrap_or(&[]);
            let _ = writeln!(
                s,
                "- {}: error keeps falling as samples grow: {}",
                c.method.name(),
                if consistent(later, 0.02) { "yes" } else { "no" }
            );
        }
        let _ = writeln!(s);
    }
    s
}

/// Writes `<name>.json`, `<name>.csv`, `<name>.md` and per-scene plots into `cfg.out`.
pub fn write_outputs(results: &[SceneResult], cfg: &BenchConfig) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(&cfg.out)?;
    let mut written = Vec::new();
    let path = |ext: &str| cfg.out.join(format!("{}.{ext}", cfg.name));
    let point = |p: &Point| {
        json!({"method": p.method.name(), "pass": p.pass, "mean_spp": p.mean_spp, "seconds": p.seconds,
               "cpu_seconds": p.cpu_seconds, "method_seconds": p.method_seconds, "rays": p.rays,
               "rmse": p.rmse, "rel_mse": p.rel_mse, "flip": p.flip})
    };
    let scenes: Vec<_> = results
        .iter()
        .map(|r| {
            let base = r.curves.iter().find(|c| c.method == Method::Uniform).map(|c| c.points.as_slice()).unwrap_or(&[]);
            json!({
                "scene": r.name, "width": cfg.width, "height": cfg.height, "bounces": r.bounces, "pixel_centers": cfg.pixel_centers, "indirect_kernel_scale": cfg.indirect_kernel_scale, "shadow_mu0": cfg.shadow_mu0, "shadow_profile_sigma": cfg.shadow_profile_sigma, "asg_lobes": cfg.asg_lobes, "upsample": cfg.upsample, "exclude_above": cfg.exclude_above, "settings": cfg.settings, "excluded_pixels": r.excluded,
                "reference": r.reference_note,
                "runs": r.runs.iter().map(|(seed, p)| { let mut v = point(p); v["repeat"] = json!(seed); v }).collect::<Vec<_>>(),
                "medians": r.curves.iter().flat_map(|c| c.points.iter().map(|p| {
                    let (ss, ts) = speedup(base, p);
                    let mut v = point(p);
                    v["speedup_samples"] = json!(ss);
                    v["speedup_seconds"] = json!(ts);
                    v["speedup_seconds_rel_mse"] = json!(relative_speedup(base, p));
                    v
                })).collect::<Vec<_>>(),
                "consistent": r.curves.iter().map(|c| (c.method.name().to_string(), json!(consistent(c.points.get(1..).unwrap_or(&[]), 0.02)))).collect::<serde_json::Map<_, _>>(),
            })
        })
        .collect();
    let doc = json!({"machine": machine_description(), "command": cfg.command, "scenes": scenes});
    std::fs::write(path("json"), serde_json::to_string_pretty(&doc)?)?;
    written.push(path("json"));
    let mut csv =
        String::from("scene,method,repeat,pass,mean_spp,seconds,cpu_seconds,method_seconds,rays,rmse,rel_mse,flip\n");
    for r in results {
        for (rep, p) in &r.runs {
            let _ = writeln!(
                csv,
                "{},{},{rep},{},{},{},{},{},{},{},{},{}",
                r.name,
                p.method.name(),
                p.pass,
                p.mean_spp,
                p.seconds,
                p.cpu_seconds.map_or(String::new(), |c| c.to_string()),
                p.method_seconds,
                p.rays,
                p.rmse,
                p.rel_mse,
                p.flip
            );
        }
    }
    std::fs::write(path("csv"), csv)?;
    written.push(path("csv"));
    std::fs::write(path("md"), markdown(results, cfg))?;
    written.push(path("md"));
    // (label, file name part, value) of each plotted quantity: the axes, then the errors.
    type Quantity = (&'static str, &'static str, fn(&Point) -> f64);
    let axes: [Quantity; 2] = [("spp", "spp", |p| p.mean_spp), ("seconds", "seconds", |p| p.seconds)];
    let metrics: [Quantity; 2] = [("RMSE", "rmse", |p| p.rmse), ("FLIP", "flip", |p| p.flip)];
    for r in results {
        for (label, file, y) in metrics {
            for (axis, _, x) in axes {
                let series: Vec<Series> = r
                    .curves
                    .iter()
                    .map(|c| Series {
                        label: c.method.name().to_string(),
                        points: c.points.iter().map(|p| (x(p), y(p))).collect(),
                    })
                    .collect();
                let title = format!("{}: {label} vs {axis}", r.name);
                let stem = cfg.out.join(format!("{}-{}-{file}-vs-{axis}", cfg.name, r.name));
                let svg = stem.with_extension("svg");
                std::fs::write(&svg, plot::svg(&title, axis, label, &series))?;
                let png = stem.with_extension("png");
                plot::png(&title, axis, label, &series).save(&png)?;
                written.extend([svg, png]);
            }
        }
        if cfg.flip_maps {
            for (method, frame) in &r.last_frames {
                let path = cfg.out.join(format!("{}-{}-{}-flip.png", cfg.name, r.name, method.name()));
                super::flip::write_error_png(frame, &r.reference, &path)?;
                written.push(path);
            }
        }
    }
    Ok(written)
}

/// A scene to benchmark: its label, its message and, for a scene file, its directory.
pub type NamedScene = (String, proto::Scene, Option<std::path::PathBuf>);

/// Scenes named on the command line: built-in names or scene files.
pub fn resolve_scenes(names: &[String]) -> anyhow::Result<Vec<NamedScene>> {
    names
        .iter()
        .map(|n| {
            if Path::new(n).is_file() {
                let s = crate::scene::json::load_scene(Path::new(n))?;
                let label = Path::new(n).file_stem().map_or(n.clone(), |s| s.to_string_lossy().into_owned());
                Ok((label, s, Path::new(n).parent().map(Path::to_path_buf)))
            } else {
                crate::scene::builtin::get(n)
                    .map(|s| (n.clone(), s, None))
                    .ok_or_else(|| anyhow::anyhow!("{n}: no scene file or built-in scene of that name"))
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tiny_benchmark_writes_every_output_and_reuses_its_reference() {
        let out = std::env::temp_dir().join(format!("wedge-bench-{}", std::process::id()));
        let cfg = BenchConfig {
            width: 12,
            height: 9,
            reference_spp: 64.0,
            reference: None,
            methods: vec![Method::Uniform, Method::Aaf],
            uniform_passes: 4,
            passes: 2,
            repeats: 2,
            seed: 1,
            bounces: None,
            pixel_centers: false,
            indirect_kernel_scale: None,
            shadow_mu0: None,
            shadow_profile_sigma: false,
            flip_maps: true,
            asg_lobes: false,
            upsample: None,
            settings: Vec::new(),
            exclude_above: None,
            out: out.clone(),
            name: "t".into(),
            command: "test".into(),
        };
        let scenes = resolve_scenes(&["curved".to_string()]).unwrap();
        let (name, scene, _) = scenes.into_iter().next().unwrap();
        let r = bench_scene(&name, scene.clone(), None, &cfg).unwrap();
        assert!(r.reference_note.contains("rendered"));
        assert_eq!(r.curves.len(), 2);
        assert_eq!(r.curves[0].points.len(), 4);
        assert_eq!(r.runs.len(), 2 * (4 + 2));
        // Uniform's sweep is 1, 2, 4, 8 spp, and its median error falls at the Monte Carlo
        // rate: 1/sqrt(8) = 0.35 from 1 to 8 spp, a little more against a 64-spp reference
        // (sqrt((1/8 + 1/64) / (1 + 1/64)) = 0.37).
        let u = &r.curves[0].points;
        assert_eq!(u.iter().map(|p| p.mean_spp).collect::<Vec<_>>(), [1.0, 2.0, 4.0, 8.0]);
        let rate = u[3].rmse / u[0].rmse;
        assert!((0.25..0.5).contains(&rate), "error ratio from 1 to 8 spp: {rate}");
        // FLIP falls with the samples too, and is in (0, 1).
        assert!(u.iter().all(|p| p.flip > 0.0 && p.flip < 1.0), "{u:?}");
        assert!(u[3].flip < u[0].flip, "FLIP from 1 to 8 spp: {} -> {}", u[0].flip, u[3].flip);
        let files = write_outputs(std::slice::from_ref(&r), &cfg).unwrap();
        // JSON, CSV, Markdown; RMSE and FLIP against spp and seconds as SVG and PNG; a FLIP
        // map per method.
        assert_eq!(files.len(), 3 + 8 + 2);
        assert!(files.iter().any(|f| f.ends_with("t-curved-aaf-flip.png")), "{files:?}");
        let doc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("t.json")).unwrap()).unwrap();
        assert_eq!(doc["scenes"][0]["medians"].as_array().unwrap().len(), 6);
        assert_eq!(std::fs::read_to_string(out.join("t.csv")).unwrap().lines().count(), 1 + 12);
        assert!(std::fs::read_to_string(out.join("t.md")).unwrap().contains("| aaf | 1 |"));
        let again = bench_scene(&name, scene, None, &cfg).unwrap();
        assert!(again.reference_note.contains("cached"));
        std::fs::remove_dir_all(&out).unwrap();
    }
}

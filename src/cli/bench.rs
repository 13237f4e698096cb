//! `wedge bench`: runs the benchmarks in src/bench and prints Markdown for BENCHMARKS.md.
use crate::bench::{latency, machine_description, median, rays};
use crate::proto;
use crate::render::geometry::BvhQuality;
use crate::scene::{builtin, compile, SceneLimits};
use clap::{Args, Subcommand};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub what: BenchKind,
}

#[derive(Subcommand, Debug)]
pub enum BenchKind {
    /// Rays per second for primary, shadow and bounce rays on 1 and 2 threads.
    Rays {
        /// Built-in scenes to trace (the procedural terrain is always added).
        #[arg(long, default_value = "cornell")]
        scene: Vec<String>,
        /// Triangles of the procedural terrain mesh.
        #[arg(long, default_value_t = 1_000_000)]
        terrain_triangles: usize,
        /// Image size the camera rays cover.
        #[arg(long, default_value_t = 320)]
        width: u32,
        #[arg(long, default_value_t = 240)]
        height: u32,
        /// Camera rays per pixel.
        #[arg(long, default_value_t = 4)]
        spp: u32,
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// BVH build preset for the terrain: fast, medium or slow.
        #[arg(long, default_value = "medium")]
        bvh: String,
        /// Write triangles and rays here for bench/embree_compare.py.
        #[arg(long)]
        dump: Option<PathBuf>,
    },
    /// Error against samples and time: uniform, uniform-filtered, adaptive and aaf against a
    /// high-spp uniform reference, with equal-error speedups over uniform.
    Shadows {
        #[arg(long, default_values_t = ["grids".to_string(), "curved".to_string()])]
        scene: Vec<String>,
        #[arg(long, default_value_t = 320)]
        width: u32,
        #[arg(long, default_value_t = 240)]
        height: u32,
        /// Samples per pixel of the reference.
        #[arg(long, default_value_t = 4096.0)]
        reference_spp: f64,
        /// Passes of the uniform sweep (1, 2, 4, ... spp).
        #[arg(long, default_value_t = 10)]
        uniform_passes: u32,
        /// Passes of the AAF-family sweeps (sparse pass, then mu = 1, 2, 4, ...).
        #[arg(long, default_value_t = 5)]
        aaf_passes: u32,
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Latency from a Render request to its first frame over gRPC.
    Latency {
        #[arg(long, default_value = "cornell")]
        scene: String,
        #[arg(long, default_value_t = 320)]
        width: u32,
        #[arg(long, default_value_t = 240)]
        height: u32,
        #[arg(long, default_value_t = 20)]
        runs: usize,
        /// Use this server instead of one started in-process.
        #[arg(long)]
        addr: Option<String>,
    },
}

pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    println!("Machine: {}\n", machine_description());
    match a.what {
        BenchKind::Rays { scene, terrain_triangles, width, height, spp, repeats, bvh, dump } => {
            let quality = match bvh.as_str() {
                "fast" => BvhQuality::Fast,
                "medium" => BvhQuality::Medium,
                "slow" => BvhQuality::Slow,
                other => anyhow::bail!("--bvh {other}: expected fast, medium or slow"),
            };
            println!("| scene | triangles | rays | kind | 1 thread Mrays/s | 2 threads Mrays/s | hits |");
            println!("|---|---|---|---|---|---|---|");
            let mut scenes = Vec::new();
            for name in &scene {
                let mut s = builtin::get(name).ok_or_else(|| anyhow::anyhow!("no built-in scene {name:?}"))?;
                if let Some(c) = s.camera.as_mut() {
                    (c.width, c.height) = (width, height);
                }
                scenes.push((name.clone(), compile(&s, &SceneLimits::default(), None)?));
            }
            scenes.push(("terrain".to_string(), rays::terrain_scene(terrain_triangles, width, height, quality)));
            for (name, s) in &scenes {
                let sets = rays::make_rays(s, spp);
                let mut results = serde_json::Map::new();
                for set in &sets {
                    let (r1, hits) = rays::measure(s, set, 1, repeats)?;
                    let (r2, _) = rays::measure(s, set, 2, repeats)?;
                    println!(
                        "| {name} | {} | {} | {} | {:.2} | {:.2} | {hits} |",
                        s.triangle_count(),
                        set.origins.len(),
                        set.kind.name(),
                        r1 / 1e6,
                        r2 / 1e6
                    );
                    results.insert(
                        set.kind.name().to_string(),
                        serde_json::json!({"rays": set.origins.len(), "hits": hits, "rays_per_second_1": r1, "rays_per_second_2": r2}),
                    );
                }
                if let Some(dir) = &dump {
                    let meta = serde_json::json!({"scene": name, "triangles": s.triangle_count(), "wedge": results});
                    rays::dump(&dir.join(name), s, &sets, &meta)?;
                }
            }
            Ok(())
        }
        BenchKind::Shadows { scene, width, height, reference_spp, uniform_passes, aaf_passes, seed } => {
            for name in &scene {
                shadows(name, width, height, reference_spp, uniform_passes, aaf_passes, seed)?;
            }
            Ok(())
        }
        BenchKind::Latency { scene, width, height, runs, addr } => {
            let req = proto::RenderRequest {
                scene_source: Some(proto::render_request::SceneSource::Builtin(scene.clone())),
                width,
                height,
                settings: Some(proto::RenderSettings { max_passes: 1, ..Default::default() }),
                ..Default::default()
            };
            let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
            let r = rt.block_on(latency::measure(req, runs, addr))?;
            let mut sorted = r.first_frame.clone();
            sorted.sort_by(f64::total_cmp);
            println!("| scene | size | runs | median first frame (ms) | min (ms) | max (ms) | connect (ms) |");
            println!("|---|---|---|---|---|---|---|");
            println!(
                "| {scene} | {width}x{height} | {runs} | {:.1} | {:.1} | {:.1} | {:.1} |",
                median(r.first_frame) * 1e3,
                sorted.first().copied().unwrap_or(f64::NAN) * 1e3,
                sorted.last().copied().unwrap_or(f64::NAN) * 1e3,
                r.connect * 1e3
            );
            Ok(())
        }
    }
}

fn shadows(
    name: &str,
    width: u32,
    height: u32,
    ref_spp: f64,
    uniform_passes: u32,
    aaf_passes: u32,
    seed: u64,
) -> anyhow::Result<()> {
    use crate::bench::convergence::{consistent, final_frame, job, speedup, sweep};
    use crate::render::progressive::Method;
    let mut s = builtin::get(name).ok_or_else(|| anyhow::anyhow!("no built-in scene {name:?}"))?;
    if let Some(c) = s.camera.as_mut() {
        (c.width, c.height) = (width, height);
    }
    let bounces = s.settings.as_ref().and_then(|s| s.bounces).unwrap_or(0);
    let scene = std::sync::Arc::new(compile(&s, &SceneLimits::default(), None)?);
    let t = std::time::Instant::now();
    let reference = final_frame(&job(scene.clone(), Method::Uniform, 64, ref_spp, seed + 1000, bounces))
        .ok_or_else(|| anyhow::anyhow!("reference render failed"))?;
    println!(
        "### {name} ({width}x{height}, {bounces} bounces; reference: uniform, {} spp, {:.1} s)\n",
        reference.stats.mean_spp,
        t.elapsed().as_secs_f64()
    );
    let runs = [
        (Method::Uniform, uniform_passes),
        (Method::UniformFiltered, aaf_passes),
        (Method::Adaptive, aaf_passes),
        (Method::Aaf, aaf_passes),
    ];
    let curves: Vec<_> =
        runs.iter().map(|&(m, p)| sweep(&job(scene.clone(), m, p, 0.0, seed, bounces), &reference)).collect();
    println!("| method | pass | mean spp | seconds | method share | RMSE | equal-error speedup over uniform (samples, time) |");
    println!("|---|---|---|---|---|---|---|");
    let base = &curves[0];
    for curve in &curves {
        for p in curve {
            let (ss, ts) = speedup(base, p);
            let f = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.1}x"));
            println!(
                "| {} | {} | {:.1} | {:.3} | {:.1}% | {:.5} | {}, {} |",
                p.method.name(),
                p.pass,
                p.mean_spp,
                p.seconds,
                100.0 * p.method_seconds / p.seconds.max(1e-9),
                p.rmse,
                f(ss),
                f(ts)
            );
        }
    }
    println!();
    for curve in &curves[1..] {
        if let Some(m) = curve.first().map(|p| p.method.name()) {
            println!(
                "- {m}: error keeps falling with more samples: {}",
                if consistent(&curve[1..], 0.02) { "yes" } else { "no" }
            );
        }
    }
    println!();
    Ok(())
}

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

//! `wedge bench`: runs the benchmarks in src/bench and prints Markdown for BENCHMARKS.md.
use crate::bench::{latency, machine_description, median, rays};
use crate::proto;
use crate::render::geometry::{BvhLayout, BvhQuality};
use crate::render::wide_bvh::{LeafCost, Width};
use crate::scene::{builtin, compile_builder, SceneLimits};
use clap::{Args, Subcommand};
use std::path::PathBuf;

/// `wedge bench [SCENES...]`: error against samples and time for every method (the default);
/// `wedge bench rays` and `wedge bench latency`: the tracer and service benchmarks.
#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub what: Option<BenchKind>,
    #[command(flatten)]
    pub convergence: ConvergenceArgs,
}

#[derive(Args, Debug)]
pub struct ConvergenceArgs {
    /// Built-in scene names or scene files (default: every built-in scene).
    pub scenes: Vec<String>,
    /// Small images, short sweeps, two seeds: finishes in a few minutes on 2 cores.
    #[arg(long)]
    pub quick: bool,
    #[arg(long)]
    pub width: Option<u32>,
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel of the rendered reference (cached under OUT/cache).
    #[arg(long)]
    pub reference_spp: Option<f64>,
    /// Use this EXR as the reference instead (one scene).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Methods to compare (default: uniform, uniform-filtered, adaptive, aaf).
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<String>,
    /// Passes of the uniform sweep (1, 2, 4, ... spp).
    #[arg(long)]
    pub uniform_passes: Option<u32>,
    /// Passes of the other methods' sweeps.
    #[arg(long)]
    pub passes: Option<u32>,
    /// Seeds per method (medians are reported).
    #[arg(long)]
    pub repeats: Option<u32>,
    /// Indirect bounces, overriding each scene's own setting.
    #[arg(long)]
    pub bounces: Option<u32>,
    /// Shade pixel centres without antialiasing (the AAF papers' setting), reference included.
    #[arg(long)]
    pub pixel_centers: bool,
    /// Scale the indirect filter's standard deviation (default 1, the paper's beta = 2/Omega;
    /// 0.25 is what the authors' code used).
    #[arg(long)]
    pub indirect_kernel_scale: Option<f64>,
    /// mu of the soft-shadow filter's pass 1 (later passes double it; the first frame keeps
    /// mu = 1).
    #[arg(long)]
    pub shadow_mu0: Option<f64>,
    /// Give the soft-shadow analysis a Gaussian light's profile sigma, as the authors' code
    /// did, rather than the standard deviation of what its rectangle emits.
    #[arg(long)]
    pub shadow_profile_sigma: bool,
    /// Glossy lobes as ASGs compared by Tokuyoshi's Eq. 13 (`lobe-aware`, `normal-aware`),
    /// rather than SGs by Eq. 12.
    #[arg(long)]
    pub asg_lobes: bool,
    /// `lobe-aware` and `normal-aware` trace indirect light at every N-th pixel and upsample
    /// it (Tokuyoshi's Sec. 5; at most 8).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=crate::methods::lobe_aware::options::MAX_UPSAMPLE_FACTOR as i64))]
    pub upsample: Option<u32>,
    /// Leave out of the errors the pixels whose reference exceeds this in some channel, and
    /// their 8 neighbours (a light in view and its edge), as bench/race.py does.
    #[arg(long)]
    pub exclude_above: Option<f32>,
    /// Set a method option by name for every render but the reference, GROUP.NAME=VALUE
    /// (repeatable; groups `auto`, `bandwidth`, `lobe`, `aaf`, `indirect` and `uniform`, e.g.
    /// `auto.narrow_scale=0.25`): how a choice
    /// measured against the default is rerun. An unknown name lists its group's names.
    #[arg(long = "set", value_name = "GROUP.NAME=VALUE")]
    pub settings: Vec<String>,
    /// Also write each method's FLIP error map of its last frame (first seed),
    /// NAME-SCENE-METHOD-flip.png, in FLIP's magma colours.
    #[arg(long)]
    pub flip_maps: bool,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output directory.
    #[arg(long, default_value = "bench-results")]
    pub out: PathBuf,
    /// Base name of the output files.
    #[arg(long)]
    pub name: Option<String>,
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
        /// Leaf choice of wedge's wide BVH, as NODE,MAX: the cost of a binary node's box test
        /// relative to a 4-triangle block test, and the largest leaf in triangles.
        #[arg(long, default_value = "1.5,16")]
        leaf_cost: String,
    },
    /// Samples and rays per second of the uniform path tracer per scene, bounce count and
    /// thread count (bench/throughput.py adds Mitsuba 3 and the time per stage).
    Throughput(ThroughputArgs),
    /// The noise-target halt's own error estimate against the true error, per scene, method
    /// and target.
    Noise {
        #[arg(long, value_delimiter = ',', default_value = "cornell,grids,curved")]
        scenes: Vec<String>,
        #[arg(long, default_value_t = 128)]
        width: u32,
        #[arg(long, default_value_t = 96)]
        height: u32,
        #[arg(long, value_delimiter = ',', default_value = "0.1,0.05,0.025")]
        targets: Vec<f64>,
        #[arg(long, value_delimiter = ',', default_value = "uniform,aaf")]
        methods: Vec<String>,
        /// Samples per pixel of each of the two uniform references.
        #[arg(long, default_value_t = 4096.0)]
        reference_spp: f64,
        /// Seconds after which a render that has not reached its target stops (its row says
        /// so): a method whose estimate never falls to the target would otherwise run on.
        #[arg(long, default_value_t = 60.0)]
        max_seconds: f64,
    },
    /// Latency from a Render request to its first five frames over gRPC, per method.
    Latency {
        #[command(flatten)]
        target: ServiceTarget,
        #[arg(long, default_value_t = 10)]
        runs: usize,
    },
    /// Camera-update latency of an editing session: an orbit of camera changes over gRPC, per
    /// method; prints `METHOD: median N ms, p95 M ms, dropped K of T` per method.
    Session {
        #[command(flatten)]
        target: ServiceTarget,
        /// Camera changes sent, and how many per second.
        #[arg(long, default_value_t = 60)]
        updates: usize,
        #[arg(long, default_value_t = 30.0)]
        rate: f64,
        /// Degrees the orbit sweeps around the scene camera's look-at point.
        #[arg(long, default_value_t = 60.0)]
        sweep: f32,
    },
}

/// What the service benchmarks (`latency`, `session`) render, with which methods, where.
#[derive(Args, Debug)]
pub struct ServiceTarget {
    #[arg(long, default_value = "cornell")]
    scene: String,
    #[arg(long, default_value_t = 320)]
    width: u32,
    #[arg(long, default_value_t = 240)]
    height: u32,
    /// Methods to time (repeatable); default: every method.
    #[arg(long)]
    method: Vec<String>,
    /// Use this server instead of one started in-process.
    #[arg(long)]
    addr: Option<String>,
}

/// What `bench rays` compares on the same rays: wedge's default BVH (8-wide with AVX2, leaves
/// chosen by `leaf`), its 4-wide BVH, the default with obvhs's own leaves, and obvhs's CWBVH.
fn layouts(leaf: LeafCost) -> [(&'static str, BvhLayout); 4] {
    [
        ("wedge default", BvhLayout::Wide(Width::Eight, Some(leaf))),
        ("wedge 4-wide", BvhLayout::Wide(Width::Four, Some(leaf))),
        ("wedge, obvhs leaves", BvhLayout::Wide(Width::Eight, None)),
        ("obvhs CWBVH", BvhLayout::Cwbvh),
    ]
}

/// The built-in scenes `names` at `width` x `height`, compiled up to their BVH (which the
/// benchmarks build themselves); an unknown name is an error naming `flag`.
fn builtin_builders(
    names: &[String],
    (width, height): (u32, u32),
    flag: &str,
) -> anyhow::Result<Vec<(String, crate::render::scene::SceneBuilder)>> {
    let mut scenes = Vec::new();
    for name in names {
        let mut s = builtin::get(name).ok_or_else(|| anyhow::anyhow!("{flag}: no built-in scene {name:?}"))?;
        if let Some(c) = s.camera.as_mut() {
            (c.width, c.height) = (width, height);
        }
        scenes.push((name.clone(), compile_builder(&s, &SceneLimits::default(), None)?));
    }
    Ok(scenes)
}

/// Prints one row of `bench rays` (rays per second on 1 and 2 threads) and returns it as JSON.
fn ray_row(
    name: &str,
    scene: &crate::render::scene::Scene,
    set: &rays::RaySet,
    label: &str,
    (r1, r2): (f64, f64),
    hits: usize,
) -> serde_json::Value {
    let (n, kind) = (set.origins.len(), set.kind.name());
    println!(
        "| {name} | {} | {n} | {kind} | {label} | {:.2} | {:.2} | {hits} |",
        scene.triangle_count(),
        r1 / 1e6,
        r2 / 1e6
    );
    serde_json::json!({"rays": n, "hits": hits, "rays_per_second_1": r1, "rays_per_second_2": r2})
}

/// Parses --leaf-cost NODE,MAX.
fn parse_leaf_cost(s: &str) -> anyhow::Result<LeafCost> {
    let bad = || anyhow::anyhow!("--leaf-cost {s}: expected NODE,MAX, e.g. 1.5,16 (MAX 1 to 32)");
    let (node, max) = s.split_once(',').ok_or_else(bad)?;
    let node: f32 = node.trim().parse().map_err(|_| bad())?;
    let max_triangles: usize = max.trim().parse().map_err(|_| bad())?;
    anyhow::ensure!(node.is_finite() && node >= 0.0 && (1..=32).contains(&max_triangles), bad());
    Ok(LeafCost { node, max_triangles })
}

pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    let Some(what) = a.what else { return convergence(a.convergence) };
    println!("Machine: {}\n", machine_description());
    match what {
        BenchKind::Rays { scene, terrain_triangles, width, height, spp, repeats, bvh, dump, leaf_cost } => {
            let layouts = layouts(parse_leaf_cost(&leaf_cost)?);
            let quality = match bvh.as_str() {
                "fast" => BvhQuality::Fast,
                "medium" => BvhQuality::Medium,
                "slow" => BvhQuality::Slow,
                other => anyhow::bail!("--bvh {other}: expected fast, medium or slow"),
            };
            println!("| scene | triangles | rays | kind | BVH | 1 thread Mrays/s | 2 threads Mrays/s | hits |");
            println!("|---|---|---|---|---|---|---|---|");
            let mut scenes = builtin_builders(&scene, (width, height), "--scene")?;
            scenes.push(("terrain".to_string(), rays::terrain_builder(terrain_triangles, width, height)));
            let mut ratios = Vec::new();
            for (name, builder) in scenes {
                // The same triangles traced by wedge's wide BVH (8-wide where the CPU has AVX2,
                // and 4-wide; with its own leaves and with obvhs's) and by obvhs's CWBVH, on the
                // same rays.
                let built = layouts.map(|(_, layout)| {
                    let mut b = builder.clone();
                    (b.bvh_quality, b.bvh_layout) = (quality, layout);
                    b.build()
                });
                let s = &built[0];
                let sets = rays::make_rays(s, spp);
                let mut results = layouts.map(|_| serde_json::Map::new());
                for set in &sets {
                    let mut one_thread = [0.0; 4];
                    for (k, ((layout, _), scene)) in layouts.iter().zip(&built).enumerate() {
                        let (r1, hits) = rays::measure(scene, set, 1, repeats)?;
                        let (r2, _) = rays::measure(scene, set, 2, repeats)?;
                        one_thread[k] = r1;
                        let row = ray_row(&name, scene, set, layout, (r1, r2), hits);
                        results[k].insert(set.kind.name().to_string(), row);
                    }
                    // The default tree again, the rays given in runs of a packet's size.
                    let (p1, hits) = rays::measure_packets(s, set, 1, repeats)?;
                    let (p2, _) = rays::measure_packets(s, set, 2, repeats)?;
                    let row = ray_row(&name, s, set, "wedge default, packets", (p1, p2), hits);
                    results[0].insert(format!("{}_packets", set.kind.name()), row);
                    ratios.push(format!(
                        "| {name} | {} | {:.2} | {:.2} | {:.2} |",
                        set.kind.name(),
                        one_thread[0] / one_thread[3],
                        one_thread[1] / one_thread[3],
                        one_thread[0] / one_thread[2]
                    ));
                }
                let [results, four, obvhs_leaves, cwbvh] = results;
                if let Some(dir) = &dump {
                    let meta = serde_json::json!({"scene": name, "triangles": s.triangle_count(), "leaf_cost": leaf_cost,
                        "wedge": results, "wedge_4_wide": four, "wedge_obvhs_leaves": obvhs_leaves, "cwbvh": cwbvh});
                    rays::dump(&dir.join(&name), s, &sets, &meta)?;
                }
            }
            println!(
                "\n| scene | kind | wedge default / CWBVH (1 thread) | wedge 4-wide / CWBVH | wedge default / obvhs leaves |\n|---|---|---|---|---|"
            );
            for r in ratios {
                println!("{r}");
            }
            Ok(())
        }
        BenchKind::Throughput(args) => throughput(args),
        BenchKind::Noise { scenes, width, height, targets, methods, reference_spp, max_seconds } => {
            if !(max_seconds > 0.0 && max_seconds.is_finite()) {
                anyhow::bail!("--max-seconds must be a positive number of seconds, not {max_seconds}");
            }
            use crate::bench::noise;
            use crate::pipeline::job::Method;
            let methods: Vec<Method> = methods
                .iter()
                .map(|m| Method::from_name(m).ok_or_else(|| anyhow::anyhow!("--methods: unknown method {m:?}")))
                .collect::<anyhow::Result<_>>()?;
            println!("{}\n", machine_description());
            println!("| scene | method | target | estimated | true | true / estimated | mean spp | seconds |");
            println!("|---|---|---|---|---|---|---|---|");
            let (mut within, mut total) = (0, 0);
            for scene in &scenes {
                let reference = noise::reference(scene, width, height, reference_spp)?;
                eprintln!("{scene}: reference's own relative RMSE {:.4}", reference.1);
                for &m in &methods {
                    for &t in &targets {
                        let r = noise::measure(scene, (width, height), m, t, max_seconds, &reference)?;
                        let ratio = r.ratio();
                        total += 1;
                        if (0.5..=2.0).contains(&ratio) {
                            within += 1;
                        }
                        println!(
                            "| {scene} | {} | {t} | {:.4} | {:.4} | {ratio:.2} | {:.0} | {:.2}{} |",
                            m.name(),
                            r.estimated,
                            r.truth,
                            r.mean_spp,
                            r.seconds,
                            if r.halted_by_target { "" } else { " (not halted by the target)" }
                        );
                    }
                }
            }
            println!("\nwithin a factor of 2: {within} of {total}");
            Ok(())
        }
        BenchKind::Session { target: ServiceTarget { scene, width, height, method, addr }, updates, rate, sweep } => {
            let camera = crate::scene::builtin::get(&scene)
                .and_then(|s| s.camera)
                .ok_or_else(|| anyhow::anyhow!("--scene: no built-in scene {scene:?} with a camera"))?;
            let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
            for m in methods_named(&method)? {
                let req = proto::RenderRequest {
                    scene_source: Some(proto::render_request::SceneSource::Builtin(scene.clone())),
                    width,
                    height,
                    settings: Some(proto::RenderSettings { method: m.to_proto() as i32, ..Default::default() }),
                    ..Default::default()
                };
                let r = rt.block_on(crate::bench::session::measure(req, camera, updates, rate, sweep, addr.clone()))?;
                println!("{}", r.line(m.name()));
                println!(
                    "  {} of {} views got a frame (a 1/4-resolution preview where the image is large) before the next \
                     change; {} got a full-resolution frame, median {:.0} ms ({scene} {width}x{height}, {updates} \
                     changes at {rate} Hz)",
                    r.latencies.len(),
                    r.updates,
                    r.full_latencies.len(),
                    median(r.full_latencies.clone()) * 1e3
                );
            }
            Ok(())
        }
        BenchKind::Latency { target: ServiceTarget { scene, width, height, method, addr }, runs } => {
            use crate::pipeline::job::Method;
            let methods: Vec<Method> = methods_named(&method)?;
            const FRAMES: usize = 5;
            let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
            println!(
                "| scene | size | method | runs | first frame median (ms) | min | max | frames 2-5 median (ms) | connect (ms) |"
            );
            println!("|---|---|---|---|---|---|---|---|---|");
            for m in methods {
                let req = proto::RenderRequest {
                    scene_source: Some(proto::render_request::SceneSource::Builtin(scene.clone())),
                    width,
                    height,
                    settings: Some(proto::RenderSettings {
                        method: m.to_proto() as i32,
                        max_passes: FRAMES as u32,
                        ..Default::default()
                    }),
                    ..Default::default()
                };
                let r = rt.block_on(latency::measure(req, runs, addr.clone()))?;
                let at = |k: usize| r.frames.iter().filter_map(|f| f.get(k).copied()).collect::<Vec<f64>>();
                let mut first = at(0);
                first.sort_by(f64::total_cmp);
                let later: Vec<String> = (1..FRAMES).map(|k| format!("{:.0}", median(at(k)) * 1e3)).collect();
                println!(
                    "| {scene} | {width}x{height} | {} | {runs} | {:.1} | {:.1} | {:.1} | {} | {:.1} |",
                    m.name(),
                    median(first.clone()) * 1e3,
                    first.first().copied().unwrap_or(f64::NAN) * 1e3,
                    first.last().copied().unwrap_or(f64::NAN) * 1e3,
                    later.join(", "),
                    r.connect * 1e3
                );
            }
            Ok(())
        }
    }
}

/// The methods `names` (`--method`, repeatable); all of them when none is named.
fn methods_named(names: &[String]) -> anyhow::Result<Vec<crate::pipeline::job::Method>> {
    use crate::pipeline::job::Method;
    if names.is_empty() {
        return Ok(Method::ALL.to_vec());
    }
    names
        .iter()
        .map(|m| Method::from_name(m).ok_or_else(|| anyhow::anyhow!("--method: unknown method {m:?}")))
        .collect()
}

fn convergence(a: ConvergenceArgs) -> anyhow::Result<()> {
    use crate::bench::run::{bench_scene, resolve_scenes, write_outputs, BenchConfig};
    use crate::pipeline::job::Method;
    let methods = if a.methods.is_empty() {
        vec![Method::Uniform, Method::UniformFiltered, Method::Adaptive, Method::Aaf]
    } else {
        a.methods
            .iter()
            .map(|m| Method::from_name(m).ok_or_else(|| anyhow::anyhow!("--methods: unknown method {m:?}")))
            .collect::<anyhow::Result<_>>()?
    };
    anyhow::ensure!(
        methods.contains(&Method::Uniform),
        "--methods must include uniform, the baseline of every speedup"
    );
    let names = if a.scenes.is_empty() { builtin::names().map(String::from).collect() } else { a.scenes.clone() };
    anyhow::ensure!(a.reference.is_none() || names.len() == 1, "--reference is one image: give one scene");
    anyhow::ensure!(
        a.exclude_above.is_none_or(|t| t.is_finite() && t > 0.0),
        "--exclude-above: must be a finite number > 0"
    );
    for assignment in &a.settings {
        crate::pipeline::named_options::check(assignment).map_err(|e| anyhow::anyhow!("--set: {e}"))?;
    }
    for (flag, v) in [("--indirect-kernel-scale", a.indirect_kernel_scale), ("--shadow-mu0", a.shadow_mu0)] {
        anyhow::ensure!(v.is_none_or(|v| v.is_finite() && v > 0.0), "{flag}: must be a finite number > 0");
    }
    let q = a.quick;
    let cfg = BenchConfig {
        width: a.width.unwrap_or(if q { 96 } else { 320 }),
        height: a.height.unwrap_or(if q { 72 } else { 240 }),
        reference_spp: a.reference_spp.unwrap_or(if q { 512.0 } else { 4096.0 }),
        reference: a.reference.clone(),
        methods,
        uniform_passes: a.uniform_passes.unwrap_or(if q { 8 } else { 11 }),
        passes: a.passes.unwrap_or(if q { 4 } else { 5 }),
        repeats: a.repeats.unwrap_or(if q { 2 } else { 3 }),
        seed: a.seed,
        bounces: a.bounces,
        pixel_centers: a.pixel_centers,
        indirect_kernel_scale: a.indirect_kernel_scale,
        shadow_mu0: a.shadow_mu0,
        shadow_profile_sigma: a.shadow_profile_sigma,
        flip_maps: a.flip_maps,
        asg_lobes: a.asg_lobes,
        upsample: a.upsample,
        exclude_above: a.exclude_above,
        settings: a.settings.clone(),
        out: a.out.clone(),
        name: a.name.clone().unwrap_or_else(|| if q { "quick".into() } else { "full".into() }),
        command: std::env::args().collect::<Vec<_>>().join(" "),
    };
    let mut results = Vec::new();
    for (name, scene, dir) in resolve_scenes(&names)? {
        eprintln!("bench: {name} ...");
        results.push(bench_scene(&name, scene, dir.as_deref(), &cfg)?);
    }
    print!("{}", crate::bench::run::markdown(&results, &cfg));
    for p in write_outputs(&results, &cfg)? {
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

#[derive(Args, Debug)]
pub struct ThroughputArgs {
    /// Built-in scenes (default: every one), plus the procedural terrain.
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Triangles of the procedural terrain mesh (0 leaves it out).
    #[arg(long, default_value_t = 1_000_000)]
    terrain_triangles: usize,
    #[arg(long, value_delimiter = ',', default_value = "0,1,3")]
    bounces: Vec<u32>,
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    threads: Vec<usize>,
    #[arg(long, default_value_t = 320)]
    width: u32,
    #[arg(long, default_value_t = 320)]
    height: u32,
    /// Samples per pixel of each timed trace.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// Rounds of timed traces: each thread count traces once per round, in turn (medians are
    /// reported; the scaling is the median of the rounds' own ratios).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Also write the results as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

fn throughput(a: ThroughputArgs) -> anyhow::Result<()> {
    use crate::bench::throughput::{job, measure};
    use std::sync::Arc;
    let (width, height) = (a.width, a.height);
    anyhow::ensure!(width > 0 && height > 0, "--width and --height must be at least 1");
    let names: Vec<String> =
        if a.scenes.is_empty() { builtin::names().map(String::from).collect() } else { a.scenes.clone() };
    let mut scenes = builtin_builders(&names, (width, height), "--scenes")?;
    if a.terrain_triangles > 0 {
        scenes.push(("terrain".to_string(), rays::terrain_builder(a.terrain_triangles, width, height)));
    }
    println!("Command: {}\n", std::env::args().collect::<Vec<_>>().join(" "));
    println!("| scene | triangles | bounces | threads | spp | seconds | M samples/s | M rays/s | rays/sample | scaling | same image |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    for (name, builder) in scenes {
        let scene = Arc::new(builder.build());
        for &b in &a.bounces {
            let t = measure(&job(scene.clone(), b, a.seed), a.spp, &a.threads, a.repeats)?;
            let scaling = t.scaling().map_or("-".to_string(), |s| format!("{s:.2}x"));
            for m in &t.by_threads {
                println!(
                    "| {name} | {} | {b} | {} | {} | {:.3} | {:.2} | {:.2} | {:.2} | {scaling} | {} |",
                    scene.triangle_count(),
                    m.threads,
                    t.spp,
                    m.seconds,
                    m.samples_per_second() / 1e6,
                    m.rays_per_second() / 1e6,
                    m.rays as f64 / m.samples as f64,
                    if t.identical { "yes" } else { "NO" }
                );
                rows.push(serde_json::json!({"scene": name, "triangles": scene.triangle_count(), "bounces": b,
                    "threads": m.threads, "spp": t.spp, "width": width, "height": height, "seconds": m.seconds,
                    "samples": m.samples, "rays": m.rays, "identical": t.identical, "rounds": m.rounds,
                    "scaling": t.scaling()}));
            }
        }
    }
    if let Some(path) = a.json {
        let doc = serde_json::json!({"machine": machine_description(), "rows": rows});
        std::fs::write(&path, serde_json::to_string_pretty(&doc)?)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    }
    Ok(())
}

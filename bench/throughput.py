#!/usr/bin/env python3
"""Path-tracing throughput (issue 21): wedge's `uniform` path tracer against Mitsuba 3's
vectorised `llvm_ad_rgb` path tracer on the same scenes, in one run.

    pip install mitsuba numpy
    apt-get install libllvm19 linux-perf   # llvm_ad_rgb; perf only for --stages
    cargo build --release
    python3 bench/throughput.py                       # cornell, grids, curved; 0, 1, 3 bounces
    python3 bench/throughput.py --stages              # adds the time per stage (perf)
    python3 bench/throughput.py --scenes cornell --bounces 1 --spp 4 --repeats 1 \
        --reference-spp 64 --no-terrain               # a smoke test

Not run in CI. Prints Markdown for BENCHMARKS.md ("Throughput").

1. `wedge bench throughput` times wedge's path tracer alone (no scene build, no output) at
   --spp on 1 and 2 threads, on the scenes and the procedural 1M-triangle terrain; the thread
   counts take turns, and "2 / 1 thread" is the median of each round's ratio.
2. Mitsuba renders the same scenes (converted by mitsuba_compare.py: same triangles, camera,
   BRDFs, emitters; max_depth = bounces + 2; box filter; `independent` sampler) at the same spp
   on 1 and 2 threads (`drjit.set_thread_count`), timed warm (a first render compiles the
   kernels) up to the image in numpy, straight after wedge's measurement of the same scene and
   bounce count. Samples per second = width x height x spp / seconds.
3. Efficiency, 1 / (MSE x seconds), of both at that spp on 2 threads: MSE against a high-spp
   wedge reference (cached in bench-results/cache, shared with race.py), the light's pixels and
   their neighbours left out as race.py does; wedge timed by `wedge render --method uniform
   --initial-spp S --max-spp S` (one pass, its own render seconds), medians of --seeds seeds.
4. --stages: the share of wedge's time in sampling, traversal, light sampling and shading, from
   `perf record` (self time per function) of `wedge bench throughput` on 2 threads, built with
   the `stage-symbols` feature so that the sampler is a function of its own (that build runs a
   few percent slower: the sampler's calls are not inlined). Functions are assigned to stages
   by module: render::sampler -> sampling; wide_bvh, Geometry/Scene intersect and occluded ->
   traversal; render::light, direct_light_of, light_sample_radiance -> light sampling;
   materials, surface interaction, path loop, camera and its samples, film -> shading; the rest -> other.
Glossy scenes are left out: the converter's glossy BSDF is a scalar Python plugin, whose speed
says nothing about Mitsuba's.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

BENCH = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(BENCH)
sys.path.insert(0, BENCH)
import race  # noqa: E402  (reference images, metrics, machine and commit lines, the llvm probe)

STAGES = [
    ("sampling", [r"render::sampler::"]),
    ("traversal", [r"wide_bvh::", r"Geometry::(intersect|occluded)", r"Scene::(intersect|occluded)", r"obvhs::"]),
    ("light sampling", [r"render::light::", r"direct_light_of", r"light_sample_radiance"]),
    ("shading", [r"render::material::", r"render::frame_basis::", r"render::integrator::", r"render::scene::",
                 r"render::camera::", r"render::camera_samples::", r"render::texture::", r"pipeline::film::", r"FnMut<A> for &F>::call_mut",
                 r"sincosf", r"render::geometry::"]),
]


def ints(s):
    return [int(x) for x in s.split(",") if x]


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="cornell,grids,curved")
    ap.add_argument("--bounces", type=ints, default=[0, 1, 3])
    ap.add_argument("--threads", type=ints, default=[1, 2])
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=320)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seeds", type=int, default=3, help="renders per efficiency point (medians)")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--exclude-above", type=float, default=1.0)
    ap.add_argument("--no-terrain", action="store_true", help="leave out the 1M-triangle terrain (wedge only)")
    ap.add_argument("--no-mitsuba", action="store_true")
    ap.add_argument("--stages", action="store_true", help="time per stage with perf (builds target/stages)")
    return ap.parse_args()


def wedge_throughput(args, scenes, bounces, threads, binary, terrain, repeats):
    """`wedge bench throughput`'s JSON rows for `scenes` (and the terrain) at `bounces`."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "t.json")
        cmd = [binary, "bench", "throughput", "--scenes", ",".join(scenes), "--bounces", ",".join(map(str, bounces)),
               "--threads", ",".join(map(str, threads)), "--width", str(args.width), "--height", str(args.height),
               "--spp", str(args.spp), "--repeats", str(repeats), "--json", out,
               "--terrain-triangles", "1000000" if terrain else "0"]
        subprocess.run(cmd, check=True, capture_output=True)
        return json.load(open(out))["rows"]


def mitsuba_throughput(args, mc, scene, bounces, threads):
    """Median seconds of --repeats warm renders at --spp on `threads` threads."""
    import drjit as dr
    import mitsuba as mi
    dr.set_thread_count(threads)
    d = mc.to_mitsuba(scene, args.width, args.height, args.spp, bounces)
    d["sensor"]["sampler"] = {"type": "independent", "sample_count": args.spp}
    sc = mi.load_dict(d)

    def render(seed):
        t = time.perf_counter()
        img = np.array(mi.render(sc, seed=seed, spp=args.spp), dtype=np.float64)
        dr.sync_thread()
        return img, time.perf_counter() - t

    render(race.WARMUP_SEED)
    times = [render(seed)[1] for seed in range(1, args.repeats + 1)]
    return float(np.median(times)), sc


def efficiency(args, mc, path, bounces, sc):
    """{renderer: (seconds, mse)} medians over --seeds at --spp on every core."""
    import drjit as dr
    import mitsuba as mi
    ref, _ = race.reference(argparse.Namespace(width=args.width, height=args.height, reference_spp=args.reference_spp),
                            mc, path, os.path.splitext(os.path.basename(path))[0], bounces)
    metrics = race.Metrics(ref, args.exclude_above)
    dr.set_thread_count(os.cpu_count())
    out = {"wedge": [], "mitsuba": []}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(1, args.seeds + 1):
            cmd = [mc.WEDGE, "render", path, "--out", tmp, "--width", str(args.width), "--height", str(args.height),
                   "--seed", str(seed), "--method", "uniform", "--initial-spp", str(args.spp), "--max-spp", str(args.spp),
                   "--bounces", str(bounces)]
            p = subprocess.run(cmd, capture_output=True, text=True, check=True)
            m = race.WROTE.search(p.stderr)
            img = mc.read_wedge_exr(os.path.join(tmp, "final.exr"))
            out["wedge"].append((float(m[3]), metrics(img)[0] ** 2))
            t = time.perf_counter()
            img = np.array(mi.render(sc, seed=seed, spp=args.spp), dtype=np.float64)
            dr.sync_thread()
            out["mitsuba"].append((time.perf_counter() - t, metrics(img)[0] ** 2))
    return {k: (float(np.median([r[0] for r in v])), float(np.median([r[1] for r in v]))) for k, v in out.items()}


def stages(args, scenes, bounces):
    """{(scene, bounces): {stage: share}} from perf on a `stage-symbols` build."""
    target = os.path.join(ROOT, "target", "stages")
    subprocess.run(["cargo", "build", "--release", "--features", "stage-symbols", "--target-dir", target],
                   cwd=ROOT, check=True, capture_output=True)
    binary = os.path.join(target, "release", "wedge")
    shares = {}
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "perf.data")
        for name in scenes:
            for b in bounces:
                cmd = [binary, "bench", "throughput", "--scenes", name, "--bounces", str(b), "--threads", "2",
                       "--width", str(args.width), "--height", str(args.height), "--spp", str(args.spp),
                       "--repeats", str(args.repeats), "--terrain-triangles", "0"]
                subprocess.run(["perf", "record", "-q", "-o", data, "--", *cmd], check=True, capture_output=True)
                rep = subprocess.run(["perf", "report", "-i", data, "--no-children", "--sort", "symbol", "--stdio", "-q"],
                                     check=True, capture_output=True, text=True).stdout
                acc = {s: 0.0 for s, _ in STAGES}
                acc["other"] = 0.0
                for line in rep.splitlines():
                    m = re.match(r"\s*([0-9.]+)%\s+\[[.k]\]\s+(.*?)\s*$", line)
                    if not m:
                        continue
                    share, sym = float(m[1]), m[2]
                    stage = next((s for s, pats in STAGES if any(re.search(p, sym) for p in pats)), "other")
                    acc[stage] += share
                shares[(name, b)] = acc
    return shares


def main():
    args = parse_args()
    scenes = [s for s in args.scenes.split(",") if s]
    print(f"Machine: {race.machine()}; commit {race.commit()}\n")
    print(f"Command: {' '.join(sys.argv)}\n")
    paths = {s: race.scene_path(s) for s in scenes}
    docs = {s: json.load(open(p)) for s, p in paths.items()}
    glossy = [s for s in scenes if any("glossy" in m for m in docs[s].get("materials", []))]
    if glossy:
        print(f"Left out (glossy, the converter's BSDF is a Python plugin): {', '.join(glossy)}\n")
        scenes = [s for s in scenes if s not in glossy]
    binary = os.path.join(ROOT, "target", "release", "wedge")
    mc = None
    if not args.no_mitsuba:
        problem = race.probe_llvm(paths[scenes[0]], 0)
        if problem:
            raise SystemExit(f"Mitsuba llvm_ad_rgb does not run here: {problem}")
        mc = race.import_converter(race.LLVM)
    print("| scene | triangles | bounces | threads | wedge M samples/s | wedge M rays/s | wedge 2 / 1 thread | Mitsuba M samples/s | wedge / Mitsuba |")
    print("|---|---|---|---|---|---|---|---|---|")
    eff_rows = []

    def print_rows(rows):
        """Prints wedge's rows, each with Mitsuba's figure for the same case measured now."""
        for r in rows:
            mit = None
            sc = None
            if mc is not None and r["scene"] in paths:
                secs, sc = mitsuba_throughput(args, mc, docs[r["scene"]], r["bounces"], r["threads"])
                mit = args.width * args.height * args.spp / secs
            ws = r["samples"] / r["seconds"]
            scaling = r.get("scaling") if r["threads"] == max(args.threads) else None
            print(f"| {r['scene']} | {r['triangles']} | {r['bounces']} | {r['threads']} | {ws / 1e6:.2f} | "
                  f"{r['rays'] / r['seconds'] / 1e6:.2f} | {race.f(scaling, '.2f')} | {race.f(mit and mit / 1e6, '.2f')} | "
                  f"{race.f(mit and ws / mit, '.2f')} |", flush=True)
            if sc is not None and r["threads"] == max(args.threads):
                eff_rows.append((r["scene"], r["bounces"], efficiency(args, mc, paths[r["scene"]], r["bounces"], sc)))

    # Each scene and bounce count: wedge, then Mitsuba straight after, so that a drift in the
    # host's speed (tens of per cent within the hour on some hosts) moves both sides alike. The
    # terrain (wedge alone) is traced with the first scene and printed last.
    terrain_rows = []
    for name in scenes:
        for b in args.bounces:
            terrain = name == scenes[0] and not args.no_terrain
            rows = wedge_throughput(args, [name], [b], args.threads, binary, terrain, args.repeats)
            terrain_rows += [r for r in rows if r["scene"] == "terrain"]
            print_rows([r for r in rows if r["scene"] != "terrain"])
    print_rows(terrain_rows)
    if eff_rows:
        print(f"\nEfficiency 1 / (MSE x seconds) at {args.spp} spp on every core (medians of {args.seeds} seeds):\n")
        print("| scene | bounces | wedge s | wedge RMSE | Mitsuba s | Mitsuba RMSE | efficiency, wedge / Mitsuba |")
        print("|---|---|---|---|---|---|---|")
        for name, b, e in eff_rows:
            (ws, wm), (ms, mm) = e["wedge"], e["mitsuba"]
            print(f"| {name} | {b} | {ws:.3f} | {wm ** 0.5:.5f} | {ms:.3f} | {mm ** 0.5:.5f} | {(ms * mm) / (ws * wm):.2f} |")
    if args.stages:
        print("\nShare of wedge's time per stage (perf, self time, 2 threads, `stage-symbols` build):\n")
        names = [s for s, _ in STAGES] + ["other"]
        print("| scene | bounces | " + " | ".join(names) + " |")
        print("|---|---|" + "---|" * len(names))
        for (name, b), acc in stages(args, scenes, args.bounces).items():
            print(f"| {name} | {b} | " + " | ".join(f"{acc[s]:.0f}%" for s in names) + " |")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""The race, recorded (issue 17): Mitsuba 3's path tracer, alone and with Intel OIDN, against
wedge's methods at equal wall time, on one scene, in one run.

    pip install mitsuba pyoidn numpy flip-evaluator
    apt-get install libllvm19      # for Mitsuba's llvm_ad_rgb variant
    export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so   # the default here if unset
    cargo build --release
    python3 bench/race.py cornell --bounces 0      # also --bounces 1 and 3
    python3 bench/race.py glossy-plates
    python3 bench/race.py cornell --bounces 1 --methods uniform,auto,uniform+oidn,auto+oidn
    python3 bench/race.py scenes/cornell.json --width 64 --height 64 --budgets 0.1,0.2 \
        --spp 1,2 --seeds 1 --reference-spp 64     # a smoke test

Not run in CI. Writes a Markdown report (default bench-results/race-<scene>-<W>x<H>-b<bounces>.md)
and a CSV beside it, and prints the equal-time table.

Reference: `wedge render --method uniform --max-spp N`, cached in bench-results/cache/ (wedge
agrees with Mitsuba within noise: BENCHMARKS.md, "Peers"). Errors leave out the pixels whose
reference exceeds --exclude-above in some channel (the light itself) and their 8 neighbours (the
pixels its edge crosses, whose error is the camera jitter's coverage of the edge, which no
denoiser and no filter touches and which would otherwise dominate the error), as the issue's
figures leave out the light's own pixels.
FLIP is LDR-FLIP (flip-evaluator) on sRGB-encoded images clamped to [0, 1].
The reference has noise of its own, which every error against it carries alike: at equal time
it pulls the ratios of the least noisy entries toward 1. `--subtract-reference-noise` renders a
second reference with another seed and takes that noise (half the two references' mean squared
difference) out of every RMSE and relative MSE.

A method `M@base` is wedge's method M run by the build `--wedge-base` names (a before/after
comparison in one run). A method `M/N` is wedge's method M with `--upsample N` (lobe-aware and normal-aware: indirect
light traced at every N-th pixel and upsampled). A method `M+oidn` is wedge's method M writing its denoiser inputs (`--aovs`) and OIDN run on
its frame with them, as for Mitsuba: its seconds are the render's plus OIDN's, and its row at
a budget is read off its curve over the budgets like Mitsuba's.

Time, on both sides, is the render alone: scene loading and acceleration structures excluded.
- wedge: `--time B`, its own wall-time halt, which starts after the scene is built and covers
  the G-buffer, every pass and the filters. Pass 0 always completes, so wedge may overrun B;
  the table shows its measured seconds and spp.
- Mitsuba: `path` integrator, `independent` sampler, at each --spp, timed warm (a first render
  compiles the kernels) up to the image in numpy. Mitsuba + OIDN adds an `aov` render of albedo
  and shading normal at the same spp and OIDN's RT filter (hdr, quality high, the noisy
  auxiliary images prefiltered), all three timed. Its value at a budget is interpolated in
  log(error) against log(time) along that curve (marked where extrapolated).
Both use every core. Mitsuba runs llvm_ad_rgb (probed in a subprocess: it once crashed in LLVM
code generation) or, failing that, scalar_rgb; scenes with glossy materials run scalar_rgb,
as the converter's glossy BSDF is a scalar Python plugin, and its times mean nothing then.
"""
import argparse
import csv
import hashlib
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

BENCH = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(BENCH)
LLVM = "llvm_ad_rgb"
os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM-19.so")
# FLIP's OpenMP threads would otherwise spin on both cores after each call, slowing whatever
# is timed next (by ~0.1 s, measured).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
# Beyond this factor outside Mitsuba's measured times its curve is not extended: extend --spp.
EXTRAPOLATE = 4.0
# Away from every measured seed (1..--seeds), so that no render shares the reference's samples.
REFERENCE_SEED = 1_000_003
# The second reference of --subtract-reference-noise: independent of the first.
SECOND_REFERENCE_SEED = 2_000_003
WARMUP_SEED = 999


def floats(s):
    return [float(x) for x in s.split(",") if x]


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", help="scene file, or a built-in name (scenes/NAME.json)")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=320)
    ap.add_argument("--bounces", type=int, help="indirect bounces (default: the scene's)")
    ap.add_argument("--budgets", type=floats, default=floats("0.25,0.5,1,2,4"), help="seconds, comma-separated")
    ap.add_argument("--spp", type=lambda s: [int(x) for x in floats(s)], default=[1, 2, 4, 8, 16, 32, 64])
    ap.add_argument("--methods", type=lambda s: [m for m in s.split(",") if m], default=["uniform", "aaf", "auto"])
    ap.add_argument("--seeds", type=int, default=3, help="renders per point; the tables show medians")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--exclude-above", type=float, default=1.0, help="leave out pixels whose reference exceeds this")
    ap.add_argument("--subtract-reference-noise", action="store_true",
                    help="render a second reference with another seed and take the reference's own noise, half their "
                         "mean squared difference, out of every RMSE and relative MSE (FLIP keeps it)")
    ap.add_argument("--no-mitsuba", action="store_true")
    ap.add_argument("--no-oidn", action="store_true")
    ap.add_argument("--set", action="append", default=[], metavar="GROUP.NAME=VALUE",
                    help="a method option for every wedge render (`wedge render --set`), repeatable")
    ap.add_argument("--save", help="directory for the images (EXR and PNG, first seed)")
    ap.add_argument("--wedge-base", help="an earlier wedge build, which methods named M@base run")
    ap.add_argument("--out", help="Markdown report (a CSV is written beside it)")
    ap.add_argument("--probe-llvm", action="store_true", help=argparse.SUPPRESS)
    return ap.parse_args(argv)


def scene_path(name):
    if os.path.isfile(name):
        return name
    path = os.path.join(ROOT, "scenes", name + ".json")
    if not os.path.isfile(path):
        raise SystemExit(f"{name}: no such file, nor {path}")
    return path


def import_converter(variant):
    """mitsuba_compare sets its Mitsuba variant from the environment when imported."""
    os.environ["WEDGE_MITSUBA_VARIANT"] = variant
    sys.path.insert(0, BENCH)
    import mitsuba_compare as mc
    return mc


def probe_llvm(path, bounces):
    """Whether the llvm variant renders this scene (path and aov), asked of a child process
    because a crash in LLVM code generation takes the whole process down."""
    cmd = [sys.executable, os.path.abspath(__file__), path, "--bounces", str(bounces), "--probe-llvm"]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    except subprocess.TimeoutExpired:
        return "timed out"
    return None if p.returncode == 0 else (p.stderr.strip().splitlines() or [f"exit status {p.returncode}"])[-1]


def run_probe(path, bounces):
    mc = import_converter(LLVM)
    import mitsuba as mi
    d = mc.to_mitsuba(json.load(open(path)), 16, 16, 2, bounces)
    d["sensor"]["sampler"] = {"type": "independent", "sample_count": 2}
    np.array(mi.render(mi.load_dict(d)))
    d["integrator"] = {"type": "aov", "aovs": "albedo:albedo,nn:sh_normal"}
    np.array(mi.render(mi.load_dict(d)))
    return 0


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055).astype(np.float32)


class Metrics:
    """RMSE over RGB, relative MSE and mean LDR-FLIP against the reference, over the pixels
    whose reference stays at or below the threshold in every channel."""

    def __init__(self, ref, exclude_above, second=None):
        self.ref = ref
        light = ref.max(axis=2) > exclude_above
        near = light.copy()
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                near[max(dy, 0):light.shape[0] + min(dy, 0), max(dx, 0):light.shape[1] + min(dx, 0)] |= \
                    light[max(-dy, 0):light.shape[0] + min(-dy, 0), max(-dx, 0):light.shape[1] + min(-dx, 0)]
        self.keep = ~near
        self.ref_ldr = srgb(ref)
        # The reference's own noise: an image X against it has E|X - ref|^2 = |X - truth|^2 +
        # Var(ref), and two references with independent seeds differ by 2 Var(ref) in
        # expectation. Subtracted, the errors are the truth's (0 where that goes negative).
        self.noise, self.rel_noise = 0.0, 0.0
        if second is not None:
            a, b = second[self.keep], ref[self.keep]
            self.noise = float(np.mean((a - b) ** 2)) / 2
            self.rel_noise = float(np.mean((a - b) ** 2 / (b ** 2 + 0.01))) / 2
        try:
            import flip_evaluator
            self.flip = flip_evaluator.evaluate
        except ImportError:
            self.flip = None

    def __call__(self, img):
        img = np.nan_to_num(img, nan=0.0, posinf=0.0, neginf=0.0)
        a, b = img[self.keep], self.ref[self.keep]
        rmse = float(np.sqrt(max(np.mean((a - b) ** 2) - self.noise, 0.0)))
        rel = max(float(np.mean((a - b) ** 2 / (b ** 2 + 0.01))) - self.rel_noise, 0.0)  # mitsuba_compare's rel_mse
        flip = math.nan
        if self.flip is not None:
            err = self.flip(self.ref_ldr, srgb(img), "LDR", applyMagma=False, computeMeanError=False)[0]
            flip = float(np.squeeze(err, axis=-1)[self.keep].mean())
        return rmse, rel, flip


def median_point(rows):
    """Per-column medians of several seeds' (seconds, spp, rmse, rel_mse, flip, ...) rows."""
    return [float(np.median([r[k] for r in rows])) for k in range(5)]


def save(directory, name, img):
    if directory:
        import mitsuba as mi
        os.makedirs(directory, exist_ok=True)
        for ext in ("exr", "png"):
            mi.util.write_bitmap(os.path.join(directory, f"{name}.{ext}"), img.astype(np.float32), write_async=False)


def reference(args, mc, path, name, bounces, seed=REFERENCE_SEED):
    digest = hashlib.sha1(open(path, "rb").read()).hexdigest()[:8]
    suffix = "" if seed == REFERENCE_SEED else f"-seed{seed}"
    key = f"race-{name}-{digest}-{args.width}x{args.height}-b{bounces}-{args.reference_spp}spp{suffix}.exr"
    cached = os.path.join(ROOT, "bench-results", "cache", key)
    if not os.path.exists(cached):
        print(f"reference: wedge uniform at {args.reference_spp} spp -> {cached}", flush=True)
        with tempfile.TemporaryDirectory() as tmp:
            _, secs = mc.wedge_reference(path, args.width, args.height, args.reference_spp, bounces, tmp, seed=seed)
            os.makedirs(os.path.dirname(cached), exist_ok=True)
            shutil.copy(os.path.join(tmp, "final.exr"), cached)
        print(f"reference took {secs:.1f} s", flush=True)
    return mc.read_wedge_exr(cached), cached


WROTE = re.compile(r"\((\d+) passes, ([0-9.]+) spp, ([0-9.]+) s.*stopped by ([^)]*)\)")


def wedge_oidn(mc, path):
    """OIDN (as for Mitsuba: hdr, quality high, noisy auxiliaries) on a wedge EXR written with
    --aovs: the denoised image and OIDN's seconds."""
    import mitsuba as mi
    import pyoidn
    color = mc.read_wedge_exr(path).astype(np.float32)
    layers = dict(mi.Bitmap(path).split())
    albedo = np.clip(np.array(layers["albedo"], dtype=np.float32), 0, 1)
    normal = np.clip(np.array(layers["normal"], dtype=np.float32), -1, 1)
    t = time.perf_counter()
    out = pyoidn.denoise(color, albedo, normal, hdr=True, quality="high")
    return np.asarray(out, dtype=np.float64), time.perf_counter() - t


def wedge_runs(args, mc, path, bounces, metrics):
    """{method: {budget: [(seconds, spp, rmse, rel_mse, flip, stopped by), ...per seed]}}. A
    method `M+oidn` renders with M and --aovs and denoises with OIDN: its time is wedge's
    render plus OIDN's, and its budget is the render's alone (as for Mitsuba + OIDN, the
    table reads its value at equal total time from the curve of budgets)."""
    out = {}
    if any(m.endswith("+oidn") for m in args.methods):
        import pyoidn  # loaded and run once untimed, as Mitsuba + OIDN is warmed up
        z = np.zeros((8, 8, 3), dtype=np.float32)
        pyoidn.denoise(z, z, z, hdr=True, quality="high")
    with tempfile.TemporaryDirectory() as tmp:
        for method in args.methods:
            base, oidn = (method[:-5], True) if method.endswith("+oidn") else (method, False)
            # `M@base`: M rendered by the --wedge-base binary (an earlier build, for a before/after
            # comparison in one run).
            base, _, other = base.partition("@")
            binary = args.wedge_base if other == "base" else mc.WEDGE
            if other and other != "base":
                raise SystemExit(f"{method}: the only build suffix is @base")
            if other and not (binary and os.path.exists(binary)):
                raise SystemExit(f"{method}: --wedge-base names no binary")
            # `M/N`: M with its indirect light traced at every N-th pixel and upsampled.
            base, _, factor = base.partition("/")
            for budget in args.budgets:
                rows = []
                for seed in range(1, args.seeds + 1):
                    cmd = [binary, "render", path, "--out", tmp, "--width", str(args.width), "--height", str(args.height),
                           "--seed", str(seed), "--method", base, "--time", str(budget), "--bounces", str(bounces)]
                    if oidn:
                        cmd.append("--aovs")
                    if factor:
                        cmd += ["--upsample", factor]
                    for assignment in args.set:
                        cmd += ["--set", assignment]
                    p = subprocess.run(cmd, capture_output=True, text=True)
                    m = WROTE.search(p.stderr)
                    if p.returncode != 0 or not m:
                        raise SystemExit(f"{' '.join(cmd)} failed:\n{p.stderr}")
                    seconds = float(m[3])
                    if oidn:
                        img, denoise_seconds = wedge_oidn(mc, os.path.join(tmp, "final.exr"))
                        seconds += denoise_seconds
                    else:
                        img = mc.read_wedge_exr(os.path.join(tmp, "final.exr"))
                    rows.append((seconds, float(m[2]), *metrics(img), m[4]))
                    if seed == 1:
                        save(args.save, f"wedge-{method}-{budget:g}s", img)
                out.setdefault(method, {})[budget] = rows
                print(f"wedge {method} {budget:g} s: RMSE {median_point(rows)[2]:.5f}", flush=True)
    return out


def mitsuba_runs(args, mc, scene, bounces, metrics, oidn):
    """({spp: rows} of the path tracer, {spp: rows} with OIDN); rows as wedge_runs', OIDN's with
    (path, aov, denoise) seconds after the metrics."""
    import drjit as dr
    import mitsuba as mi
    d = mc.to_mitsuba(scene, args.width, args.height, 1, bounces)
    d["sensor"]["sampler"] = {"type": "independent", "sample_count": 1}
    path_scene = mi.load_dict(d)
    aov_scene = mi.load_dict({**d, "integrator": {"type": "aov", "aovs": "albedo:albedo,nn:sh_normal"}}) if oidn else None

    def render(sc, spp, seed):
        img = np.array(mi.render(sc, seed=seed, spp=spp), dtype=np.float32)  # evaluates and waits
        dr.sync_thread()
        return img

    def denoise(img, aux):
        return pyoidn.denoise(img, np.clip(aux[..., :3], 0, 1), np.clip(aux[..., 3:6], -1, 1), hdr=True, quality="high")

    if oidn:
        import pyoidn
    jit = not mi.variant().startswith("scalar")
    plain, denoised = {}, {}
    for i, spp in enumerate(args.spp):
        if jit or i == 0:  # kernels are compiled per spp; scalar has nothing to compile
            img = render(path_scene, spp, WARMUP_SEED)
            if oidn:
                denoise(img, render(aov_scene, spp, WARMUP_SEED))
        for seed in range(1, args.seeds + 1):
            # The timed steps run back to back, the metrics (FLIP is multithreaded) after them.
            t0 = time.perf_counter()
            img = render(path_scene, spp, seed)
            t1 = time.perf_counter()
            if oidn:
                # The AOVs with the path render's seed: the pixel positions a renderer writing
                # them in the same pass would use.
                aux = render(aov_scene, spp, seed)
                t2 = time.perf_counter()
                out = denoise(img, aux)
                t3 = time.perf_counter()
            plain.setdefault(spp, []).append((t1 - t0, spp, *metrics(img)))
            if oidn:
                denoised.setdefault(spp, []).append((t3 - t0, spp, *metrics(out.astype(np.float64)), t1 - t0, t2 - t1, t3 - t2))
            if seed == 1:
                save(args.save, f"mitsuba-{spp}spp", img)
                if oidn:
                    save(args.save, f"mitsuba-oidn-{spp}spp", out)
        print(f"Mitsuba {spp} spp: {median_point(plain[spp])[0]:.3f} s, RMSE {median_point(plain[spp])[2]:.5f}"
              + (f"; + OIDN {median_point(denoised[spp])[0]:.3f} s, RMSE {median_point(denoised[spp])[2]:.5f}" if oidn else ""),
              flush=True)
    return plain, denoised


def at_time(points, budget):
    """Values at `budget` seconds along a curve of (seconds, spp, rmse, rel_mse, flip) medians,
    each interpolated linearly in log-log between the neighbouring times (the end segment
    beyond them, up to EXTRAPOLATE times its range, NaN further); and whether that
    extrapolated."""
    # Timing noise can make a lower spp look slower than a higher one, which would fold the
    # curve: each point takes the least time of any higher spp (in Mitsuba's favour), and of
    # points with equal times the highest spp stays.
    pts, best = [], math.inf
    for p in sorted(points, key=lambda p: -p[1]):
        if 0 < p[0] < best:
            best = p[0]
            pts.append([best, *p[1:5]])
    pts.reverse()
    if len(pts) < 2 or not pts[0][0] / EXTRAPOLATE <= budget <= pts[-1][0] * EXTRAPOLATE:
        return [math.nan] * 4, True
    lt = [math.log(p[0]) for p in pts]
    x = math.log(budget)
    k = min(max(np.searchsorted(lt, x) - 1, 0), len(pts) - 2)
    w = (x - lt[k]) / (lt[k + 1] - lt[k]) if lt[k + 1] > lt[k] else 0.0
    vals = []
    for c in range(1, 5):
        a, b = pts[k][c], pts[k + 1][c]
        vals.append(math.exp((1 - w) * math.log(a) + w * math.log(b)) if a > 0 and b > 0 else math.nan)
    return vals, not (pts[0][0] <= budget <= pts[-1][0])


def f(x, spec=".4g"):
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def machine():
    lines = open("/proc/cpuinfo").read().splitlines()
    model = next((l.split(":", 1)[1].strip() for l in lines if l.startswith("model name")), "?")
    flags = next((l.split(":", 1)[1].split() for l in lines if l.startswith("flags")), [])
    # The workplace's hosts share a model name with and without AVX-512 (Mitsuba's LLVM kernels
    # use it, wedge's code does not), which moves every comparison with Mitsuba: name it.
    simd = "AVX-512" if "avx512f" in flags else "no AVX-512"
    return f"nproc {subprocess.run(['nproc'], capture_output=True, text=True).stdout.strip()}, {model} ({simd})"


def oidn_version():
    import pyoidn
    return pyoidn.version.oidn_version


def commit():
    git = lambda *a: subprocess.run(["git", "-C", ROOT, *a], capture_output=True, text=True).stdout.strip()
    dirty = git("status", "--porcelain", "--untracked-files=no")
    return git("rev-parse", "--short", "HEAD") + (" (with uncommitted changes)" if dirty else "")


def main():
    args = parse_args()
    path = scene_path(args.scene)
    scene = json.load(open(path))
    name = os.path.splitext(os.path.basename(path))[0]
    bounces = args.bounces if args.bounces is not None else scene.get("settings", {}).get("bounces", 0)
    if args.probe_llvm:
        return run_probe(path, bounces)
    notes = []
    glossy = any("glossy" in m for m in scene.get("materials", []))
    variant = "scalar_rgb"
    if args.no_mitsuba:
        pass
    elif glossy:
        notes.append("**Mitsuba's times are not representative**: this scene's glossy materials go through the "
                     "converter's Python BSDF plugin, which runs only in `scalar_rgb`, once per shading point.")
    else:
        failure = probe_llvm(path, bounces)
        if failure is None:
            variant = LLVM
        else:
            print(f"WARNING: Mitsuba's {LLVM} failed ({failure}); falling back to scalar_rgb, which is slower", file=sys.stderr)
            notes.append(f"Mitsuba's `{LLVM}` failed to render ({failure}): `scalar_rgb` instead, slower than llvm.")
    mc = import_converter(variant)
    import mitsuba as mi
    if not os.path.exists(mc.WEDGE):
        raise SystemExit(f"{mc.WEDGE} missing: cargo build --release")
    ref, ref_file = reference(args, mc, path, name, bounces)
    second = reference(args, mc, path, name, bounces, SECOND_REFERENCE_SEED)[0] if args.subtract_reference_noise else None
    metrics = Metrics(ref, args.exclude_above, second)
    if second is not None:
        notes.append(f"The reference's own noise is taken out of every RMSE and relative MSE (MSE {metrics.noise:.3g}, "
                     f"relative MSE {metrics.rel_noise:.3g}: half the mean squared difference of two references with "
                     "different seeds); "
                     "FLIP keeps it.")
    excluded = int((~metrics.keep).sum())
    if metrics.flip is None:
        notes.append("flip-evaluator is not installed: no FLIP (`pip install flip-evaluator`).")
    save(args.save, "reference", ref)

    curves = {}  # entry -> {x: seed rows}; Mitsuba's keyed by spp, wedge's by budget
    oidn = not args.no_mitsuba and not args.no_oidn
    if not args.no_mitsuba:
        plain, denoised = mitsuba_runs(args, mc, scene, bounces, metrics, oidn)
        curves["Mitsuba"] = plain
        if oidn:
            curves["Mitsuba+OIDN"] = denoised
    wedge = wedge_runs(args, mc, path, bounces, metrics)
    for method, rows in wedge.items():
        curves[f"wedge {method}"] = rows

    # The equal-time table: wedge measured at each budget, Mitsuba read off its curves.
    table = []
    for budget in args.budgets:
        rows = []
        for entry, points in curves.items():
            if entry.startswith("wedge") and not entry.endswith("+oidn"):
                secs, spp, rmse, rel, flip = median_point(points[budget])
                rows.append([budget, entry, secs, spp, rmse, rel, flip, False])
            else:
                (spp, rmse, rel, flip), extrap = at_time([median_point(r) for r in points.values()], budget)
                rows.append([budget, entry, budget, spp, rmse, rel, flip, extrap])
        # The ratios compare each entry with the baseline at the entry's own seconds: a wedge
        # render ends past its budget by its final frame's filter, and is charged for it.
        base_entry = "Mitsuba+OIDN" if "Mitsuba+OIDN" in curves else "Mitsuba" if "Mitsuba" in curves else None
        for r in rows:
            if base_entry is None:
                r += [math.nan, math.nan]
                continue
            (_, b_rmse, _, b_flip), _ = at_time([median_point(p) for p in curves[base_entry].values()], r[2])
            r += [r[4] / b_rmse if b_rmse > 0 else math.nan, r[6] / b_flip if b_flip > 0 else math.nan]
        table += rows
    base_name = "Mitsuba+OIDN" if oidn else "(no Mitsuba)" if args.no_mitsuba else "Mitsuba"

    lines = [f"# The race: {name}, {args.width}x{args.height}, {bounces} bounce{'s' if bounces != 1 else ''}", "",
             f"- command: `{' '.join(['python3', 'bench/race.py'] + sys.argv[1:])}`",
             f"- commit: {commit()}; machine: {machine()}",
             f"- Mitsuba {mi.__version__} (`{variant}`), OIDN {oidn_version() if oidn else '—'}; "
             f"medians of {args.seeds} seed(s)",
             f"- reference: wedge `uniform`, {args.reference_spp} spp (`{os.path.relpath(ref_file, ROOT)}`)",
             f"- errors over {metrics.keep.size - excluded} of {metrics.keep.size} pixels: {excluded} excluded "
             f"(reference above {args.exclude_above:g} in some channel, and their 8 neighbours: the light and its edge)",
             "- FLIP: LDR-FLIP (flip-evaluator) on sRGB-encoded images clamped to [0, 1], mean over the same pixels",
             "- time: the render alone (scene loading excluded). wedge: its own `--time` halt, measured seconds shown. "
             "Mitsuba: warm render to numpy; +OIDN adds the aov render and the denoise. Mitsuba's rows at a budget are "
             f"interpolated in log-log along its curve below (* = extrapolated; — = more than {EXTRAPOLATE:g}x outside "
             "its measured times: extend --spp). The ratio columns read the baseline's curve at each entry's own "
             "seconds, so a render that ends past its budget is compared with the baseline given as long."]
    lines += [f"- {n}" for n in notes]
    eq = ["| budget s | entry | seconds | spp | RMSE | rel. MSE | FLIP | RMSE / " + base_name + " | FLIP / " + base_name + " |",
          "|---|---|---|---|---|---|---|---|---|"]
    for b, e, secs, spp, rmse, rel, flip, extrap, r1, r2 in table:
        star = "*" if extrap and not math.isnan(rmse) else ""
        eq.append(f"| {b:g} | {e} | {f(secs, '.3f')} | {f(spp, '.1f')}{star} | {f(rmse, '.5f')}{star} | "
                  f"{f(rel, '.3e')}{star} | {f(flip, '.4f')}{star} | {f(r1, '.3f')} | {f(r2, '.3f')} |")
    lines += ["", "## Equal time", ""] + eq + ["", "## Measured curves (medians)", ""]
    lines += ["| entry | budget s or spp | seconds | spp | RMSE | rel. MSE | FLIP | path s | aov s | denoise s | stopped by |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for entry, points in curves.items():
        for x, rows in points.items():
            secs, spp, rmse, rel, flip = median_point(rows)
            parts = [float(np.median([r[k] for r in rows])) for k in (5, 6, 7)] if entry == "Mitsuba+OIDN" else [None] * 3
            stop = "; ".join(sorted({r[5] for r in rows})) if entry.startswith("wedge") else ""
            lines.append(f"| {entry} | {x:g} | {secs:.3f} | {spp:.1f} | {rmse:.5f} | {rel:.3e} | {f(flip, '.4f')} | "
                         + " | ".join(f(p, ".3f") for p in parts) + f" | {stop} |")
    out = args.out or os.path.join(ROOT, "bench-results", f"race-{name}-{args.width}x{args.height}-b{bounces}.md")
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    with open(out, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    with open(os.path.splitext(out)[0] + ".csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["kind", "scene", "width", "height", "bounces", "entry", "budget_or_spp", "seconds", "spp", "rmse",
                    "rel_mse", "flip", "extrapolated", "rmse_ratio", "flip_ratio"])
        for b, e, secs, spp, rmse, rel, flip, extrap, r1, r2 in table:
            w.writerow(["equal-time", name, args.width, args.height, bounces, e, b, secs, spp, rmse, rel, flip, int(extrap), r1, r2])
        for entry, points in curves.items():
            for x, rows in points.items():
                w.writerow(["curve", name, args.width, args.height, bounces, entry, x, *median_point(rows), "", "", ""])
    print("\n" + "\n".join(lines[2:] + [""]))
    print(f"wrote {out} and its .csv")
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""The `bandwidth` method (Bagher et al. 2012) against `uniform` on environment-lit scenes.

Builds the scenes (the built-in `sky-spheres`, and two built-in scenes relit by maps from
../shared/assets: `glossy-plates` under Grace Cathedral and `curved` under the Uffizi), copies
each map next to its scene file (scene files may only name files under their own directory),
and runs `wedge bench` on them with the methods `uniform` and `bandwidth`: error against time,
medians over seeds, jittered pixels, the reference rendered by `uniform`. The bench's
"speedup at equal error (time)" column is the efficiency ratio the issue's target is about;
its "method share" column for `bandwidth` is the share of time spent predicting bandwidth and
planning the passes. Per-pass shaded and full-resolution sample counts come from
`wedge render` (the EXR header's `wedge.shadedPoints` / `wedge.fullResolutionPoints`).

    python3 bench/bandwidth.py [--wedge target/release/wedge] [--out bench-results/bandwidth]
"""
import argparse
import json
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
ASSETS = os.path.join(ROOT, "..", "shared", "assets", "envmaps")

RELIT = [
    # (name, built-in scene file, map, rotation_deg, scale)
    ("plates-grace", "glossy-plates.json", "debevec-grace-pbrt-v2/grace_latlong.exr", 90.0, 1.0),
    ("curved-uffizi", "curved.json", "probulator-256x128/uffizi.hdr", 0.0, 1.0),
]


def relit_scene(out, name, base, env_map, rotation, scale):
    """`base` with its lights replaced by the map, written to out/name/name.json."""
    d = os.path.join(out, "scenes", name)
    os.makedirs(d, exist_ok=True)
    src = os.path.join(ASSETS, env_map)
    if not os.path.exists(src):
        sys.exit(f"bandwidth.py: {src} not found (../shared/assets is needed for the relit scenes)")
    shutil.copy(src, os.path.join(d, os.path.basename(src)))
    scene = json.load(open(os.path.join(ROOT, "scenes", base)))
    scene["description"] = f"{scene.get('description', base)}, relit by {os.path.basename(src)}"
    scene["lights"] = [{"environment": {"path": os.path.basename(src), "rotationDeg": rotation, "scale": scale}}]
    path = os.path.join(d, f"{name}.json")
    with open(path, "w") as f:
        json.dump(scene, f, indent=1)
    return path


def shaded_points(wedge, scene, out, passes):
    """Shaded and full-resolution camera samples of each pass of one `bandwidth` render."""
    rows = []
    tmp = os.path.join(out, "passes")
    subprocess.run([wedge, "render", scene, "--method", "bandwidth", "--max-passes", str(passes), "--every", "1",
                    "--out", tmp], check=True, capture_output=True)
    import mitsuba as mi  # reads EXR headers; installed by bench/mitsuba_compare.py's users

    mi.set_variant("scalar_rgb")
    for p in range(passes):
        meta = mi.Bitmap(os.path.join(tmp, f"pass_{p:03}.exr")).metadata()
        shaded, full = int(meta["wedge.shadedPoints"]), int(meta["wedge.fullResolutionPoints"])
        rows.append((p, shaded, full))
    shutil.rmtree(tmp)
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--wedge", default=os.path.join(ROOT, "target", "release", "wedge"))
    ap.add_argument("--out", default=os.path.join(ROOT, "bench-results", "bandwidth"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--reference-spp", type=int, default=2048)
    ap.add_argument("--uniform-passes", type=int, default=9, help="uniform's sweep: 1, 2, 4, ... spp")
    ap.add_argument("--passes", type=int, default=7, help="bandwidth's sweep")
    ap.add_argument("--bounces", type=int, help="override every scene's bounces")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    scenes = ["sky-spheres"] + [relit_scene(args.out, *r) for r in RELIT]
    cmd = [args.wedge, "bench", *scenes, "--methods", "uniform,bandwidth", "--repeats", str(args.repeats),
           "--reference-spp", str(args.reference_spp), "--uniform-passes", str(args.uniform_passes),
           "--passes", str(args.passes), "--out", args.out, "--name", "bandwidth"]
    if args.bounces is not None:
        cmd += ["--bounces", str(args.bounces)]
    print("$", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True)
    print("\n### Shaded camera samples per pass (seed 0)\n")
    print("| scene | pass | shaded | full resolution | share |")
    print("|---|---|---|---|---|")
    for s in scenes:
        name = os.path.splitext(os.path.basename(s))[0]
        for p, shaded, full in shaded_points(args.wedge, s, args.out, args.passes):
            print(f"| {name} | {p} | {shaded} | {full} | {shaded / max(full, 1):.1%} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

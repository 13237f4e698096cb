"""Per-seed errors at equal spp for this build and a base (an earlier build, or this one with
other settings): the mean squared error over seeds next to the median RMSE the race reports,
its split into squared bias and variance (from the seeds' mean image and spread), and the share
of the squared error in the worst 1% of pixels. A heavy-tailed estimator (rare, huge samples)
has a mean far above its median, which medians of a few seeds hide; a filter that is too wide
shows as bias, one too narrow as variance. Not run in CI.

    python3 bench/seeds.py glossy-plates --width 320 --height 240 --method uniform --spp 16 \\
        --seeds 8 --wedge-base OLD/target/release/wedge
    python3 bench/seeds.py cornell --width 320 --height 320 --bounces 1 --method auto --spp 16 \\
        --seeds 6 --base-set auto.narrow_from_spp=32

The reference is the race's (`bench/race.py`: `uniform` at --reference-spp, cached in
bench-results/cache, rendered if missing); errors leave out the pixels above 1 in it and their
8 neighbours, as the race does.
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mitsuba_compare as mc  # noqa: E402
import race  # noqa: E402


def kept(ref):
    bright = (ref > 1).any(axis=2)
    mask = bright.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            mask |= np.roll(np.roll(bright, dy, 0), dx, 1)
    return ~mask


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", help="scene file, or a built-in name (scenes/NAME.json)")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--bounces", type=int, help="indirect bounces (default: the scene's)")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--method", default="uniform")
    ap.add_argument("--spp", default="16", help="comma-separated")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--set", action="append", default=[], metavar="GROUP.NAME=VALUE",
                    help="a method option for this build's renders, repeatable")
    ap.add_argument("--wedge-base", help="an earlier build to compare with")
    ap.add_argument("--base-set", action="append", default=[], metavar="GROUP.NAME=VALUE",
                    help="a method option for the base's renders (the base is this build unless --wedge-base)")
    args = ap.parse_args()
    path = race.scene_path(args.scene)
    name = os.path.splitext(os.path.basename(path))[0]
    bounces = args.bounces
    if bounces is None:
        import json
        bounces = json.load(open(path)).get("settings", {}).get("bounces", 0)
    ref, ref_file = race.reference(args, mc, path, name, bounces)
    keep = kept(ref)
    builds = [("this build", mc.WEDGE, args.set)]
    if args.wedge_base or args.base_set:
        builds.append(("base", args.wedge_base or mc.WEDGE, args.base_set))
    print(f"{name}, {args.width}x{args.height}, {bounces} bounce(s), `{args.method}`, {args.seeds} seeds; "
          f"reference {os.path.relpath(ref_file, race.ROOT)}")
    for label, _, settings in builds:
        print(f"- {label}: {' '.join('--set ' + s for s in settings) or 'defaults'}")
    print()
    print("| spp | build | mean MSE over seeds | bias^2 | variance | median RMSE | worst 1% of pixels' share |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for spp in (int(s) for s in args.spp.split(",")):
            for label, binary, settings in builds:
                images, mse, share = [], [], []
                for seed in range(1, args.seeds + 1):
                    cmd = [binary, "render", path, "--out", tmp, "--width", str(args.width), "--height",
                           str(args.height), "--bounces", str(bounces), "--method", args.method, "--max-spp",
                           str(spp), "--seed", str(seed)]
                    for s in settings:
                        cmd += ["--set", s]
                    subprocess.run(cmd, check=True, capture_output=True)
                    img = mc.read_wedge_exr(os.path.join(tmp, "final.exr"))
                    images.append(img)
                    e = ((img - ref) ** 2).mean(axis=2)[keep]
                    mse.append(e.mean())
                    worst = np.sort(e)[::-1]
                    share.append(worst[: len(worst) // 100].sum() / worst.sum())
                images = np.array(images)
                # Per pixel: the seeds' variance, and the mean image's squared error less the part
                # of it the mean's own variance explains (var / seeds).
                variance = images.var(axis=0, ddof=1).mean(axis=2)[keep].mean() if args.seeds > 1 else np.nan
                bias2 = ((images.mean(axis=0) - ref) ** 2).mean(axis=2)[keep].mean() - variance / args.seeds
                print(f"| {spp} | {label} | {np.mean(mse):.3e} | {bias2:.2e} | {variance:.2e} | "
                      f"{np.median(np.sqrt(mse)):.5f} | {np.median(share):.2f} |", flush=True)


if __name__ == "__main__":
    main()

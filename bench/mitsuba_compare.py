#!/usr/bin/env python3
"""Cross-checks wedge against Mitsuba 3 on the same scenes.

    pip install mitsuba numpy
    cargo build --release
    python3 bench/mitsuba_compare.py scenes/cornell.json scenes/curved.json scenes/grids.json

For each wedge scene file (canonical protobuf JSON) this
1. converts it to a Mitsuba 3 scene (same triangles, camera, BRDFs, emitters, bounces);
2. renders a high-spp reference with wedge (`wedge render --method uniform`) and with Mitsuba,
   and reports their relative MSE and mean ratio next to each renderer's own noise (the same
   renderer with another seed). Two independent noisy images differ by the sum of their
   variances, so with nothing systematic, wedge vs Mitsuba equals the mean of the two noise
   columns;
3. times Mitsuba at increasing spp and reports its RMSE against its own reference, next to
   the same curve for wedge's methods from `wedge bench`, for BENCHMARKS.md.

Conventions matched:
- box pixel filter (wedge jitters uniformly inside each pixel);
- one-sided rectangular emitters whose backs are black (wedge's emitter surfaces reflect nothing);
- Mitsuba's max_depth = bounces + 2 (1 is emitters seen directly, 2 adds direct light);
- the Gaussian emission profile as a radiance texture over the rectangle.
Only what wedge's built-in scenes use is converted (Lambertian materials with constant or checker
albedo, rect and point lights); anything else is reported, not approximated.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

import mitsuba as mi

# scalar_rgb everywhere: the llvm variant crashed in LLVM code generation on the CI machine
# type. WEDGE_MITSUBA_VARIANT=llvm_ad_rgb selects it where it works.
mi.set_variant(os.environ.get("WEDGE_MITSUBA_VARIANT", "scalar_rgb"))
mi.set_log_level(mi.LogLevel.Error)  # warnings would land inside the printed tables
T = mi.ScalarTransform4f
HERE = os.path.dirname(os.path.abspath(__file__))
WEDGE = os.path.join(HERE, "..", "target", "release", "wedge")


def vec(v, default=(0.0, 0.0, 0.0)):
    if v is None:
        return np.array(default, dtype=np.float64)
    return np.array([v.get("x", 0.0), v.get("y", 0.0), v.get("z", 0.0)], dtype=np.float64)


def rgb(c):
    return [c.get("r", 0.0), c.get("g", 0.0), c.get("b", 0.0)]


def transform(t):
    """The shape transform as a 4x4 matrix: scale, then rotate, then translate; or `matrix`."""
    if not t:
        return np.eye(4)
    if t.get("matrix"):
        return np.array(t["matrix"], dtype=np.float64).reshape(4, 4)
    s = vec(t.get("scale"), (1.0, 1.0, 1.0)) if "scale" in t else np.ones(3)
    m = np.diag([s[0], s[1], s[2], 1.0])
    deg = t.get("rotateDeg", 0.0)
    if deg:
        a = vec(t.get("rotateAxis"))
        a = a / np.linalg.norm(a)
        th = math.radians(deg)
        c, si = math.cos(th), math.sin(th)
        x, y, z = a
        r = np.array([[c + x * x * (1 - c), x * y * (1 - c) - z * si, x * z * (1 - c) + y * si],
                      [y * x * (1 - c) + z * si, c + y * y * (1 - c), y * z * (1 - c) - x * si],
                      [z * x * (1 - c) - y * si, z * y * (1 - c) + x * si, c + z * z * (1 - c)]])
        rot = np.eye(4)
        rot[:3, :3] = r
        m = rot @ m
    tr = np.eye(4)
    tr[:3, 3] = vec(t.get("translate"))
    return tr @ m


def geometry(shape):
    """Local-space (positions Nx3, indices Mx3, uvs Nx2 or None), tessellated as wedge does."""
    if "mesh" in shape:
        m = shape["mesh"]
        if m.get("path"):
            raise SystemExit("mesh files are not converted: inline them first (wedge client does)")
        p = np.array(m["positions"], dtype=np.float64).reshape(-1, 3)
        i = np.array(m["indices"], dtype=np.int64).reshape(-1, 3)
        uv = np.array(m["uvs"], dtype=np.float64).reshape(-1, 2) if m.get("uvs") else None
        nrm = np.array(m["normals"], dtype=np.float64).reshape(-1, 3) if m.get("normals") else None
        return p, i, uv, nrm
    if "quad" in shape:
        q = shape["quad"]
        c, u, v = vec(q.get("corner")), vec(q.get("edgeU")), vec(q.get("edgeV"))
        return np.array([c, c + u, c + u + v, c + v]), np.array([[0, 1, 2], [0, 2, 3]]), np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float), None
    if "box" in shape:
        lo, hi = vec(shape["box"].get("min")), vec(shape["box"].get("max"))
        s = hi - lo
        ex, ey, ez = np.array([s[0], 0, 0]), np.array([0, s[1], 0]), np.array([0, 0, s[2]])
        faces = [(lo, ey, ez), (lo + ex, ey, ez), (lo, ex, ez), (lo + ey, ex, ez), (lo, ex, ey), (lo + ez, ex, ey)]
        centre = (lo + hi) / 2
        p, idx, uv = [], [], []
        for c, u, v in faces:
            if np.dot(np.cross(u, v), c + (u + v) / 2 - centre) < 0:
                u, v = v, u
            k = len(p)
            p += [c, c + u, c + u + v, c + v]
            uv += [[0, 0], [1, 0], [1, 1], [0, 1]]
            idx += [[k, k + 1, k + 2], [k, k + 2, k + 3]]
        return np.array(p), np.array(idx), np.array(uv, float), None
    if "sphere" in shape:
        sp = shape["sphere"]
        c, r, bands = vec(sp.get("center")), sp["radius"], sp.get("subdivisions", 0) or 24
        segs = 2 * bands
        p, uv, idx = [], [], []
        for i in range(bands + 1):
            st, ct = (0.0, 1.0) if i == 0 else (0.0, -1.0) if i == bands else (math.sin(math.pi * i / bands), math.cos(math.pi * i / bands))
            for j in range(segs + 1):
                phi = 2 * math.pi * j / segs
                p.append(c + r * np.array([st * math.cos(phi), ct, st * math.sin(phi)]))
                uv.append([j / segs, i / bands])
        row = segs + 1
        for i in range(bands):
            for j in range(segs):
                a, b = i * row + j, (i + 1) * row + j
                idx += [[a, a + 1, b], [a + 1, b + 1, b]]
        nrm = (np.array(p) - c) / r
        return np.array(p), np.array(idx), np.array(uv, float), nrm
    raise SystemExit(f"shape not converted: {list(shape)}")


def material(m, uses_uv):
    a = m.get("lambertian", {}).get("albedo")
    if a is None:
        raise SystemExit(f"material {m.get('name')}: only lambertian is converted")
    if "constant" in a:
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb(a["constant"])}}
    ch = a["checker"]
    # wedge: even where floor(u s) + floor(v s) is even. Mitsuba's checkerboard over [0,1]^2 is
    # color0 where the cell sum is even, on a 2 x 2 board: scale uv by s/2.
    return {"type": "diffuse", "reflectance": {"type": "checkerboard", "color0": {"type": "rgb", "value": rgb(ch["even"])},
                                               "color1": {"type": "rgb", "value": rgb(ch["odd"])},
                                               "to_uv": T.scale([ch["scale"] / 2, ch["scale"] / 2, 1])}}


def to_mitsuba(scene, width, height, spp, bounces):
    cam = scene["camera"]
    d = {"type": "scene",
         "integrator": {"type": "path", "max_depth": bounces + 2, "hide_emitters": False},
         "sensor": {"type": "perspective", "fov_axis": "y", "fov": cam["verticalFovDeg"],
                    # Mitsuba's look_at has the same handedness as wedge's camera (image x along
                    # forward x up): checked on the asymmetric Cornell box.
                    "to_world": T.look_at(origin=vec(cam.get("position")).tolist(), target=vec(cam.get("lookAt")).tolist(),
                                          up=vec(cam.get("up"), (0, 1, 0)).tolist() if cam.get("up") else [0, 1, 0]),
                    "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                    "sampler": {"type": "ldsampler", "sample_count": spp}}}
    mats = {m["name"]: m for m in scene.get("materials", [])}
    names = {s["name"]: s for s in scene.get("shapes", []) if s.get("name")}
    for k, s in enumerate(scene.get("shapes", [])):
        src = names[s["instance"]["shape"]] if "instance" in s else s
        mat_name = s.get("material") or src.get("material")
        p, idx, uv, nrm = geometry(src)
        m = transform(s.get("transform"))
        pw = (m[:3, :3] @ p.T).T + m[:3, 3]
        nw = None
        if nrm is not None:
            nw = (np.linalg.inv(m[:3, :3]).T @ nrm.T).T
            nw /= np.linalg.norm(nw, axis=1, keepdims=True)
        # Texture coordinates only where the material reads them, as wedge stores them.
        uses_uv = "checker" in mats[mat_name].get("lambertian", {}).get("albedo", {})
        d[f"shape{k}"] = {"type": "ply", "filename": write_ply(pw, idx, uv if uses_uv else None, nw),
                          # wedge shades both sides of every surface; Mitsuba's BSDFs are one-sided.
                          "bsdf": {"type": "twosided", "bsdf": material(mats[mat_name], uses_uv)}, "face_normals": nw is None}
    for k, l in enumerate(scene.get("lights", [])):
        if "point" in l:
            pt = l["point"]
            d[f"light{k}"] = {"type": "point", "position": vec(pt.get("position")).tolist(), "intensity": {"type": "rgb", "value": rgb(pt["intensity"])}}
            continue
        r = l["rect"]
        c, u, v = vec(r.get("corner")), vec(r.get("edgeU")), vec(r.get("edgeV"))
        n = np.cross(u, v)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u / 2, v / 2, n / np.linalg.norm(n), c + (u + v) / 2
        radiance = {"type": "rgb", "value": rgb(r["radiance"])}
        if r.get("profile") == "EMISSION_PROFILE_GAUSSIAN":
            # exp(-|y - c|^2 / (2 sigma^2)), sigma = sqrt(area)/2, over the rectangle's uv.
            res = 256
            s = np.linspace(-1 + 1 / res, 1 - 1 / res, res)
            xx, yy = np.meshgrid(s, s)
            sigma2 = np.linalg.norm(n) / 4
            w = np.exp(-((xx * np.linalg.norm(u) / 2) ** 2 + (yy * np.linalg.norm(v) / 2) ** 2) / (2 * sigma2))
            img = w[:, :, None] * np.array(rgb(r["radiance"]))[None, None, :]
            radiance = {"type": "bitmap", "bitmap": mi.Bitmap(img.astype(np.float32)), "raw": True, "filter_type": "bilinear"}
        d[f"light{k}"] = {"type": "rectangle", "to_world": T(m.tolist()), "flip_normals": False,
                          "emitter": {"type": "area", "radiance": radiance},
                          "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0, 0, 0]}}}
    return d


_tmp = tempfile.mkdtemp(prefix="wedge-mitsuba-")


def write_ply(p, idx, uv, nrm):
    path = os.path.join(_tmp, f"m{len(os.listdir(_tmp))}.ply")
    with open(path, "w") as f:
        f.write(f"ply\nformat ascii 1.0\nelement vertex {len(p)}\nproperty float x\nproperty float y\nproperty float z\n")
        if nrm is not None:
            f.write("property float nx\nproperty float ny\nproperty float nz\n")
        if uv is not None:
            f.write("property float u\nproperty float v\n")
        f.write(f"element face {len(idx)}\nproperty list uchar int vertex_indices\nend_header\n")
        for k, q in enumerate(p):
            line = f"{q[0]} {q[1]} {q[2]}"
            if nrm is not None:
                line += f" {nrm[k][0]} {nrm[k][1]} {nrm[k][2]}"
            if uv is not None:
                line += f" {uv[k][0]} {uv[k][1]}"
            f.write(line + "\n")
        for t in idx:
            f.write(f"3 {t[0]} {t[1]} {t[2]}\n")
    return path


def wedge_reference(path, width, height, spp, bounces, out, seed=7):
    cmd = [WEDGE, "render", path, "--method", "uniform", "--width", str(width), "--height", str(height),
           "--max-spp", str(spp), "--bounces", str(bounces), "--seed", str(seed), "--out", out, "--reproducible"]
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    secs = time.perf_counter() - t
    bmp = mi.Bitmap(os.path.join(out, "final.exr"))
    layers = dict(bmp.split())
    key = next(k for k in layers if k in ("<root>", "", "R,G,B") or k.endswith("RGB"))
    return np.array(layers[key], dtype=np.float64)[:, :, :3], secs


def mitsuba_render(scene_dict, spp, seed=0):
    scene_dict = dict(scene_dict)
    scene_dict["sensor"] = dict(scene_dict["sensor"])
    # Mitsuba's low-discrepancy sampler: stratified like wedge's, its best for a fair timing.
    scene_dict["sensor"]["sampler"] = {"type": "ldsampler", "sample_count": spp}
    scene = mi.load_dict(scene_dict)
    t = time.perf_counter()
    img = np.array(mi.render(scene, seed=seed), dtype=np.float64)
    return img, time.perf_counter() - t


def rel_mse(a, b):
    return float(np.mean((a - b) ** 2 / (b ** 2 + 0.01)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--max-spp", type=int, default=256)
    ap.add_argument("--bounces", type=int, help="override the scenes' indirect bounces")
    args = ap.parse_args()
    print(f"Mitsuba {mi.__version__} ({mi.variant()}), wedge {WEDGE}\n")
    print("| scene | spp | wedge s | Mitsuba s | relative MSE wedge vs Mitsuba | noise: wedge vs wedge | noise: Mitsuba vs Mitsuba | mean ratio wedge/Mitsuba |")
    print("|---|---|---|---|---|---|---|---|")
    curves = {}
    for path in args.scenes:
        scene = json.load(open(path))
        name = os.path.splitext(os.path.basename(path))[0]
        bounces = args.bounces if args.bounces is not None else scene.get("settings", {}).get("bounces", 0)
        d = to_mitsuba(scene, args.width, args.height, args.reference_spp, bounces)
        out = os.path.join(_tmp, name)
        w, ws = wedge_reference(path, args.width, args.height, args.reference_spp, bounces, out)
        w2, _ = wedge_reference(path, args.width, args.height, args.reference_spp, bounces, out + "-2", seed=8)
        m, ms = mitsuba_render(d, args.reference_spp, seed=1)
        m2, _ = mitsuba_render(d, args.reference_spp, seed=2)
        print(f"| {name} | {args.reference_spp} | {ws:.1f} | {ms:.1f} | {rel_mse(w, m):.2e} | {rel_mse(w, w2):.2e} "
              f"| {rel_mse(m, m2):.2e} | {w.mean() / m.mean():.4f} |")
        curve = []
        spp = 4  # ldsampler's smallest count
        while spp <= args.max_spp:
            img, secs = mitsuba_render(d, spp, seed=100 + spp)
            curve.append((spp, secs, float(np.sqrt(np.mean((img - m) ** 2)))))
            spp *= 4  # ldsampler takes square powers of two only
        curves[name] = curve
    print("\nMitsuba's own convergence (RMSE against its reference above; render time only, scene load excluded):\n")
    print("| scene | spp | seconds | RMSE |")
    print("|---|---|---|---|")
    for name, curve in curves.items():
        for spp, secs, e in curve:
            print(f"| {name} | {spp} | {secs:.3f} | {e:.5f} |")


if __name__ == "__main__":
    sys.exit(main())

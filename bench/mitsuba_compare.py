#!/usr/bin/env python3
"""Cross-checks wedge against Mitsuba 3 on the same scenes.

    pip install mitsuba numpy
    cargo build --release
    python3 bench/mitsuba_compare.py --check-bsdf       # the glossy BSDF plugin alone (~1 min)
    python3 bench/mitsuba_compare.py scenes/cornell.json scenes/curved.json scenes/grids.json
    python3 bench/mitsuba_compare.py scenes/cornell-glossy.json scenes/interior.json \
        --width 96 --height 72 --reference-spp 1024 --max-spp 256
    python3 bench/mitsuba_compare.py scenes/sky-spheres.json scenes/curved.json \
        --env-map ../shared/assets/envmaps/probulator-256x128/uffizi.hdr --env-rotation 30

For each wedge scene file (canonical protobuf JSON) this
1. converts it to a Mitsuba 3 scene (same triangles, camera, BRDFs, emitters, bounces);
2. renders a high-spp reference with wedge (`wedge render --method uniform`) and with Mitsuba,
   and reports their relative MSE and mean ratio next to each renderer's own noise (the same
   renderer with another seed). Two independent noisy images differ by the sum of their
   variances, so with nothing systematic, wedge vs Mitsuba equals the mean of the two noise
   columns. The same numbers follow per material (the one seen at each pixel's centre), with
   the mean ratio's two standard errors from the per-pixel spread of each renderer's two seeds;
3. times Mitsuba at increasing spp and reports its RMSE against the reference, next to the
   same curve for wedge's methods from `wedge bench`, for BENCHMARKS.md.

Mitsuba's sampler: `independent` for the references (`--mitsuba-sampler`), `ldsampler` for the
timing curve (`--curve-sampler`). Mitsuba 3.9.1's `ldsampler` correlates its dimensions in
scalar mode (`--check-sampler`: the x coordinates of 2-D dimensions d and d+2 correlate by about
-0.2 in every pixel), which biases its images (Cornell box at 8 bounces: 0.3% darker than its
own `independent` sampler) and makes two of its renders with different seeds share an error, so
that "Mitsuba vs Mitsuba" understates its error. Until this script used `independent`, that
showed as a wedge/Mitsuba mismatch on multi-bounce scenes (bench-results/mitsuba-gi.md).

Conventions matched:
- box pixel filter (wedge jitters uniformly inside each pixel);
- one-sided rectangular emitters whose backs are black (wedge's emitter surfaces reflect nothing);
- Mitsuba's max_depth = bounces + 2 (1 is emitters seen directly, 2 adds direct light);
- the Gaussian emission profile as a radiance texture over the rectangle;
- two-sided BSDFs (wedge shades both sides of every surface): Mitsuba's `twosided` around each;
- shapes tessellated as wedge does (src/scene/shapes.rs): quads and boxes as two triangles per
  face, spheres as the same latitude bands with smooth normals, not Mitsuba's analytic sphere;
- wedge's glossy materials (Phong and Blinn-Phong, src/render/material.rs) through the Python
  BSDF plugin `wedge_glossy` below: wedge's f, density and lobe choice, textures included.
- environment maps through Mitsuba's `envmap` with wedge's `up` and `rotation_deg` as its
  to_world (the two share the map frame and texel layout), constant environments through
  `constant`.
Only what wedge's scene format has is converted (Lambertian and glossy materials with constant
or checker textures, rect and point lights, environment maps and constants (not wedge's
procedural sky: --env-map puts a map file in its place), inline meshes and the analytic
shapes); anything else
is reported, not approximated. The Python plugin makes glossy scenes slow (the scalar variant
calls it once per shading point: about 45 s for cornell-glossy at 96x72 and 1024 spp).
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
                # As wedge: one triangle per quad in the rows touching a pole (the other has no area).
                if i > 0:
                    idx.append([a, a + 1, b])
                if i + 1 < bands:
                    idx.append([a + 1, b + 1, b])
        nrm = (np.array(p) - c) / r
        return np.array(p), np.array(idx), np.array(uv, float), nrm
    raise SystemExit(f"shape not converted: {list(shape)}")


def texture_at(t, uv):
    """A wedge texture (ColorTexture or ScalarTexture JSON) at surface coordinates uv: its
    constant, or a checker's `even` value where floor(u s) + floor(v s) is even, else `odd`."""
    if "checker" in t:
        ch = t["checker"]
        s = ch.get("scale", 0.0)
        return ch.get("even" if (math.floor(uv[0] * s) + math.floor(uv[1] * s)) % 2 == 0 else "odd", 0.0)
    return t.get("constant", 0.0)


def uses_uv(m):
    """Whether the material reads surface coordinates (some texture is a checker): wedge
    stores texture coordinates only then."""
    if "glossy" in m:
        return any("checker" in m["glossy"].get(k, {}) for k in ("diffuse", "specular", "exponent"))
    return "checker" in m.get("lambertian", {}).get("albedo", {})


# ---- wedge's glossy BRDF (src/render/material.rs) as a Mitsuba BSDF ---------------------------
#
# f = kd/pi + ks * lobe, with
#   Phong:       lobe = (m+2)/(2 pi) cos^m(alpha), alpha between wi and the mirror direction of
#                wo about the shading normal, 0 where cos(alpha) <= 0;
#   Blinn-Phong: lobe = (m+1)/(8 pi) cos^m(theta_h) / ((wo.h) max(cos_i, cos_o)),
#                h = normalize(wo + wi), 0 where n.h <= 0 or wo.h <= 0;
# and f = 0 when either direction is below the shading normal. Sampling as wedge's
# `Brdf::sample`: the glossy lobe with probability lum(ks) / (lum(kd) + lum(ks)) (Rec. 709
# luminance), else the cosine lobe; the density is that of the mixture. The glossy lobe draws a
# power-cosine direction about the mirror direction (Phong) or a power-cosine half vector that
# reflects wo (Blinn-Phong, density (m+1)/(2 pi) cos^m(theta_h) / (4 wo.h)).
#
# Mitsuba's names are the other way round from wedge's: Mitsuba's si.wi points to the viewer
# (wedge's wo) and its `wo` argument is the sampled or light direction (wedge's wi); both local,
# z = the shading normal. Mitsuba's eval() returns f * cos(theta) of that `wo`, pdf() the
# solid-angle density of sample(), and sample() the weight f * cos / pdf. The plugin is
# one-sided (front: si.wi.z > 0); the converter wraps it in `twosided` like the diffuse ones.
# Plain Python floats throughout: the scalar variant calls it once per shading point.

LUMINANCE = (0.2126, 0.7152, 0.0722)
INV_PI = 1.0 / math.pi


def glossy_lobe(phong, m, o, i):
    """wedge's `Brdf::lobe`: (lobe value without ks, density of the lobe's sampling) for local
    unit vectors o (to the viewer) and i (to the light), both above the surface."""
    if phong:
        c = -o[0] * i[0] - o[1] * i[1] + o[2] * i[2]  # reflect(o, z) . i
        if c <= 0.0:
            return 0.0, 0.0
        p = (m + 1.0) / (2.0 * math.pi) * c ** m
        return (m + 2.0) / (m + 1.0) * p, p
    hx, hy, hz = o[0] + i[0], o[1] + i[1], o[2] + i[2]
    ln = math.sqrt(hx * hx + hy * hy + hz * hz)
    if ln == 0.0:
        return 0.0, 0.0
    c = hz / ln
    oh = (o[0] * hx + o[1] * hy + o[2] * hz) / ln
    if c <= 0.0 or oh <= 0.0:
        return 0.0, 0.0
    pdf = (m + 1.0) / (2.0 * math.pi) * c ** m / (4.0 * oh)
    return pdf / max(i[2], o[2]), pdf


def _basis(n):
    """An orthonormal basis (t, b) around unit n (Duff et al. 2017, as wedge's frame_basis)."""
    sign = math.copysign(1.0, n[2])
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return (1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]), (b, sign + n[1] * n[1] * a, -n[1])


def _power_cosine(u0, u1, m, n):
    """A direction about unit n with density (m+1)/(2 pi) cos^m(theta)."""
    ct = u0 ** (1.0 / (m + 1.0))
    st = math.sqrt(max(0.0, 1.0 - ct * ct))
    phi = 2.0 * math.pi * u1
    x, y = st * math.cos(phi), st * math.sin(phi)
    t, b = _basis(n)
    return (t[0] * x + b[0] * y + n[0] * ct, t[1] * x + b[1] * y + n[1] * ct, t[2] * x + b[2] * y + n[2] * ct)


class WedgeGlossy(mi.BSDF):
    """wedge's glossy material (property `glossy`: the Glossy message as JSON)."""

    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        g = json.loads(props["glossy"])
        self.phong = g.get("model") == "GLOSSY_MODEL_PHONG"
        self.textures = (g.get("diffuse", {}), g.get("specular", {}), g.get("exponent", {}))
        self.varying = any("checker" in t for t in self.textures)
        self.fixed = None if self.varying else self.at((0.0, 0.0))
        flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
        if self.varying:
            flags = flags | mi.BSDFFlags.SpatiallyVarying
        self.m_components = [flags]
        self.m_flags = flags

    def at(self, uv):
        """(kd, ks, exponent, probability of sampling the glossy lobe) at uv."""
        kd, ks = rgb(texture_at(self.textures[0], uv) or {}), rgb(texture_at(self.textures[1], uv) or {})
        m = float(texture_at(self.textures[2], uv))
        d = sum(w * c for w, c in zip(LUMINANCE, kd))
        s = sum(w * c for w, c in zip(LUMINANCE, ks))
        return kd, ks, m, (0.0 if s <= 0.0 else s / (d + s))

    def brdf(self, si):
        return self.fixed if self.fixed is not None else self.at((si.uv[0], si.uv[1]))

    def f_cos_pdf(self, b, o, i):
        """(f * cos_i as a list, mixture density) for local o (viewer) and i (light)."""
        if o[2] <= 0.0 or i[2] <= 0.0:
            return [0.0, 0.0, 0.0], 0.0
        kd, ks, m, ps = b
        lobe, lobe_pdf = glossy_lobe(self.phong, m, o, i) if ps > 0.0 else (0.0, 0.0)
        f = [(kd[k] * INV_PI + ks[k] * lobe) * i[2] for k in range(3)]
        return f, (1.0 - ps) * i[2] * INV_PI + ps * lobe_pdf

    def eval(self, ctx, si, wo, active=True):
        f, _ = self.f_cos_pdf(self.brdf(si), (si.wi[0], si.wi[1], si.wi[2]), (wo[0], wo[1], wo[2]))
        return mi.Color3f(f)

    def pdf(self, ctx, si, wo, active=True):
        return self.f_cos_pdf(self.brdf(si), (si.wi[0], si.wi[1], si.wi[2]), (wo[0], wo[1], wo[2]))[1]

    def eval_pdf(self, ctx, si, wo, active=True):
        f, pdf = self.f_cos_pdf(self.brdf(si), (si.wi[0], si.wi[1], si.wi[2]), (wo[0], wo[1], wo[2]))
        return mi.Color3f(f), pdf

    def sample(self, ctx, si, sample1, sample2, active=True):
        bs = mi.BSDFSample3f()
        o = (si.wi[0], si.wi[1], si.wi[2])
        b = self.brdf(si)
        if o[2] <= 0.0:
            return bs, mi.Color3f(0.0)
        u0, u1 = sample2[0], sample2[1]
        if sample1 < b[3]:
            if self.phong:
                i = _power_cosine(u0, u1, b[2], (-o[0], -o[1], o[2]))
            else:
                h = _power_cosine(u0, u1, b[2], (0.0, 0.0, 1.0))
                d = 2.0 * (o[0] * h[0] + o[1] * h[1] + o[2] * h[2])
                i = (d * h[0] - o[0], d * h[1] - o[1], d * h[2] - o[2])
        else:
            r, phi = math.sqrt(u0), 2.0 * math.pi * u1
            i = (r * math.cos(phi), r * math.sin(phi), math.sqrt(max(0.0, 1.0 - u0)))
        ln = math.sqrt(i[0] * i[0] + i[1] * i[1] + i[2] * i[2])
        if ln == 0.0:
            return bs, mi.Color3f(0.0)
        i = (i[0] / ln, i[1] / ln, i[2] / ln)
        f, pdf = self.f_cos_pdf(b, o, i)
        if not (pdf > 0.0 and math.isfinite(pdf)):
            return bs, mi.Color3f(0.0)
        bs.wo = mi.Vector3f(i)
        bs.pdf = pdf
        bs.eta = 1.0
        bs.sampled_type = int(mi.BSDFFlags.GlossyReflection if sample1 < b[3] else mi.BSDFFlags.DiffuseReflection)
        bs.sampled_component = 0
        return bs, mi.Color3f([c / pdf for c in f])

    def traverse(self, callback):
        pass

    def parameters_changed(self, keys):
        pass

    def to_string(self):
        return f"WedgeGlossy[{'phong' if self.phong else 'blinn-phong'}, {self.textures}]"


mi.register_bsdf("wedge_glossy", lambda props: WedgeGlossy(props))


def material(m):
    """The Mitsuba BSDF of a wedge material, one-sided (the caller wraps it in `twosided`)."""
    if "glossy" in m:
        return {"type": "wedge_glossy", "glossy": json.dumps(m["glossy"])}
    a = m.get("lambertian", {}).get("albedo")
    if a is None:
        raise SystemExit(f"material {m.get('name')}: only lambertian and glossy are converted")
    if "constant" in a:
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb(a["constant"])}}
    ch = a["checker"]
    # wedge: even where floor(u s) + floor(v s) is even. Mitsuba's checkerboard over [0,1]^2 is
    # color0 where the cell sum is even, on a 2 x 2 board: scale uv by s/2.
    return {"type": "diffuse", "reflectance": {"type": "checkerboard", "color0": {"type": "rgb", "value": rgb(ch["even"])},
                                               "color1": {"type": "rgb", "value": rgb(ch["odd"])},
                                               "to_uv": T.scale([ch["scale"] / 2, ch["scale"] / 2, 1])}}


def environment(e, base_dir):
    """wedge's environment light (src/render/environment.rs) as Mitsuba's `envmap` or
    `constant` emitter. wedge's map frame is Mitsuba's (zenith +Y, u = 0 towards -Z, u = 1/4
    towards +X); wedge turns world directions into it by `up` -> +Y, then -rotation_deg about
    +Y, so Mitsuba's to_world is the inverse of that."""
    scale = e.get("scale") or 1.0
    if "constant" in e:
        return {"type": "constant", "radiance": {"type": "rgb", "value": [c * scale for c in rgb(e["constant"])]}}
    if "sky" in e:
        raise SystemExit("the procedural sky is wedge's own: give the scene a map file (--env-map) to compare")
    up = vec(e.get("up"), (0, 1, 0)) if e.get("up") else np.array([0.0, 1.0, 0.0])
    up = up / np.linalg.norm(up)
    y = np.array([0.0, 1.0, 0.0])
    axis, c = np.cross(up, y), float(up @ y)
    if np.linalg.norm(axis) < 1e-9:
        align = np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    else:
        k = axis / np.linalg.norm(axis)
        kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        s = np.linalg.norm(axis)
        align = np.eye(3) + s * kx + (1 - c) * kx @ kx
    r = math.radians(e.get("rotationDeg", 0.0))
    turn_back = np.array([[math.cos(r), 0, math.sin(r)], [0, 1, 0], [-math.sin(r), 0, math.cos(r)]])
    m = np.eye(4)
    m[:3, :3] = align.T @ turn_back
    out = {"type": "envmap", "scale": scale, "to_world": T(m.tolist())}
    if "path" in e:
        out["filename"] = os.path.join(base_dir, e["path"])
    else:
        mp = e["map"]
        img = np.array(mp["rgb"], dtype=np.float32).reshape(mp["height"], mp["width"], 3)
        out["bitmap"] = mi.Bitmap(img)
    return out


def to_mitsuba(scene, width, height, spp, bounces, base_dir="."):
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
    for name, m in mats.items():
        # wedge shades both sides of every surface; Mitsuba's BSDFs are one-sided.
        d[f"material-{name}"] = {"type": "twosided", "id": f"material-{name}", "bsdf": material(m)}
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
        d[f"shape{k}"] = {"type": "ply", "filename": write_ply(pw, idx, uv if uses_uv(mats[mat_name]) else None, nw),
                          "bsdf": {"type": "ref", "id": f"material-{mat_name}"}, "face_normals": nw is None}
    for k, l in enumerate(scene.get("lights", [])):
        if "environment" in l:
            d[f"light{k}"] = environment(l["environment"], base_dir)
            continue
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
            # exp(-|y - c|^2 / (2 sigma^2)) over the rectangle's uv, sigma the scene's
            # `gaussianSigma` (scene units) or, when absent or 0, sqrt(area)/2.
            res = 256
            s = np.linspace(-1 + 1 / res, 1 - 1 / res, res)
            xx, yy = np.meshgrid(s, s)
            given = float(r.get("gaussianSigma", 0.0) or 0.0)
            sigma2 = given * given if given > 0 else np.linalg.norm(n) / 4
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
           "--max-spp", str(spp), "--bounces", str(bounces), "--seed", str(seed), "--out", out, "--reproducible",
           "--mesh-root", "/"]
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    secs = time.perf_counter() - t
    return read_wedge_exr(os.path.join(out, "final.exr")), secs


def read_wedge_exr(path):
    """The colour (channels R, G, B) of a wedge EXR as an H x W x 3 float64 array."""
    layers = dict(mi.Bitmap(path).split())
    key = next(k for k in layers if k in ("<root>", "", "R,G,B") or k.endswith("RGB"))
    return np.array(layers[key], dtype=np.float64)[:, :, :3]


def mitsuba_render(scene_dict, spp, seed=0, sampler="independent"):
    """Mitsuba's image at spp samples per pixel. `independent` (PCG32 per pixel) for the
    references: Mitsuba 3.9.1's `ldsampler` correlates its dimensions (the x coordinates of 2-D
    dimensions d and d+2 correlate by about -0.2 in every pixel, `--check-sampler`), which biases
    its images and gives renders with different seeds a shared error, so that "Mitsuba vs
    Mitsuba" understates its error. `ldsampler` (stratified like wedge's sampler) only for the
    timing curve."""
    scene_dict = dict(scene_dict)
    scene_dict["sensor"] = dict(scene_dict["sensor"])
    scene_dict["sensor"]["sampler"] = {"type": sampler, "sample_count": spp}
    scene = mi.load_dict(scene_dict)
    t = time.perf_counter()
    img = np.array(mi.render(scene, seed=seed), dtype=np.float64)
    return img, time.perf_counter() - t


def rel_mse(a, b):
    return float(np.mean((a - b) ** 2 / (b ** 2 + 0.01)))


def material_ids(scene, d):
    """The material name (or "light" / "background") seen through each pixel's centre, by
    Mitsuba's camera and ray casting on the converted scene."""
    sc = mi.load_dict(d)
    sensor = sc.sensors()[0]
    width, height = sensor.film().crop_size()
    out = np.empty((height, width), dtype=object)
    for y in range(height):
        for x in range(width):
            ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((x + 0.5) / width, (y + 0.5) / height), mi.Point2f(0.5, 0.5))
            si = sc.ray_intersect(ray)
            bsdf_id = si.bsdf().id() if si.is_valid() else ""
            out[y, x] = bsdf_id[len("material-"):] if bsdf_id.startswith("material-") else "light" if si.is_valid() else "background"
    return out


def by_material(scene, d, wedge, mitsuba):
    """Table rows comparing the two renderers over the pixels of each material."""
    ids = material_ids(scene, d)
    (w, w2), (m, m2) = wedge, mitsuba
    rows = []
    for mat in sorted(set(ids.ravel())):
        sel = ids == mat
        a, a2, b, b2 = w[sel], w2[sel], m[sel], m2[sel]
        # The sums of the two-seed means and their variances, (x1 - x2)^2 / 4 per value.
        sw, sm = (a + a2).sum() / 2, (b + b2).sum() / 2
        vw, vm = ((a - a2) ** 2).sum() / 4, ((b - b2) ** 2).sum() / 4
        if sw > 0 and sm > 0:
            r = sw / sm
            ratio = f"{r:.4f} ± {2 * r * math.sqrt(vw / sw ** 2 + vm / sm ** 2):.4f}"
        else:
            ratio = "black"
        rows.append([mat, str(int(sel.sum())), f"{rel_mse(a, b):.2e}", f"{rel_mse(a, a2):.2e}", f"{rel_mse(b, b2):.2e}", ratio])
    return rows


def reference_glossy(kd, ks, m, phong, wo, wi):
    """An independent numpy transcription of wedge's glossy f and sampling density, straight
    from the formulas (not the plugin's code): wo (1 x 3, to the viewer) and wi (N x 3, to the
    light) local to n = +z. Returns (f as N x 3, mixture pdf as N)."""
    wo = np.asarray(wo, float)[None, :]
    cos_o, cos_i = wo[:, 2], wi[:, 2]
    above = (cos_i > 0) & (cos_o > 0)
    if phong:
        r = np.array([-wo[0, 0], -wo[0, 1], wo[0, 2]])
        ca = wi @ r
        ok = above & (ca > 0)
        cam = np.where(ok, np.maximum(ca, 0) ** m, 0.0)
        lobe = (m + 2) / (2 * np.pi) * cam
        lobe_pdf = (m + 1) / (2 * np.pi) * cam
    else:
        h = wi + wo
        h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-300)
        ch, oh = h[:, 2], h @ wo[0]
        ok = above & (ch > 0) & (oh > 0)
        chm = np.where(ok, np.maximum(ch, 0) ** m, 0.0)
        safe_oh = np.where(ok, oh, 1.0)
        lobe = (m + 1) / (8 * np.pi) * chm / (safe_oh * np.maximum(cos_i, cos_o))
        lobe_pdf = (m + 1) / (2 * np.pi) * chm / (4 * safe_oh)
    lum = np.array(LUMINANCE)
    ps = float(lum @ ks) / float(lum @ kd + lum @ ks)
    f = np.where(above[:, None], np.asarray(kd)[None, :] / np.pi + np.asarray(ks)[None, :] * lobe[:, None], 0.0)
    pdf = np.where(above, (1 - ps) * np.maximum(cos_i, 0) / np.pi + ps * lobe_pdf, 0.0)
    return f, pdf


def hemisphere_grid(n):
    """Midpoints of an n x 2n grid in (cos theta, phi) over the upper hemisphere, each cell of
    solid angle 2 pi / (2 n^2)."""
    c = (np.arange(n) + 0.5) / n
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    cc, pp = np.meshgrid(c, phi, indexing="ij")
    s = np.sqrt(1 - cc ** 2)
    return np.stack([s * np.cos(pp), s * np.sin(pp), cc], axis=-1).reshape(-1, 3), 2 * np.pi / (2 * n * n)


def check_bsdf(samples=40000, seed=3):
    """The plugin in isolation, through Mitsuba's API and the `twosided` wrapper, against the
    numpy transcription above:
    - eval() = f cos_i and pdf() at 400 random direction pairs, front and back side;
    - the mean of sample()'s weights (f cos / pdf) = the directional albedo, a quadrature of
      f cos (a white-furnace test: a surface under uniform unit radiance reflects its albedo);
    - the fraction of samples above the surface = the quadrature of pdf() (the density's mass);
    - the sampled directions' histogram (8 cos-theta x 16 phi bins) against the quadrature of
      the density in each bin (chi-square per degree of freedom, ~1 when they agree);
    - a rendered point-lit plane (front and back) = f cos_i I / r^2 at the pixel.
    Returns False on any failure."""
    rng = np.random.default_rng(seed)
    ctx = mi.BSDFContext()
    kd, ks = [0.3, 0.2, 0.1], [0.5, 0.6, 0.4]
    grid, dw = hemisphere_grid(1500)
    ok_all = True
    print("| model | m | theta_o | side | albedo (quadrature, R) | albedo (sampled, R) | 4 sigma | max rel. err eval, pdf | mass (quadrature / sampled) | chi2/dof |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for phong in (False, True):
        for m in (1.0, 12.0, 20.0):
            g = {"diffuse": {"constant": dict(zip("rgb", kd))}, "specular": {"constant": dict(zip("rgb", ks))},
                 "exponent": {"constant": m}, "model": "GLOSSY_MODEL_PHONG" if phong else "GLOSSY_MODEL_BLINN_PHONG"}
            bsdf = mi.load_dict({"type": "twosided", "bsdf": {"type": "wedge_glossy", "glossy": json.dumps(g)}})
            for theta, side in ((10, 1), (45, 1), (75, 1), (45, -1)):
                t = math.radians(theta)
                wo = np.array([math.sin(t) * 0.8, math.sin(t) * 0.6, math.cos(t)])
                si = mi.SurfaceInteraction3f()
                si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
                si.wi = mi.Vector3f(wo[0], wo[1], side * wo[2])
                # Pointwise eval and pdf over random directions of both hemispheres.
                d = rng.normal(size=(400, 3))
                d /= np.linalg.norm(d, axis=1, keepdims=True)
                fr, pr = reference_glossy(kd, ks, m, phong, wo, d * np.array([1, 1, side]))
                fr = fr * np.maximum(side * d[:, 2:3], 0)
                ev = np.array([list(bsdf.eval(ctx, si, mi.Vector3f(*x))) for x in d])
                pd = np.array([bsdf.pdf(ctx, si, mi.Vector3f(*x)) for x in d])
                err = max(float(np.max(np.abs(ev - fr) / (np.abs(fr) + 1e-3))), float(np.max(np.abs(pd - pr) / (pr + 1e-3))))
                # Quadratures.
                f, p = reference_glossy(kd, ks, m, phong, wo, grid)
                albedo = (f * grid[:, 2:3]).sum(axis=0) * dw
                mass = p.sum() * dw
                # Sampling.
                u = rng.random((samples, 3))
                w = np.zeros((samples, 3))
                dirs = np.zeros((samples, 3))
                for k in range(samples):
                    bs, wt = bsdf.sample(ctx, si, float(u[k, 0]), mi.Point2f(float(u[k, 1]), float(u[k, 2])))
                    w[k] = list(wt)
                    dirs[k] = [bs.wo[0], bs.wo[1], side * bs.wo[2]]
                valid = (w.sum(axis=1) > 0) & (dirs[:, 2] > 0)
                sampled = w.mean(axis=0)
                sigma = w.std(axis=0) / math.sqrt(samples)
                # Histogram in (cos theta, phi) against the density's mass per bin.
                nb_c, nb_p = 8, 16
                ci = np.minimum((dirs[valid, 2] * nb_c).astype(int), nb_c - 1)
                pj = np.minimum(((np.arctan2(dirs[valid, 1], dirs[valid, 0]) % (2 * np.pi)) / (2 * np.pi) * nb_p).astype(int), nb_p - 1)
                obs = np.bincount(ci * nb_p + pj, minlength=nb_c * nb_p).astype(float)
                gi = np.minimum((grid[:, 2] * nb_c).astype(int), nb_c - 1)
                gj = np.minimum(((np.arctan2(grid[:, 1], grid[:, 0]) % (2 * np.pi)) / (2 * np.pi) * nb_p).astype(int), nb_p - 1)
                exp = np.bincount(gi * nb_p + gj, weights=p * dw, minlength=nb_c * nb_p) * samples
                keep = exp >= 5
                chi2 = float((((obs - exp) ** 2 / np.where(keep, exp, 1))[keep]).sum()) / max(1, keep.sum() - 1)
                good = (np.all(np.abs(sampled - albedo) < 4 * sigma + 2e-3) and err < 1e-4
                        and abs(mass - valid.mean()) < 4 * math.sqrt(mass * (1 - mass) / samples) + 2e-3 and chi2 < 2.0)
                ok_all &= bool(good)
                print(f"| {'Phong' if phong else 'Blinn-Phong'} | {m:g} | {theta} | {'front' if side > 0 else 'back'} "
                      f"| {albedo[0]:.4f} | {sampled[0]:.4f} | {4 * sigma[0]:.4f} | {err:.1e} | {mass:.4f} / {valid.mean():.4f} "
                      f"| {chi2:.2f} |{'' if good else ' **FAIL**'}")
    ok_all &= check_rendered_plane()
    return ok_all


def check_rendered_plane():
    """A glossy plane z = 0 under a point light, seen through a very narrow camera from another
    angle, rendered by Mitsuba's path integrator (direct light only): the pixel is
    f(wo, wi) cos_i I / r^2. From above and, mirrored, from below (the `twosided` wrapper)."""
    kd, ks, intensity = [0.2, 0.3, 0.1], [0.6, 0.5, 0.7], 5.0
    ok = True
    for phong in (False, True):
        g = {"diffuse": {"constant": dict(zip("rgb", kd))}, "specular": {"constant": dict(zip("rgb", ks))},
             "exponent": {"constant": 12}, "model": "GLOSSY_MODEL_PHONG" if phong else "GLOSSY_MODEL_BLINN_PHONG"}
        for side in (1, -1):
            cam, light = np.array([-1.0, 0.2, 1.5 * side]), np.array([0.7, -0.1, 0.8 * side])
            scene = mi.load_dict({
                "type": "scene", "integrator": {"type": "path", "max_depth": 2},
                "sensor": {"type": "perspective", "fov": 0.01, "to_world": T.look_at(origin=cam.tolist(), target=[0, 0, 0], up=[0, 0, 1]),
                           "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                           "sampler": {"type": "independent", "sample_count": 16}},
                "plane": {"type": "rectangle", "to_world": T.scale([5, 5, 1]),
                          "bsdf": {"type": "twosided", "bsdf": {"type": "wedge_glossy", "glossy": json.dumps(g)}}},
                "light": {"type": "point", "position": light.tolist(), "intensity": {"type": "rgb", "value": [intensity] * 3}}})
            got = np.array(mi.render(scene), dtype=np.float64)[0, 0, :3]
            wo = cam / np.linalg.norm(cam) * np.array([1, 1, side])
            wi = light / np.linalg.norm(light) * np.array([1, 1, side])
            f, _ = reference_glossy(kd, ks, 12.0, phong, wo, wi[None, :])
            want = f[0] * wi[2] * intensity / float(light @ light)
            good = bool(np.all(np.abs(got - want) < 1e-3 * want))
            ok &= good
            print(f"rendered plane, {'Phong' if phong else 'Blinn-Phong'}, {'front' if side > 0 else 'back'}: "
                  f"Mitsuba {np.round(got, 5).tolist()}, f cos I / r^2 {np.round(want, 5).tolist()}{'' if good else ' **FAIL**'}")
    return ok


def check_sampler(spp=1024, pixels=40, dims=10):
    """Correlation between the x coordinates of a Mitsuba sampler's 2-D dimensions within a
    pixel's spp samples, as the path tracer draws them (every dimension a next_2d here), over
    `pixels` pixel seeds: the mean (systematic: the same sign in every pixel, with its z score)
    and the mean magnitude, next to the ~0.8/sqrt(spp) of independent points."""
    for kind in ("ldsampler", "independent"):
        s = mi.load_dict({"type": kind, "sample_count": spp})
        x = np.zeros((pixels, spp, dims))
        for p in range(pixels):
            s.seed(5000 + 7919 * p)
            for j in range(spp):
                for k in range(dims):
                    x[p, j, k] = s.next_2d()[0]
                s.advance()
        c = np.einsum("pni,pnj->pij", x - 0.5, x - 0.5) / spp * 12
        mean, se, mag = c.mean(0), c.std(0) / math.sqrt(pixels), np.abs(c).mean(0)
        print(f"{kind}, {spp} spp, {pixels} pixels (independent points: mean |corr| {math.sqrt(2 / math.pi / spp):.3f})")
        print("| dimensions | mean corr (z) | mean abs corr |")
        print("|---|---|---|")
        for lag in (1, 2, 3, 4):
            for k in range(dims - lag):
                z = mean[k, k + lag] / se[k, k + lag]
                if lag == 2 or abs(z) > 5:
                    print(f"| {k}, {k + lag} | {mean[k, k + lag]:+.3f} ({z:+.1f}) | {mag[k, k + lag]:.3f} |")
        print()
    return 0


def with_env_map(scene, name, args):
    """`scene` lit by the map file of --env-map (replacing its environment light, if any),
    written out as a scene file; returns the scene and the file."""
    env = {"environment": {"path": os.path.abspath(args.env_map), "rotationDeg": args.env_rotation,
                           "scale": args.env_scale}}
    lights = [l for l in scene.get("lights", []) if "environment" not in l]
    scene = dict(scene, lights=lights + [env])
    path = os.path.join(_tmp, f"{name}-env.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    return scene, path


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--check-bsdf", action="store_true", help="verify the glossy BSDF plugin in isolation, then exit")
    ap.add_argument("--check-sampler", action="store_true",
                    help="measure the correlation between the dimensions of Mitsuba's samplers, then exit")
    ap.add_argument("--mitsuba-sampler", default="independent", help="Mitsuba sampler of the reference renders")
    ap.add_argument("--curve-sampler", default="ldsampler", help="Mitsuba sampler of the timing curve")
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--max-spp", type=int, default=256)
    ap.add_argument("--bounces", type=int, help="override the scenes' indirect bounces")
    ap.add_argument("--save", help="directory to keep the four reference images in (.npy)")
    ap.add_argument("--env-map", help="light every scene by this map file (.exr or .hdr): it replaces the scene's "
                                      "environment light, or joins its other lights")
    ap.add_argument("--env-rotation", type=float, default=0.0, help="with --env-map: its rotation_deg")
    ap.add_argument("--env-scale", type=float, default=1.0, help="with --env-map: its scale")
    args = ap.parse_args()
    if args.check_bsdf:
        return 0 if check_bsdf() else 1
    if args.check_sampler:
        return check_sampler()
    print(f"Mitsuba {mi.__version__} ({mi.variant()}), wedge {WEDGE}; Mitsuba references: {args.mitsuba_sampler}, "
          f"curve: {args.curve_sampler}\n")
    print("| scene | spp | wedge s | Mitsuba s | relative MSE wedge vs Mitsuba | noise: wedge vs wedge | noise: Mitsuba vs Mitsuba | mean ratio wedge/Mitsuba |")
    print("|---|---|---|---|---|---|---|---|")
    curves, groups = {}, {}
    for path in args.scenes:
        scene = json.load(open(path))
        name = os.path.splitext(os.path.basename(path))[0]
        if args.env_map:
            scene, path = with_env_map(scene, name, args)
            name += "+" + os.path.splitext(os.path.basename(args.env_map))[0]
        bounces = args.bounces if args.bounces is not None else scene.get("settings", {}).get("bounces", 0)
        d = to_mitsuba(scene, args.width, args.height, args.reference_spp, bounces, os.path.dirname(os.path.abspath(path)))
        out = os.path.join(_tmp, name)
        w, ws = wedge_reference(path, args.width, args.height, args.reference_spp, bounces, out)
        w2, _ = wedge_reference(path, args.width, args.height, args.reference_spp, bounces, out + "-2", seed=8)
        # Scalar Mitsuba seeds pixel i of a render with seed s as s * width * height + i (plus
        # block padding): seeds 1 and 3 never share a pixel stream.
        m, ms = mitsuba_render(d, args.reference_spp, seed=1, sampler=args.mitsuba_sampler)
        m2, _ = mitsuba_render(d, args.reference_spp, seed=3, sampler=args.mitsuba_sampler)
        print(f"| {name} | {args.reference_spp} | {ws:.1f} | {ms:.1f} | {rel_mse(w, m):.2e} | {rel_mse(w, w2):.2e} "
              f"| {rel_mse(m, m2):.2e} | {w.mean() / m.mean():.4f} |", flush=True)
        if args.save:
            os.makedirs(args.save, exist_ok=True)
            for key, img in (("wedge-7", w), ("wedge-8", w2), ("mitsuba-1", m), ("mitsuba-3", m2)):
                np.save(os.path.join(args.save, f"{name}-{key}.npy"), img)
        groups[name] = by_material(scene, d, (w, w2), (m, m2))
        curve = []
        spp = 4  # ldsampler's smallest count
        while spp <= args.max_spp:
            img, secs = mitsuba_render(d, spp, seed=100 + 2 * spp, sampler=args.curve_sampler)
            curve.append((spp, secs, float(np.sqrt(np.mean((img - m) ** 2)))))
            spp *= 4  # ldsampler takes square powers of two only
        curves[name] = curve
    print("\nBy the material seen at each pixel's centre (relative MSE as above; mean ratio of the two seeds' mean "
          "images, with two standard errors from the per-pixel spread between the seeds):\n")
    print("| scene | material | pixels | relative MSE wedge vs Mitsuba | noise: wedge vs wedge | noise: Mitsuba vs Mitsuba | mean ratio wedge/Mitsuba |")
    print("|---|---|---|---|---|---|---|")
    for name, rows in groups.items():
        for row in rows:
            print(f"| {name} | " + " | ".join(row) + " |")
    print(f"\nMitsuba's convergence with {args.curve_sampler} (RMSE against its {args.mitsuba_sampler} reference above; "
          "render time only, scene load excluded):\n")
    print("| scene | spp | seconds | RMSE |")
    print("|---|---|---|---|")
    for name, curve in curves.items():
        for spp, secs, e in curve:
            print(f"| {name} | {spp} | {secs:.3f} | {e:.5f} |")


if __name__ == "__main__":
    sys.exit(main())

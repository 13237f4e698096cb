#!/usr/bin/env python3
"""Writes the built-in scenes (cornell.json, grids.json, curved.json) as canonical protobuf JSON
of wedge.v1.Scene. Run from anywhere: `python3 scenes/generate.py`. The JSON files are
committed and compiled into the binary; this script is how they were made."""
import json
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def v(x, y, z):
    return {"x": round(x, 5), "y": round(y, 5), "z": round(z, 5)}


def rgb(r, g, b):
    return {"r": r, "g": g, "b": b}


def lambert(name, c):
    return {"name": name, "lambertian": {"albedo": {"constant": rgb(*c)}}}


def polygon_mesh(name, material, polys):
    """Inline mesh of planar convex polygons (fan-triangulated), flat shaded."""
    pos, idx = [], []
    for poly in polys:
        base = len(pos) // 3
        for p in poly:
            pos += [round(c, 4) for c in p]
        for k in range(1, len(poly) - 1):
            idx += [base, base + k, base + k + 1]
    return {"name": name, "material": material, "mesh": {"positions": pos, "indices": idx}}


def cornell():
    # Cornell Program of Computer Graphics, "Cornell Box Data" (mm); reflectances and light as
    # RGB from Mitsuba 3's cbox-rgb scene. The light sits 0.5 mm below the ceiling.
    floor = [(552.8, 0, 0), (0, 0, 0), (0, 0, 559.2), (549.6, 0, 559.2)]
    ceiling = [(556, 548.8, 0), (556, 548.8, 559.2), (0, 548.8, 559.2), (0, 548.8, 0)]
    back = [(549.6, 0, 559.2), (0, 0, 559.2), (0, 548.8, 559.2), (556, 548.8, 559.2)]
    green = [(0, 0, 559.2), (0, 0, 0), (0, 548.8, 0), (0, 548.8, 559.2)]
    red = [(552.8, 0, 0), (549.6, 0, 559.2), (556, 548.8, 559.2), (556, 548.8, 0)]

    def block(top, h):
        sides = [[top[i], top[(i + 1) % 4], (top[(i + 1) % 4][0], 0, top[(i + 1) % 4][2]),
                  (top[i][0], 0, top[i][2])] for i in range(4)]
        return [[(x, h, z) for (x, _, z) in top]] + [[(p[0], p[1], p[2]) for p in s] for s in sides]

    short = block([(130, 165, 65), (82, 165, 225), (240, 165, 272), (290, 165, 114)], 165)
    tall = block([(423, 330, 247), (265, 330, 296), (314, 330, 456), (472, 330, 406)], 330)
    return {
        "description": "Cornell box: the published dimensions (mm), one area light, diffuse walls",
        "camera": {"position": v(278, 273, -800), "lookAt": v(278, 273, 0), "up": v(0, 1, 0),
                   "verticalFovDeg": 39.3077, "width": 256, "height": 256},
        "materials": [lambert("white", (0.885809, 0.698859, 0.666422)),
                      lambert("red", (0.570068, 0.0430135, 0.0443706)),
                      lambert("green", (0.105421, 0.37798, 0.076425))],
        "shapes": [polygon_mesh("floor", "white", [floor]),
                   polygon_mesh("ceiling", "white", [ceiling]),
                   polygon_mesh("back", "white", [back]),
                   polygon_mesh("green_wall", "green", [green]),
                   polygon_mesh("red_wall", "red", [red]),
                   polygon_mesh("short_block", "white", short),
                   polygon_mesh("tall_block", "white", tall)],
        "lights": [{"rect": {"corner": v(343, 548.3, 227), "edgeU": v(0, 0, 105), "edgeV": v(-130, 0, 0),
                             "radiance": rgb(18.387, 10.9873, 2.75357)}}],
        "settings": {"method": "METHOD_UNIFORM", "maxPasses": 8, "bounces": 3},
    }


def grids():
    # Stacked grids of thin bars over a ground plane under a square Gaussian light: occluders at
    # several heights give shadows from sharp to very soft (Mehta et al. 2012, Fig. 6).
    shapes = [{"name": "ground", "material": "ground",
               "quad": {"corner": v(-12, 0, -12), "edgeU": v(0, 0, 24), "edgeV": v(24, 0, 0)}},
              {"name": "bar", "material": "bars", "box": {"min": v(-0.5, -0.5, -0.5), "max": v(0.5, 0.5, 0.5)}}]
    levels = [(0.35, 0.06, 0.45, 9), (1.1, 0.08, 0.7, 7), (2.2, 0.1, 1.0, 5)]
    for height, thick, spacing, count in levels:
        span = spacing * (count - 1) + 2 * spacing
        for i in range(count):
            off = (i - (count - 1) / 2) * spacing
            # Bars along z at this level, then bars along x slightly above them.
            shapes.append({"material": "bars", "instance": {"shape": "bar"},
                           "transform": {"translate": v(off, height, 0), "scale": v(thick, thick, span)}})
            shapes.append({"material": "bars", "instance": {"shape": "bar"},
                           "transform": {"translate": v(0, height + thick, off), "scale": v(span, thick, thick)}})
    # The first bar is the prototype the others instance: it takes the first placement.
    first = shapes.pop(2)
    shapes[1]["transform"] = first["transform"]
    return {
        "description": "stacked grids of thin bars over a plane, square Gaussian area light (AAF 2012 Fig. 6)",
        "camera": {"position": v(0, 6.0, 6.5), "lookAt": v(0, 0.2, 0.4), "up": v(0, 1, 0),
                   "verticalFovDeg": 50, "width": 320, "height": 240},
        "materials": [lambert("ground", (0.8, 0.8, 0.8)), lambert("bars", (0.6, 0.45, 0.3))],
        "shapes": shapes,
        "lights": [{"rect": {"corner": v(-1, 6, -1), "edgeU": v(2, 0, 0), "edgeV": v(0, 0, 2),
                             "radiance": rgb(40, 40, 40), "profile": "EMISSION_PROFILE_GAUSSIAN"}}],
        "settings": {"method": "METHOD_UNIFORM", "maxPasses": 8, "bounces": 0},
    }


def curved():
    # A curved occluder (a half torus) over a curved receiver (a concave trough): shadow
    # softness varies continuously along both (Mehta et al. 2012, Fig. 8).
    def trough(radius, length, nu, nv):
        pos, idx = [], []
        for i in range(nu + 1):
            a = math.pi * (1.1 + 0.8 * i / nu)  # an arc below the axis
            for j in range(nv + 1):
                z = -length / 2 + length * j / nv
                pos += [radius * math.cos(a), radius * math.sin(a) + radius, z]
        for i in range(nu):
            for j in range(nv):
                a, b = i * (nv + 1) + j, (i + 1) * (nv + 1) + j
                idx += [a, b, a + 1, a + 1, b, b + 1]
        return pos, idx

    def half_torus(R, r, nu, nv):
        pos, nrm, idx = [], [], []
        for i in range(nu + 1):
            u = math.pi * i / nu
            cu, su = math.cos(u), math.sin(u)
            for j in range(nv + 1):
                w = 2 * math.pi * j / nv
                n = (math.cos(w) * cu, math.sin(w), math.cos(w) * su)
                pos += [(R + r * math.cos(w)) * cu, r * math.sin(w), (R + r * math.cos(w)) * su]
                nrm += list(n)
        for i in range(nu):
            for j in range(nv):
                a, b = i * (nv + 1) + j, (i + 1) * (nv + 1) + j
                idx += [a, a + 1, b, a + 1, b + 1, b]
        return pos, nrm, idx

    tp, ti = trough(4.0, 14.0, 48, 24)
    hp, hn, hi = half_torus(1.6, 0.18, 48, 12)
    r4 = lambda xs: [round(x, 4) for x in xs]
    return {
        "description": "a curved occluder over a curved receiver under a square area light (AAF 2012 Fig. 8)",
        "camera": {"position": v(0, 4.2, 6.0), "lookAt": v(0, 0.3, 0), "up": v(0, 1, 0),
                   "verticalFovDeg": 45, "width": 320, "height": 240},
        "materials": [lambert("receiver", (0.75, 0.75, 0.7)), lambert("occluder", (0.3, 0.5, 0.8))],
        "shapes": [{"name": "trough", "material": "receiver", "mesh": {"positions": r4(tp), "indices": ti}},
                   {"name": "arch", "material": "occluder",
                    "mesh": {"positions": r4(hp), "normals": r4(hn), "indices": hi},
                    "transform": {"translate": v(0, 1.3, -0.2), "rotateAxis": v(1, 0, 0), "rotateDeg": -50}}],
        "lights": [{"rect": {"corner": v(-0.75, 5, -0.75), "edgeU": v(1.5, 0, 0), "edgeV": v(0, 0, 1.5),
                             "radiance": rgb(20, 20, 20)}}],
        "settings": {"method": "METHOD_UNIFORM", "maxPasses": 8, "bounces": 0},
    }


if __name__ == "__main__":
    for name, make in [("cornell", cornell), ("grids", grids), ("curved", curved)]:
        with open(os.path.join(HERE, name + ".json"), "w") as f:
            json.dump(make(), f, separators=(",", ":") if name == "curved" else (",", ": "),
                      indent=None if name == "curved" else 1)
            f.write("\n")

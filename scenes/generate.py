#!/usr/bin/env python3
"""Writes the built-in scenes (cornell, grids, curved, cornell-glossy, cornell-polished, interior, glossy-plates, sky-spheres) as canonical protobuf JSON
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
        "settings": {"bounces": 3},
    }


def glossy(name, kd, ks, m, model="GLOSSY_MODEL_BLINN_PHONG"):
    return {"name": name, "glossy": {"diffuse": {"constant": rgb(*kd)}, "specular": {"constant": rgb(*ks)},
                                     "exponent": {"constant": m}, "model": model}}


def box(name, material, lo, hi):
    return {"name": name, "material": material, "box": {"min": v(*lo), "max": v(*hi)}}


def cornell_glossy():
    # The Cornell box of `cornell` with glossy objects, lit by a point light below the ceiling
    # as in the AAF indirect paper (Mehta et al. 2013, Fig. 8: glossy objects with Blinn-Phong
    # exponent 12, 2 bounces; all its examples use one point light).
    base = cornell()
    walls = [s for s in base["shapes"] if not s["name"].endswith("_block")]
    short = [s for s in base["shapes"] if s["name"] == "short_block"]
    return {
        "description": "Cornell box with glossy Blinn-Phong objects (m = 12-20) under a point light (AAF 2013 Fig. 8)",
        "camera": base["camera"],
        "materials": base["materials"] + [
            glossy("blue_gloss", (0.15, 0.2, 0.45), (0.45, 0.45, 0.45), 12),
            glossy("gold_gloss", (0.35, 0.25, 0.08), (0.5, 0.42, 0.2), 20),
            glossy("white_phong", (0.45, 0.45, 0.45), (0.3, 0.3, 0.3), 16, "GLOSSY_MODEL_PHONG")],
        "shapes": walls + [dict(short[0], material="white_phong"),
                           {"name": "ball", "material": "blue_gloss",
                            "sphere": {"center": v(370, 110, 330), "radius": 110, "subdivisions": 48}},
                           {"name": "pillar", "material": "gold_gloss",
                            "box": {"min": v(120, 165, 120), "max": v(220, 345, 220)}}],
        "lights": [{"point": {"position": v(278, 500, 279.6), "intensity": rgb(190000, 150000, 110000)}}],
        "settings": {"bounces": 2},
    }


def cornell_polished():
    # `cornell-glossy` with high-frequency lobes: a polished floor (Blinn-Phong m = 3000), a
    # near-mirror ball (Phong m = 5000) and a glossy pillar (m = 800) reflecting the lit room,
    # the setting of Tokuyoshi 2015's Fig. 14(b), where normal-aware weights blur reflections
    # that lobe-aware weights keep. The reflections of the point light itself are direct light,
    # which neither weight filters; the benches leave those pixels out (`--exclude-above 1`).
    base = cornell_glossy()
    materials = [m for m in base["materials"] if "glossy" not in m] + [
        glossy("floor_polished", (0.25, 0.22, 0.2), (0.55, 0.55, 0.55), 3000),
        glossy("blue_mirror", (0.05, 0.07, 0.15), (0.7, 0.7, 0.7), 5000, "GLOSSY_MODEL_PHONG"),
        glossy("gold_gloss", (0.3, 0.22, 0.07), (0.55, 0.45, 0.22), 800),
        glossy("white_phong", (0.45, 0.45, 0.45), (0.3, 0.3, 0.3), 16, "GLOSSY_MODEL_PHONG")]
    polished = {"floor": "floor_polished", "ball": "blue_mirror"}
    shapes = [dict(s, material=polished.get(s["name"], s["material"])) for s in base["shapes"]]
    return dict(base, materials=materials, shapes=shapes, settings={"bounces": 1},
                description="Cornell box with a polished floor, ball and pillar (Blinn-Phong and Phong m = 800-5000) "
                            "under a point light (Tokuyoshi 2015 Fig. 14(b): high-frequency lobes)")


def interior():
    # A meeting room with reflectors at many distances (like the AAF indirect paper's conference
    # room, Fig. 6, built procedurally): a long table with chairs, shelves, pillars and a sofa;
    # two point lights under the ceiling; a checkered floor (texture kept out of the filter).
    W, H, D = 10.0, 3.0, 8.0
    shapes = [
        {"name": "floor", "material": "floor", "quad": {"corner": v(0, 0, 0), "edgeU": v(0, 0, D), "edgeV": v(W, 0, 0)}},
        {"name": "ceiling", "material": "wall", "quad": {"corner": v(0, H, 0), "edgeU": v(W, 0, 0), "edgeV": v(0, 0, D)}},
        {"name": "back", "material": "wall", "quad": {"corner": v(0, 0, D), "edgeU": v(0, H, 0), "edgeV": v(W, 0, 0)}},
        {"name": "front", "material": "wall", "quad": {"corner": v(0, 0, 0), "edgeU": v(W, 0, 0), "edgeV": v(0, H, 0)}},
        {"name": "left", "material": "accent", "quad": {"corner": v(0, 0, 0), "edgeU": v(0, H, 0), "edgeV": v(0, 0, D)}},
        {"name": "right", "material": "wall", "quad": {"corner": v(W, 0, 0), "edgeU": v(0, 0, D), "edgeV": v(0, H, 0)}},
        box("table_top", "table", (3.0, 0.72, 2.8), (7.0, 0.78, 5.2)),
    ]
    for i, (x, z) in enumerate([(3.2, 2.9), (6.6, 2.9), (3.2, 4.9), (6.6, 4.9)]):
        shapes.append(box(f"table_leg{i}", "table", (x, 0, z), (x + 0.2, 0.72, z + 0.2)))
    for i, x in enumerate([3.4, 4.6, 5.8]):
        for side, (z0, z1, back_z) in enumerate([(2.0, 2.45, 1.95), (5.55, 6.0, 6.0)]):
            shapes.append(box(f"seat{i}_{side}", "chair", (x, 0.42, z0), (x + 0.45, 0.48, z1)))
            shapes.append(box(f"seat_base{i}_{side}", "chair", (x + 0.18, 0, z0 + 0.18), (x + 0.27, 0.42, z1 - 0.18)))
            bz = back_z - 0.06 if side == 0 else back_z
            shapes.append(box(f"chair_back{i}_{side}", "chair", (x, 0.48, min(bz, bz + 0.06)), (x + 0.45, 1.0, max(bz, bz + 0.06))))
    for i, y in enumerate([0.0, 0.6, 1.2, 1.8]):
        shapes.append(box(f"shelf{i}", "shelf", (9.55, y, 1.0), (9.95, y + 0.04, 3.4)))
    shapes.append(box("shelf_side_a", "shelf", (9.55, 0, 0.96), (9.95, 1.84, 1.0)))
    shapes.append(box("shelf_side_b", "shelf", (9.55, 0, 3.4), (9.95, 1.84, 3.44)))
    for i, (y, z) in enumerate([(0.04, 1.2), (0.64, 2.1), (1.24, 1.5), (0.04, 2.7)]):
        shapes.append(box(f"books{i}", "books", (9.6, y, z), (9.9, y + 0.35, z + 0.5)))
    for i, x in enumerate([2.0, 8.0]):
        shapes.append({"name": f"pillar{i}", "material": "wall",
                       "box": {"min": v(x - 0.2, 0, 7.0), "max": v(x + 0.2, H, 7.4)}})
    shapes += [box("sofa_seat", "sofa", (0.2, 0, 5.5), (1.1, 0.45, 7.8)),
               box("sofa_back", "sofa", (0.05, 0, 5.5), (0.3, 0.9, 7.8)),
               {"name": "lamp_shade", "material": "accent", "sphere": {"center": v(5.0, 2.55, 4.0), "radius": 0.2,
                                                                        "subdivisions": 3}}]
    return {
        "description": "a procedurally built meeting room: reflectors at many distances, two point lights (AAF 2013 Fig. 6)",
        "camera": {"position": v(0.6, 1.7, 0.5), "lookAt": v(6.0, 0.7, 5.0), "up": v(0, 1, 0),
                   "verticalFovDeg": 60, "width": 320, "height": 240},
        "materials": [
            {"name": "floor", "lambertian": {"albedo": {"checker": {"even": rgb(0.55, 0.42, 0.3),
                                                                   "odd": rgb(0.35, 0.25, 0.18), "scale": 10}}}},
            lambert("wall", (0.75, 0.74, 0.7)), lambert("accent", (0.6, 0.25, 0.15)),
            lambert("table", (0.45, 0.3, 0.2)), lambert("chair", (0.2, 0.3, 0.5)),
            lambert("shelf", (0.6, 0.55, 0.45)), lambert("books", (0.3, 0.5, 0.3)),
            lambert("sofa", (0.5, 0.15, 0.2))],
        "shapes": shapes,
        "lights": [{"point": {"position": v(3.3, 2.7, 4.0), "intensity": rgb(6, 5.6, 5)}},
                   {"point": {"position": v(7.5, 2.7, 3.0), "intensity": rgb(5, 5, 5.4)}}],
        "settings": {"bounces": 1},
    }


def grids():
    # Grids of thin bars at three heights over a ground plane under a square Gaussian light:
    # shadows from sharp (low grid) to soft (high grid), as in Mehta et al. 2012, Fig. 6. The
    # grids stand side by side so that no grid shadows another: the paper's Sec. 7 calls the
    # variant "where they also shadow each other" (its Fig. 11(b)) the more challenging scene.
    # Below each grid a pixel sees one layer of occluders, so s1/s2 stays near 1.
    shapes = [{"name": "ground", "material": "ground",
               "quad": {"corner": v(-12, 0, -12), "edgeU": v(0, 0, 24), "edgeV": v(24, 0, 0)}},
              {"name": "bar", "material": "bars", "box": {"min": v(-0.5, -0.5, -0.5), "max": v(0.5, 0.5, 0.5)}}]
    # (height, bar thickness, spacing, bars per direction, centre x). The high grid sits under
    # the light's centre. For light samples anywhere on the light, its shadow (penumbra
    # included) ends about 0.1 short of the others' on the ground and 0.3 short of the other
    # grids themselves.
    levels = [(0.3, 0.05, 0.3, 5, -2.75), (1.5, 0.08, 0.5, 3, 0.0), (0.8, 0.06, 0.4, 4, 2.75)]
    for height, thick, spacing, count, cx in levels:
        span = spacing * (count + 1)
        for i in range(count):
            off = (i - (count - 1) / 2) * spacing
            # Bars along z at this height, then bars along x resting on them.
            shapes.append({"material": "bars", "instance": {"shape": "bar"},
                           "transform": {"translate": v(cx + off, height, 0), "scale": v(thick, thick, span)}})
            shapes.append({"material": "bars", "instance": {"shape": "bar"},
                           "transform": {"translate": v(cx, height + thick, off), "scale": v(span, thick, thick)}})
    # The first bar is the prototype the others instance: it takes the first placement.
    first = shapes.pop(2)
    shapes[1]["transform"] = first["transform"]
    return {
        "description": "grids of thin bars at three heights over a plane, side by side, square Gaussian area light "
                       "(AAF 2012 Fig. 6)",
        "camera": {"position": v(0.3, 6.0, 5.5), "lookAt": v(0.3, 0.1, 0.3), "up": v(0, 1, 0),
                   "verticalFovDeg": 50, "width": 320, "height": 240},
        "materials": [lambert("ground", (0.8, 0.8, 0.8)), lambert("bars", (0.6, 0.45, 0.3))],
        "shapes": shapes,
        "lights": [{"rect": {"corner": v(-1, 6, -1), "edgeU": v(2, 0, 0), "edgeV": v(0, 0, 2),
                             "radiance": rgb(40, 40, 40), "profile": "EMISSION_PROFILE_GAUSSIAN"}}],
        "settings": {"bounces": 0},
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
        "description": "a curved occluder over a curved receiver under a square Gaussian area light (AAF 2012 Fig. 8)",
        "camera": {"position": v(0, 4.2, 6.0), "lookAt": v(0, 0.3, 0), "up": v(0, 1, 0),
                   "verticalFovDeg": 45, "width": 320, "height": 240},
        "materials": [lambert("receiver", (0.75, 0.75, 0.7)), lambert("occluder", (0.3, 0.5, 0.8))],
        "shapes": [{"name": "trough", "material": "receiver", "mesh": {"positions": r4(tp), "indices": ti}},
                   {"name": "arch", "material": "occluder",
                    "mesh": {"positions": r4(hp), "normals": r4(hn), "indices": hi},
                    "transform": {"translate": v(0, 1.3, -0.2), "rotateAxis": v(1, 0, 0), "rotateDeg": -50}}],
        # Gaussian emission, as in the paper's Fig. 8 (uniform lights are its Sec. 7 extension);
        # radiance 27 keeps the power of the earlier uniform light of radiance 20 (the profile
        # averages 0.732 over the square).
        "lights": [{"rect": {"corner": v(-0.75, 5, -0.75), "edgeU": v(1.5, 0, 0), "edgeV": v(0, 0, 1.5),
                             "radiance": rgb(27, 27, 27), "profile": "EMISSION_PROFILE_GAUSSIAN"}}],
        "settings": {"bounces": 0},
    }


def glossy_plates():
    # Veach's multiple-importance-sampling plates (Veach 1997, Fig. 9.2) rebuilt for wedge: four
    # glossy plates side by side in depth, Blinn-Phong exponents 10, 100, 1,000 and 10,000, each
    # tilted so that it mirrors the area light towards the camera, in front of a two-coloured
    # back wall on a grey floor (1 bounce: the plates also reflect the lit walls). Tokuyoshi
    # 2015's lobe-aware weights should keep the plates' edges of glossiness where normal-aware
    # weights (one normal per plate) cannot tell the plates' lobes apart.
    cam, light_c = (0.0, 90.0, -160.0), (0.0, 140.0, 150.0)

    def unit(a):
        n = math.sqrt(sum(c * c for c in a))
        return tuple(c / n for c in a)

    def sub(a, b):
        return tuple(x - y for x, y in zip(a, b))

    def cross(a, b):
        return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

    plates, materials = [], [lambert("floor", (0.4, 0.4, 0.4)), lambert("warm", (0.7, 0.35, 0.1)),
                              lambert("cool", (0.1, 0.3, 0.7))]
    for k, m in enumerate([10, 100, 1000, 10000]):
        c = (0.0, 12.0 + 9.0 * k, 20.0 + 30.0 * k)
        h = unit(tuple(a + b for a, b in zip(unit(sub(light_c, c)), unit(sub(cam, c)))))
        t = unit(cross(h, (1.0, 0.0, 0.0)))
        half_u, half_v = (55.0, 0.0, 0.0), tuple(6.0 * x for x in t)
        corner = tuple(c[i] - half_u[i] - half_v[i] for i in range(3))
        materials.append(glossy(f"plate_{m}", (0.03, 0.03, 0.03), (0.6, 0.6, 0.6), m))
        plates.append({"name": f"plate_{m}", "material": f"plate_{m}",
                       "quad": {"corner": v(*corner), "edgeU": v(*(2 * x for x in half_u)),
                                "edgeV": v(*(2 * x for x in half_v))}})
    return {
        "description": "Veach-style glossy plates (Blinn-Phong m = 10 to 10,000) under an area light, 1 bounce",
        "camera": {"position": v(*cam), "lookAt": v(0, 30, 80), "up": v(0, 1, 0),
                   "verticalFovDeg": 40, "width": 320, "height": 240},
        "materials": materials,
        "shapes": [{"name": "floor", "material": "floor",
                    "quad": {"corner": v(-150, 0, -60), "edgeU": v(0, 0, 280), "edgeV": v(300, 0, 0)}},
                   {"name": "back_left", "material": "warm",
                    "quad": {"corner": v(-150, 0, 220), "edgeU": v(0, 200, 0), "edgeV": v(150, 0, 0)}},
                   {"name": "back_right", "material": "cool",
                    "quad": {"corner": v(0, 0, 220), "edgeU": v(0, 200, 0), "edgeV": v(150, 0, 0)}}] + plates,
        "lights": [{"rect": {"corner": v(15, 140, 135), "edgeU": v(0, 0, 30), "edgeV": v(-30, 0, 0),
                             "radiance": rgb(60, 55, 50)}}],
        "settings": {"bounces": 1},
    }


def sky_spheres():
    # Glossy spheres under the built-in procedural sky, like the scenes of Bagher et al. 2012
    # (glossy and textured objects under distant light): Phong exponents 10 to 1,000 in a row on
    # a checkered floor (2-unit checks), left to right, the sun behind them on the left, low
    # enough to cast long shadows, one bounce.
    materials = [{"name": "floor", "lambertian": {"albedo": {"checker": {"even": rgb(0.7, 0.7, 0.68),
                                                                         "odd": rgb(0.2, 0.2, 0.22), "scale": 200}}}}]
    spheres = []
    colours = [(0.5, 0.1, 0.05), (0.45, 0.3, 0.05), (0.1, 0.35, 0.1), (0.05, 0.2, 0.45), (0.3, 0.1, 0.4)]
    for k, (m, kd) in enumerate(zip([10, 30, 100, 300, 1000], colours)):
        materials.append(glossy(f"phong_{m}", kd, (0.45, 0.45, 0.45), m, "GLOSSY_MODEL_PHONG"))
        spheres.append({"name": f"sphere_{m}", "material": f"phong_{m}",
                        "sphere": {"center": v(4.4 - 2.2 * k, 1, 0), "radius": 1, "subdivisions": 48}})
    return {
        "description": "Glossy spheres (Phong m = 10 to 1,000) on a checkered floor under the procedural sky, 1 bounce",
        "camera": {"position": v(0, 3.2, -9), "lookAt": v(0, 0.8, 0), "up": v(0, 1, 0),
                   "verticalFovDeg": 40, "width": 320, "height": 240},
        "materials": materials,
        # The floor reaches almost to the horizon (its far checkers are finer than a pixel).
        "shapes": [{"name": "floor", "material": "floor",
                    "quad": {"corner": v(-200, 0, -200), "edgeU": v(0, 0, 400), "edgeV": v(400, 0, 0)}}] + spheres,
        "lights": [{"environment": {"sky": {"sunElevationDeg": 35, "sunAzimuthDeg": 120}}}],
        "settings": {"bounces": 1},
    }


def three_sigma(make):
    # The same scene under the Gaussian light that AAF's analysis assumes (Mehta et al. 2012,
    # Sec. 4: Omega_L = 1/sigma): same centre and same sigma, on a rectangle three times as wide
    # so that it spans +-3 sigma and its edges emit 1% of the centre. The base scenes follow the
    # authors' code instead: sigma = sqrt(area)/2, a rectangle spanning +-1 sigma whose edges
    # still emit 61%, close to a uniform light. The radiance keeps the power: per axis the
    # profile integrates to sqrt(2 pi) erf(k / sqrt 2) sigma over +-k sigma.
    def made():
        scene = make()
        light = scene["lights"][0]["rect"]
        u, w = light["edgeU"], light["edgeV"]
        sigma = math.sqrt(math.hypot(u["x"], u["y"], u["z"]) * math.hypot(w["x"], w["y"], w["z"])) / 2
        centre = {k: light["corner"][k] + (u[k] + w[k]) / 2 for k in "xyz"}
        light["corner"] = {k: centre[k] - 1.5 * (u[k] + w[k]) for k in "xyz"}
        light["edgeU"] = {k: 3 * u[k] for k in "xyz"}
        light["edgeV"] = {k: 3 * w[k] for k in "xyz"}
        light["gaussianSigma"] = sigma
        power = (math.erf(1 / math.sqrt(2)) / math.erf(3 / math.sqrt(2))) ** 2
        light["radiance"] = {k: round(c * power, 3) for k, c in light["radiance"].items()}
        scene["description"] += ", the light spanning +-3 sigma (the paper's Gaussian)"
        return scene
    return made


if __name__ == "__main__":
    for name, make in [("cornell", cornell), ("grids", grids), ("curved", curved),
                       ("cornell-glossy", cornell_glossy), ("cornell-polished", cornell_polished), ("interior", interior),
                       ("grids-3sigma", three_sigma(grids)), ("curved-3sigma", three_sigma(curved)),
                       ("glossy-plates", glossy_plates), ("sky-spheres", sky_spheres)]:
        with open(os.path.join(HERE, name + ".json"), "w") as f:
            compact = name in ("curved", "cornell-glossy", "cornell-polished", "interior", "curved-3sigma")
            json.dump(make(), f, separators=(",", ":") if compact else (",", ": "), indent=None if compact else 1)
            f.write("\n")

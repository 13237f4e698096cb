"""Glossy variants of built-in area-lit scenes: with `glossy-plates`, the scenes on which the
rect lights' two-strategy direct light (docs/methods.md §0.5) is measured. Not run in CI.

    python3 bench/shiny.py [--out DIR]      # writes DIR/NAME.json and prints each path
    python3 bench/race.py "$(python3 bench/shiny.py | head -1)" --methods uniform,uniform@base \\
        --wedge-base OLD/target/release/wedge --no-mitsuba

- `cornell-shiny`: `cornell` (its 3 bounces) with its white surfaces (floor, ceiling, back wall,
  blocks) a Blinn-Phong of exponent 300 over half the white albedo, reflecting the ceiling light.
- `curved-shiny`: `curved` (direct light, a Gaussian light) with a Phong receiver of exponent 2000
  and a Blinn-Phong occluder of exponent 100: sharp and broad lobes under a Gaussian profile.
"""
import argparse
import copy
import json
import os

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def glossy(diffuse, specular, exponent, model):
    rgb = lambda c: {"constant": {"r": c[0], "g": c[1], "b": c[2]}}
    return {"glossy": {"diffuse": rgb(diffuse), "specular": rgb(specular), "exponent": {"constant": exponent},
                       "model": f"GLOSSY_MODEL_{model}"}}


def albedo(material):
    c = material["lambertian"]["albedo"]["constant"]
    return [c["r"], c["g"], c["b"]]


def variant(base, name, description, change):
    scene = json.load(open(os.path.join(ROOT, "scenes", f"{base}.json")))
    scene = copy.deepcopy(scene)
    scene["description"] = description
    for m in scene["materials"]:
        new = change(m)
        if new:
            m.pop("lambertian", None)
            m.update(new)
    return name, scene


def variants():
    yield variant("cornell", "cornell-shiny", "cornell with Blinn-Phong (m = 300) white surfaces",
                  lambda m: m["name"] == "white" and glossy([0.5 * c for c in albedo(m)], [0.3] * 3, 300, "BLINN_PHONG"))
    yield variant("curved", "curved-shiny", "curved with a Phong (m = 2000) receiver and a Blinn-Phong (m = 100) occluder",
                  lambda m: {"receiver": glossy([0.3 * c for c in albedo(m)], [0.5] * 3, 2000, "PHONG"),
                             "occluder": glossy([0.5 * c for c in albedo(m)], [0.4] * 3, 100, "BLINN_PHONG")}[m["name"]])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(ROOT, "bench-results", "shiny"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    for name, scene in variants():
        path = os.path.join(args.out, f"{name}.json")
        with open(path, "w") as f:
            json.dump(scene, f, indent=1)
        print(path)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Beverloo's discharge rate for a case file: a sanity line beside the measured <m_dot>.

usage: scripts/beverloo.py CASE.toml [CASE.toml ...] [--json] [--phi 0.6]

Circular orifice (Beverloo, Leniger & van de Velde, Chem. Eng. Sci. 15, 260, 1961):
    W = C rho_b sqrt(g) (D0 - k d)^(5/2),            C = 0.58, k = 1.5
Slot of width W0 and length L (the slot form of the same law, as quoted by Nedderman,
Statics and Kinematics of Granular Materials, 1992, ch. 10):
    W = C' rho_b sqrt(g) (W0 - k d)^(3/2) (L - k d),  C' = 1.03
rho_b = phi rho_p (phi = 0.6 unless --phi), d = the number-mean diameter of the case's
insertions at alpha = 1 times the alpha of the case's finest level (the particles that
pass the orifice), rho_p the inserted material's density, g = |gravity|.

The orifice: [orifice] (center, diameter or width + length) when the case has it, else
the opening under a wall an event removes (a disk lid): the narrowest cone bottom,
cylinder bottom or disk hole (inner_radius) centred within the lid's radius, else the
lid's own diameter; else the lowest cone narrowing to a bottom radius > 0. The same
rules as `mlcg run`'s region checks (common/config/region_rules.cpp).
Beverloo's law is for flat-bottomed bins; hoppers (cones, wedges) discharge faster.
Plain python3 (3.11+: tomllib), no packages.
"""
import argparse
import json
import math
import sys
import tomllib

C_CIRCLE, C_SLOT, K = 0.58, 1.03, 1.5


def mean_diameter(radius):
    """Number-mean diameter of one insertion's radius entry [m]."""
    if isinstance(radius, (int, float)):
        return 2.0 * radius
    if "uniform" in radius:
        a, b = radius["uniform"]
        return a + b
    return 2.0 * sum(v * f for v, f in zip(radius["values"], radius["fractions"]))


def dist(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


def unit(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


def bottom_centre(w):
    c, a = w.get("center", [0, 0, 0]), unit(w.get("axis", [0, 0, 1]))
    return [c[i] + w["bottom"] * a[i] for i in range(3)]


def openings(walls, removed):
    out = []
    for w in walls:
        if w["name"] in removed:
            continue
        if w["type"] == "cone" and w["radius_bottom"] > 0:
            out.append((bottom_centre(w), w["radius_bottom"], f"cone '{w['name']}'"))
        elif w["type"] == "cylinder":
            out.append((bottom_centre(w), w["radius"], f"cylinder '{w['name']}'"))
        elif w["type"] == "disk" and w.get("inner_radius", 0) > 0:
            out.append((w.get("center", [0, 0, 0]), w["inner_radius"], f"the hole of disk '{w['name']}'"))
    return out


def find_orifice(case):
    """{'center', 'diameter'} or {'center', 'width', 'length'}, with 'from'; None if unknown."""
    if "orifice" in case:
        o = dict(case["orifice"])
        o["from"] = "[orifice]"
        return o
    walls = case.get("walls", [])
    removed = {w for e in case.get("events", []) for w in e.get("remove_walls", [])}
    holes = openings(walls, removed)
    for lid in walls:
        if lid["type"] != "disk" or lid["name"] not in removed:
            continue
        c = lid.get("center", [0, 0, 0])
        under = [h for h in holes if dist(h[0], c) <= lid["radius"] and h[1] <= lid["radius"]]
        if under:
            h = min(under, key=lambda h: h[1])
            return {"center": h[0], "diameter": 2 * h[1], "from": f"lid '{lid['name']}' over {h[2]}"}
        return {"center": c, "diameter": 2 * lid["radius"], "from": f"lid '{lid['name']}'"}
    cones = [w for w in walls if w["type"] == "cone" and w["name"] not in removed
             and 0 < w["radius_bottom"] < w["radius_top"]]
    if cones:
        w = min(cones, key=lambda w: bottom_centre(w)[2])
        return {"center": bottom_centre(w), "diameter": 2 * w["radius_bottom"], "from": f"the bottom of cone '{w['name']}'"}
    return None


def beverloo(path, phi):
    with open(path, "rb") as f:
        case = tomllib.load(f)
    o = find_orifice(case)
    if o is None:
        raise SystemExit(f"{path}: no orifice found; give [orifice] (center, diameter or width + length)")
    ins = case.get("insertion", [])
    if not ins:
        raise SystemExit(f"{path}: no [[insertion]]: the particle size is unknown")
    alpha = min(l.get("alpha", 1.0) for l in case["levels"])
    d = alpha * sum(mean_diameter(i["radius"]) for i in ins) / len(ins)
    densities = {m["name"]: m["density"] for m in case["materials"]}
    rho_b = phi * densities[ins[0]["material"]]
    g = math.sqrt(sum(x * x for x in case.get("gravity", [0, 0, -9.81])))
    if "diameter" in o:
        size = {"D0": o["diameter"]}
        w = C_CIRCLE * rho_b * math.sqrt(g) * max(o["diameter"] - K * d, 0.0) ** 2.5
    else:
        size = {"W0": o["width"], "L": o["length"]}
        w = C_SLOT * rho_b * math.sqrt(g) * max(o["width"] - K * d, 0.0) ** 1.5 * max(o["length"] - K * d, 0.0)
    return {"case": path, "orifice_from": o["from"], **size, "d": d, "rho_b": rho_b, "kg_per_s": w}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cases", nargs="+")
    ap.add_argument("--json", action="store_true", help="one JSON object per case")
    ap.add_argument("--phi", type=float, default=0.6, help="bulk solid fraction (rho_b = phi rho_p)")
    a = ap.parse_args()
    for path in a.cases:
        r = beverloo(path, a.phi)
        if a.json:
            print(json.dumps(r))
            continue
        size = ", ".join(f"{k} = {v * 1000:g} mm" for k, v in r.items() if k in ("D0", "W0", "L"))
        print(f"{path}: Beverloo {r['kg_per_s']:.4f} kg/s ({size} from {r['orifice_from']}, "
              f"d = {r['d'] * 1000:.3g} mm, rho_b = {r['rho_b']:g} kg/m3)")


if __name__ == "__main__":
    sys.exit(main())

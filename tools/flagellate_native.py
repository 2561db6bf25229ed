#!/usr/bin/env python3
"""Builds the MuJoCo-native twin of a rigid-flagellum model (models/flagellate_native.xml).

Reads a model whose flagellum is a <cosserat> rod of rigid sections (models/flagellate_rigid.xml)
and replaces the rod by what a MuJoCo user would build without this project: a chain of N
capsules following the same centreline (the exact rest shape of the rod: straight and helical
pieces of constant strain), welded into one rigid body (a child body without joints) in the rod's
place. Each capsule carries the mass of the stretch of filament it stands for; the rod's sites
(<name>/base, <name>/tip and the user's <site at=...>) become sites of that body. The fluid model
is the same: the rod's resistive-force coefficients (Gray & Hancock from the filament radius and
the helix pitch, as plugin/core/fluid.cpp computes them) go to a <numeric name="cosserat:drag:BODY">
for the capsules, which the plugin then applies along each capsule (scene_fluid.hpp).

Usage:
  python3 tools/flagellate_native.py [--capsules N] [--input models/flagellate_rigid.xml]
                                     [--output models/flagellate_native.xml]
N is the number of capsules along the helical part (the straight hook is one capsule). The
discretisation error of the native chain (chords instead of arcs) shrinks as N^-2: see the README.
Pure Python 3 (no packages).
"""
import argparse
import math
import sys
import xml.etree.ElementTree as ET


def fmt(x):
    return "%.10g" % x


def mat_vec(A, v):
    return [sum(A[i][k] * v[k] for k in range(3)) for i in range(3)]


def mat_mul(A, B):
    return [[sum(A[i][k] * B[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def skew(k):
    return [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]]


def exp_strain(k, X):
    """Pose (R, p) reached after X along a constant strain [k; 1 0 0]: exp(X xi^)."""
    th = math.sqrt(sum(c * c for c in k))
    K = skew(k)
    K2 = mat_mul(K, K)
    t = th * X
    if th * X < 1e-6:
        a, b, c = X, X * X / 2.0, X ** 3 / 6.0
        ra, rb = 1.0, X * X / 2.0
        rs = X
    else:
        ra = 1.0
        rs = math.sin(t) / th
        rb = (1.0 - math.cos(t)) / th ** 2
        a, b, c = X, (1.0 - math.cos(t)) / th ** 2, (t - math.sin(t)) / th ** 3
    R = [[(1.0 if i == j else 0.0) + rs * K[i][j] + rb * K2[i][j] for j in range(3)] for i in range(3)]
    V = [[(a if i == j else 0.0) + b * K[i][j] + c * K2[i][j] for j in range(3)] for i in range(3)]
    p = mat_vec(V, [1.0, 0.0, 0.0])
    return R, p


def compose(g, h):
    (R1, p1), (R2, p2) = g, h
    return mat_mul(R1, R2), [p1[i] + mat_vec(R1, p2)[i] for i in range(3)]


def numbers(text):
    return [float(x) for x in text.split()]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--capsules", type=int, default=64, help="capsules along the helix (default 64)")
    ap.add_argument("--input", default="models/flagellate_rigid.xml")
    ap.add_argument("--output", default="models/flagellate_native.xml")
    ap.add_argument("--rod", default="flagellum", help="name of the <cosserat> to replace")
    args = ap.parse_args()
    if args.capsules < 1:
        sys.exit("--capsules must be >= 1")

    text = open(args.input).read()
    text = text[text.index("<mujoco"):]  # the header comment may hold "--" (not XML, but tinyxml2 takes it)
    root = ET.fromstring(text, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    tree = ET.ElementTree(root)
    parent = rod = None
    for p in root.iter():
        for c in list(p):
            if c.tag == "cosserat" and c.get("name") == args.rod:
                parent, rod = p, c
    if rod is None:
        sys.exit("no <cosserat name='%s'> in %s" % (args.rod, args.input))
    if rod.get("strain", "kl") != "rigid":
        sys.exit("the rod must be rigid (strain='rigid') to have a rigid native twin")
    option = root.find("option")
    mu = float(option.get("viscosity", "0")) if option is not None else 0.0

    # sections: (length, rest curvature k); unsized sections share the rest of the rod's length
    L = float(rod.get("length"))
    a = numbers(rod.get("radius", "0.01"))
    if len(a) != 1:
        sys.exit("tapered rods are not supported")
    a = a[0]
    rho = float(rod.get("density", "1000"))
    rest = numbers(rod.get("reststrain", "0 0 0 1 0 0"))
    secs = []
    for s in rod.findall("section"):
        if s.get("strain", "rigid") != "rigid":
            sys.exit("every section must be rigid")
        r = numbers(s.get("reststrain")) if s.get("reststrain") else rest
        if r[3:] != [1.0, 0.0, 0.0]:
            sys.exit("only unsheared, unstretched rest strains are supported")
        secs.append([float(s.get("length", "0")), r[:3]])
    if not secs:
        n = int(rod.get("sections", "1"))
        secs = [[0.0, rest[:3]] for _ in range(n)]
    given = sum(s[0] for s in secs)
    unsized = sum(1 for s in secs if s[0] == 0.0)
    for s in secs:
        if s[0] == 0.0:
            s[0] = (L - given) / unsized

    # the rod's resistive-force coefficients (plugin/core/fluid.cpp: set_rod_drag, Gray & Hancock)
    lam = None
    for _, k in secs:
        k2 = sum(c * c for c in k)
        if k2 > 0:
            radius = math.sqrt(k[1] ** 2 + k[2] ** 2) / k2
            pitch = 2 * math.pi * k[0] / k2
            if radius > 1e-9 / math.sqrt(k2) and abs(pitch) > 1e-9 / math.sqrt(k2):
                lam = abs(pitch)
                break
    if rod.get("wavelength"):
        lam = float(rod.get("wavelength"))
    if lam is None:
        lam = L / 2
    if rod.get("drag"):
        d = numbers(rod.get("drag"))
        ct, cn = d[0], d[1]
        crot = d[2] if len(d) > 2 else 4 * math.pi * mu * a * a
    else:
        lg = math.log(2 * lam / a)
        ct, cn, crot = 2 * math.pi * mu / (lg - 0.5), 4 * math.pi * mu / (lg + 0.5), 4 * math.pi * mu * a * a

    # capsules: straight sections as one capsule each, curved ones share N by length
    curved = [s for s in secs if sum(c * c for c in s[1]) > 0]
    Lc = sum(s[0] for s in curved)
    body = ET.Element("body", {"name": args.rod})
    for attr in ("pos", "quat", "euler", "axisangle", "xyaxes", "zaxis"):
        if rod.get(attr):
            body.set(attr, rod.get(attr))
    g = ([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]], [0.0, 0.0, 0.0])
    X0 = 0.0
    count = 0
    geom_attrs = {}
    for attr in ("rgba", "group", "material", "contype", "conaffinity", "condim", "friction"):
        if rod.get(attr):
            geom_attrs[attr] = rod.get(attr)
    for length, k in secs:
        straight = sum(c * c for c in k) == 0
        n = 1 if straight else max(1, round(args.capsules * length / Lc))
        for j in range(n):
            ga = compose(g, exp_strain(k, length * j / n))[1]
            gb = compose(g, exp_strain(k, length * (j + 1) / n))[1]
            mass = rho * math.pi * a * a * length / n
            attrs = {"name": "%s/c%d" % (args.rod, count), "type": "capsule",
                     "fromto": " ".join(fmt(x) for x in ga + gb), "size": fmt(a), "mass": fmt(mass)}
            attrs.update(geom_attrs)
            ET.SubElement(body, "geom", attrs)
            count += 1
        g = compose(g, exp_strain(k, length))
        X0 += length

    def point_at(X):
        gg = ([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]], [0.0, 0.0, 0.0])
        x = 0.0
        for length, k in secs:
            if X <= x + length:
                return compose(gg, exp_strain(k, max(X - x, 0.0)))[1]
            gg = compose(gg, exp_strain(k, length))
            x += length
        return gg[1]

    sites = [("%s/base" % args.rod, 0.0, {}), ("%s/tip" % args.rod, L, {})]
    for s in rod.findall("site"):
        extra = {k: v for k, v in s.attrib.items() if k not in ("name", "at", "pos")}
        if s.get("pos"):
            sys.exit("sites with an offset (pos) are not supported")
        sites.append((s.get("name"), float(s.get("at", "0")), extra))
    for name, X, extra in sites:
        attrs = {"name": name, "pos": " ".join(fmt(x) for x in point_at(X)), "size": "0.001"}
        attrs.update(extra)
        ET.SubElement(body, "site", attrs)
    for child in rod.findall("body"):
        sys.exit("bodies at the rod's tip are not supported")

    index = list(parent).index(rod)
    parent.remove(rod)
    body.tail = rod.tail
    parent.insert(index, body)

    custom = root.find("custom")
    if custom is None:
        custom = ET.Element("custom")
        custom.tail = "\n"
        after = root.find("actuator")
        root.insert(list(root).index(after) if after is not None else len(root), custom)
    ET.SubElement(custom, "numeric", {"name": "cosserat:drag:%s" % args.rod,
                                      "data": "%s %s %s" % (fmt(ct), fmt(cn), fmt(crot))})

    root.set("model", root.get("model", "flagellate").replace("_rigid", "") + "_native")
    # replace the leading comment by ours
    comment = ("MuJoCo-native twin of %s, generated by tools/flagellate_native.py with %d capsules\n"
               "     (do not edit: regenerate). The rigid flagellum (hook and helix) is a chain of %d capsules\n"
               "     welded into one body '%s' in the rod's place, following the rod's exact rest centreline;\n"
               "     each capsule has the mass of the filament it stands for (%g kg/m). The same fluid model\n"
               "     acts on them: resistive force theory along each capsule with the rod's coefficients\n"
               "     c_t = %.6g, c_n = %.6g N s/m^2, c_rot = %.6g N s (Gray & Hancock, mu = %g Pa s,\n"
               "     a = %g m, pitch %.6g m), given by the numeric cosserat:drag:%s.\n"
               "     Compare with: cosserat compare %s %s (README, Swimming flagellates)"
               % (args.input, args.capsules, count, args.rod, rho * math.pi * a * a, ct, cn, crot, mu, a, lam,
                  args.rod, args.input, args.output))
    ET.indent(tree, space="  ")
    with open(args.output, "w") as f:
        f.write("<!-- " + comment + " -->\n")
        body_xml = ET.tostring(root, encoding="unicode")
        f.write(body_xml + "\n")
    print("wrote %s: %d capsules (%d along the helix), c_t %.6g, c_n %.6g, c_rot %.6g" %
          (args.output, count, count - sum(1 for s in secs if sum(c * c for c in s[1]) == 0), ct, cn, crot))


if __name__ == "__main__":
    main()

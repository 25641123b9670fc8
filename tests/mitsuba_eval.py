"""Evaluate a brdfit Mitsuba export with Mitsuba 3 itself (scalar_rgb).

usage: python mitsuba_eval.py EXPORT.xml DIRS.csv OUT.csv

An EXPORT ending in .bsdf is an RGL file, loaded with Mitsuba's `measured` plugin.

DIRS.csv holds theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg per row (brdfit's convention,
normal +z). OUT.csv gets r,g,b: Mitsuba's f_r = bsdf.eval(wi = light, wo = eye) / cos(theta_o),
both directions in the local frame of a surface with normal +z. Used by tests/it/export.rs and
tests/it/rgl.rs.
"""
import csv
import math
import sys

import mitsuba as mi

mi.set_variant("scalar_rgb")


def direction(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return mi.Vector3f(math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))


def main():
    xml_path, dirs_path, out_path = sys.argv[1:4]
    if xml_path.endswith(".bsdf"):
        bsdf = mi.load_dict({"type": "measured", "filename": xml_path})
    else:
        text = open(xml_path).read()
        start = text.index("<bsdf")
        text = text[:start] + '<bsdf version="3.0.0"' + text[start + len("<bsdf"):]
        bsdf = mi.load_string(text)
    ctx = mi.BSDFContext()
    rows = []
    with open(dirs_path) as f:
        for r in csv.DictReader(f):
            li = direction(float(r["theta_i_deg"]), float(r["phi_i_deg"]))
            eo = direction(float(r["theta_o_deg"]), float(r["phi_o_deg"]))
            si = mi.SurfaceInteraction3f()
            si.n = mi.Normal3f(0, 0, 1)
            si.sh_frame = mi.Frame3f(si.n)
            si.wi = li
            v = bsdf.eval(ctx, si, eo)
            c = eo.z
            rows.append([float(v[0]) / c, float(v[1]) / c, float(v[2]) / c])
    with open(out_path, "w") as f:
        f.write("r,g,b\n")
        for r in rows:
            f.write(",".join(repr(x) for x in r) + "\n")


main()

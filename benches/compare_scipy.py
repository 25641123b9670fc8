#!/usr/bin/env python3
"""Table rows for benches/compare_scipy.sh: brdfit against the scipy peer on one CSV file.

  compare_scipy.py DATA.csv PEER.py PEER_JSON MODE=BRDFIT_JSON...

Times. The peer times least_squares alone (its geometry is computed before its clock starts);
brdfit reports `seconds` (geometry pass + solve + statistics) and `geometry_seconds`. Two
ratios are printed: solve against solve (brdfit's seconds minus its geometry, the peer's
seconds), and everything against everything (the peer's geometry() timed here, median of 5,
added to its seconds).

Costs. Each program reports ½ Σ r² summed its own way, and the two sums round differently in
the last digits. So both parameter sets are also evaluated here by one evaluator: the peer's
formulas (exact Fresnel, Blinn's G, D3, log loss) in long double, summed pairwise; "cost no
higher" is judged on that column.
"""
import importlib.util, json, statistics, sys, time
import numpy as np


def peer_module(path):
    spec = importlib.util.spec_from_file_location("scipy_peer", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def common_cost(ang, y):
    """½ Σ r² of the log loss at a parameter dict, every step in long double."""
    L = np.longdouble
    ti, pi_, to, po = [a.astype(L) for a in ang]
    y = y.astype(L)
    lv = np.stack([np.sin(ti) * np.cos(pi_), np.sin(ti) * np.sin(pi_), np.cos(ti)], -1)
    ev = np.stack([np.sin(to) * np.cos(po), np.sin(to) * np.sin(po), np.cos(to)], -1)
    nl, ne = lv[:, 2], ev[:, 2]
    h = lv + ev
    h /= np.sqrt(np.sum(h * h, 1))[:, None]
    nh, eh = h[:, 2], np.sum(ev * h, 1)
    g = np.minimum(L(1), np.minimum(2 * nh * ne / eh, 2 * nh * nl / eh))
    pi = L("3.141592653589793238462643383279502884")
    k = g / (pi * nl * ne)
    x = nh * nh
    target = np.log1p(nl * y)

    def cost(p):
        n, c3, ps, pd = (L(p[name]) for name in ("n", "c3", "ps", "pd"))
        c2 = c3 * c3
        d = (c2 / (x * (c2 - 1) + 1)) ** 2
        gg = np.sqrt(n * n + eh * eh - 1)
        f = L(0.5) * ((gg - eh) / (gg + eh)) ** 2 * (
            1 + ((eh * (gg + eh) - 1) / (eh * (gg - eh) + 1)) ** 2)
        r = np.log1p(nl * (pd / pi + ps * d * k * f)) - target
        return float(L(0.5) * np.sum(r * r))

    return cost


def main():
    data, peer_path, peer_json = sys.argv[1:4]
    peer = peer_module(peer_path)
    ang, y = peer.load(data, "brdf")
    keep = (np.cos(ang[0]) > 0) & (np.cos(ang[2]) > 0) & np.isfinite(y)
    ang = [a[keep] for a in ang]
    y = y[keep]
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        peer.geometry(*ang)
        times.append(time.perf_counter() - t0)
    peer_geo = statistics.median(times)
    cost = common_cost(ang, y)
    p = json.loads(peer_json)
    p_common = cost(p["params"])
    n = len(y)
    rows = []
    for arg in sys.argv[4:]:
        mode, path = arg.split("=", 1)
        f = json.load(open(path))
        solve = f["seconds"] - f["geometry_seconds"]
        c = cost(f["params"])
        rows.append((f"brdfit {mode}", solve, f["geometry_seconds"], f["seconds"], f["cost"], c,
                     f"{p['seconds'] / solve:6.1f}x {(p['seconds'] + peer_geo) / f['seconds']:6.1f}x"
                     f"   {(c - p_common) / p_common:+.1e}"))
    rows.append(("scipy least_squares lm", p["seconds"], peer_geo, p["seconds"] + peer_geo,
                 p["cost"], p_common, ""))
    for name, solve, geo, total, own, common, tail in rows:
        print(f"{n:<9} {name:<24} {solve:9.5f} {geo:9.5f} {total:9.5f} {own:.12e} "
              f"{common:.12e} {tail}")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Table rows for benches/compare_scipy.sh: brdfit against the scipy peers on one CSV file and model.

  compare_scipy.py DATA.csv --model M [--channel brdf] [--shared-peer PATH]
                   --peer NAME=PEER_JSON... --brdfit MODE=BRDFIT_JSON...

M is a model of benches/scipy_models.py (lambert, phong, blinn-phong, ts-d1, ts-d2, ts-d3,
ts-abc, ggx-smith, ggx-smith-2). The first --peer is the reference of the ratios.

Times. A peer times least_squares alone (its geometry is computed before its clock starts);
benches/scipy_models.py reports the median time of that geometry as `geometry_seconds`; for a
peer that does not (a peer script given as --shared-peer, e.g. scipy_fit.py) its geometry() is timed
here, median of 5. brdfit reports `seconds` = `geometry_seconds` (the per-sample pass) +
`solve_seconds` (set-up, global initialisation, local fits and polish: reaching the minimum) +
`statistics_seconds` (checks at return, standard errors, correlations, 1 % ranges, the physical
check's albedo quadrature), each the
median of its own column. Two ratios are printed: solve against solve (brdfit's
`solve_seconds`, the peer's seconds: the work both clocks cover), and everything against
everything (brdfit's `seconds`, statistics included, against the peer's geometry + solve; the
peers compute no statistics). brdfit's fit JSON of versions before `solve_seconds` gives
seconds − geometry as its solve and no statistics column.

Costs. Each program reports ½ Σ r² summed its own way, and the sums round differently in the
last digits. So every parameter set is also evaluated here by one evaluator: scipy_models.py's
formulas (written from the papers, not from brdfit's code) in long double, summed pairwise;
"cost no higher" is judged on that column. Two checks per row: `vs ref` is the row's common cost
relative to the reference peer's (negative: lower), `own/common` is the program's own cost
relative to the common evaluator's at its own parameters (a model or loss that differs from the
papers' shows here). Either beyond 1e-6 in size is marked `!`.
"""
import argparse, importlib.util, json, os, statistics, sys, time
import numpy as np

sys.dont_write_bytecode = True  # no __pycache__ in the repository
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scipy_models as sm  # noqa: E402

FLAG = 1e-6


def module(path):
    spec = importlib.util.spec_from_file_location("shared_peer", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def common_cost(model, ang, y):
    """½ Σ r² of the log loss at a parameter dict, every step in long double."""
    L = np.longdouble
    g = sm.geometry(model, *[a.astype(L) for a in ang])
    target = np.log1p(g["nl"] * y.astype(L))
    names = [nm for nm, _ in sm.MODELS[model][0]]

    def cost(p):
        r = sm.residual(model, g, target, [L(float(p[nm])) for nm in names])
        return float(L("0.5") * np.sum(r * r))

    return cost


def pairs(items):
    out = []
    for it in items or []:
        name, path = it.split("=", 1)
        with open(path) as f:
            j = json.load(f)
        out.append((name, j["fits"][0] if "fits" in j else j))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("--model", required=True, choices=list(sm.MODELS))
    ap.add_argument("--channel", default="brdf")
    ap.add_argument("--shared-peer")
    ap.add_argument("--peer", action="append", required=True)
    ap.add_argument("--brdfit", action="append")
    a = ap.parse_args()
    ang, y = sm.load(a.data, a.channel)
    cost = common_cost(a.model, ang, y)
    rows = []
    for name, p in pairs(a.peer):
        geo = p.get("geometry_seconds")
        if geo is None:
            shared = module(a.shared_peer)
            times = []
            for _ in range(5):
                t0 = time.perf_counter()
                shared.geometry(*ang)
                times.append(time.perf_counter() - t0)
            geo = statistics.median(times)
        rows.append((name, p["seconds"], 0.0, geo, p["cost"], cost(p["params"]), p["params"]))
    for mode, f in pairs(a.brdfit):
        geo = f["geometry_seconds"]
        if "solve_seconds" in f:
            solve, stats = f["solve_seconds"], f["statistics_seconds"]
        else:
            solve, stats = f["seconds"] - geo, 0.0
        rows.append((f"brdfit {mode}", solve, stats, geo, f["cost"], cost(f["params"]), f["params"]))
    _, ref_solve, _, ref_geo, _, ref_common, _ = rows[0]
    label = a.model if a.channel == "brdf" else f"{a.model}/{a.channel}"
    flagged = False
    for k, (name, solve, stats, geo, own, common, _) in enumerate(rows):
        total = solve + stats + geo
        vs = (common - ref_common) / ref_common
        oc = own / common - 1
        flagged |= abs(vs) > FLAG or abs(oc) > FLAG
        tail = "" if k == 0 else f"{ref_solve / solve:7.1f}x {(ref_solve + ref_geo) / total:7.1f}x "
        print(f"{len(y):<9} {label:<18} {name:<24} {solve:9.5f} {stats:9.5f} {geo:9.5f} {total:9.5f} "
              f"{own:.12e} {common:.12e} {tail:>17} {vs:+.1e}{'!' if abs(vs) > FLAG else ' '} "
              f"{oc:+.1e}{'!' if abs(oc) > FLAG else ' '}")
    if flagged:  # the parameters, to find out which program is right
        for name, *_, params in rows:
            print(f"{'':<10}{name}: " + ", ".join(f"{k}={v:.10g}" for k, v in params.items()))


if __name__ == "__main__":
    main()

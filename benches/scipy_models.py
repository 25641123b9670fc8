#!/usr/bin/env python3
"""scipy peer for every model brdfit fits: scipy.optimize.least_squares (MINPACK lm) on the log loss.

  scipy_models.py DATA.csv --model M [--start NAME=VALUE,...] [--repeat 5] [--channel brdf]
                  [--loss log|linear] [--check-jac]

M is one of: lambert, phong, blinn-phong, ts-d1, ts-d2, ts-d3, ts-abc, ggx-smith, ggx-smith-2
(ts-* is Torrance–Sparrow with Blinn's D1, D2, D3 or Löw's ABC distribution).

Written from the papers and brdfit's README, not from brdfit's code, so that it is an
independent check. f_r in 1/sr, N = +z, L and E unit vectors from (θi, φi) and (θo, φo),
H = (L + E)/|L + E|; a model is Blinn's intensity i for a unit light and f_r = i/(π N·L):

  lambert       f = pd/π
  phong         f = pd/π + ps max(0, R·E)^c1 / (π N·L),  R = 2(N·L)N − L     (Phong 1975)
  blinn-phong   f = pd/π + ps max(0, N·H)^c1 / (π N·L)                      (Blinn 1977, D1)
  ts-*          f = pd/π + ps D F G / (π N·L N·E)                           (Blinn 1977)
                D1 = (N·H)^c1, D2 = exp(−(c2 α)²) with α = acos N·H,
                D3 = (c3² / ((N·H)²(c3² − 1) + 1))²,
                ABC = (1 + b (1 − N·H))^(−c)                 (Löw et al. 2012, eq. 6 with A = 1)
                G = min(1, 2(N·H)(N·E)/(E·H), 2(N·H)(N·L)/(E·H)),
                F = ½ (g−c)²/(g+c)² [1 + (c(g+c)−1)²/(c(g−c)+1)²], g² = n² + c² − 1, c = E·H
  ggx-smith     f = pd/π + ps F D G1(L) G1(E) / (4 N·L N·E)                 (Walter et al. 2007)
                D = α² / (π (N·H)⁴ (α² + tan²θh)²)                                  (eq. 33)
                G1(v) = 2 / (1 + √(1 + α² tan²θv))                                    (eq. 34)
  ggx-smith-2   two such lobes (alpha1, ps1; alpha2, ps2) sharing F's n.

Loss (brdfit's default, src/fit/problem.rs): r = ln(1 + cosθi f_model) − ln(1 + cosθi f_data);
linear: r = f_model − f_data; cost = ½ Σ r². Rows kept as brdfit keeps them: cosθi > 0,
cosθo > 0, value finite and not negative (brdfit's default --negative mask).

Variables. MINPACK's lm knows no bounds, so the peer solves for the same unconstrained
variables brdfit maps its box to: shape parameters (c1, c2, c3, b, c, alpha…) as ln θ, the index
as ln(n − 1), ps and pd as themselves (they may leave [0, ∞): a peer without bounds). The
Jacobian is analytic (dF/dn too) and chained through those maps; --check-jac compares it with
central differences at the start and exits.

Timing as a scipy peer script (scipy_fit.py) times itself: geometry() (the parameter-free per-sample
terms) is computed once per fit before the clock starts and timed on its own; `seconds` is
least_squares alone; both are medians over --repeat fits. Prints one JSON line: peer, model,
loss, params, cost, nfev, status, samples, seconds, geometry_seconds.
Install: python3 -m venv VENV && VENV/bin/pip install numpy scipy
"""
import argparse, json, statistics, sys, time
import numpy as np
from scipy.optimize import least_squares

LONG_PI = "3.141592653589793238462643383279502884"


# Each model: its parameters in brdfit's declared order, each with the map of its solver
# variable ("log": θ = e^u, "log1": θ = 1 + e^u, "lin": θ = u), and brdfit's command-line form.
MODELS = {
    "lambert": ([("pd", "lin")], ["--model", "lambert"]),
    "phong": ([("c1", "log"), ("ps", "lin"), ("pd", "lin")], ["--model", "phong"]),
    "blinn-phong": ([("c1", "log"), ("ps", "lin"), ("pd", "lin")], ["--model", "blinn-phong"]),
    "ts-d1": ([("n", "log1"), ("c1", "log"), ("ps", "lin"), ("pd", "lin")],
              ["--model", "torrance-sparrow", "--distribution", "d1"]),
    "ts-d2": ([("n", "log1"), ("c2", "log"), ("ps", "lin"), ("pd", "lin")],
              ["--model", "torrance-sparrow", "--distribution", "d2"]),
    "ts-d3": ([("n", "log1"), ("c3", "log"), ("ps", "lin"), ("pd", "lin")],
              ["--model", "torrance-sparrow", "--distribution", "d3"]),
    "ts-abc": ([("n", "log1"), ("b", "log"), ("c", "log"), ("ps", "lin"), ("pd", "lin")],
               ["--model", "torrance-sparrow", "--distribution", "abc"]),
    "ggx-smith": ([("alpha", "log"), ("n", "log1"), ("ps", "lin"), ("pd", "lin")],
                  ["--model", "ggx-smith"]),
    "ggx-smith-2": ([("alpha1", "log"), ("ps1", "lin"), ("alpha2", "log"), ("ps2", "lin"),
                     ("n", "log1"), ("pd", "lin")], ["--model", "ggx-smith-2"]),
}


def load(path, channel):
    """Angles (radians) and f_r of column `channel` of a brdfit CSV; rows kept as brdfit keeps them."""
    with open(path) as f:
        for line in f:
            if line.strip() and not line.lstrip().startswith("#"):
                head = [h.strip() for h in line.lstrip("\ufeff").split(",")]
                break
        else:
            sys.exit(f"{path}: no header line; fix: a brdfit CSV starts with its column names")
    try:
        a = np.loadtxt(path, delimiter=",", comments="#", skiprows=1, ndmin=2)
    except ValueError:  # empty fields (missing values)
        a = np.genfromtxt(path, delimiter=",", comments="#", skip_header=1, filling_values=np.nan)
    col = {h: a[:, k] for k, h in enumerate(head)}
    if channel not in col:
        sys.exit(f"{path}: no column {channel!r}; fix: --channel one of {', '.join(head[4:])}")
    if not channel.startswith("brdf") or channel.startswith("brdf_cos"):
        sys.exit(f"{path}: column {channel!r} is not f_r; fix: convert the file to a brdf column "
                 "(brdfit convert)")
    ang = []
    for c in ("theta_i", "phi_i", "theta_o", "phi_o"):
        if c + "_deg" in col:
            ang.append(np.radians(col[c + "_deg"]))
        elif c + "_rad" in col:
            ang.append(col[c + "_rad"])
        else:
            sys.exit(f"{path}: no column {c}_deg or {c}_rad; fix: name the angle columns with units")
    y = col[channel]
    keep = (np.cos(ang[0]) > 0) & (np.cos(ang[2]) > 0) & np.isfinite(y) & (y >= 0)
    return [v[keep] for v in ang], y[keep]


def geometry(model, ti, pi_, to, po):
    """Parameter-free per-sample terms the model needs (dtype of the angles: float64 or long double)."""
    dt = ti.dtype
    L = np.stack([np.sin(ti) * np.cos(pi_), np.sin(ti) * np.sin(pi_), np.cos(ti)], -1)
    E = np.stack([np.sin(to) * np.cos(po), np.sin(to) * np.sin(po), np.cos(to)], -1)
    nl, ne = L[:, 2], E[:, 2]
    g = {"pi": dt.type(LONG_PI), "nl": nl}
    if model == "lambert":
        return g
    if model == "phong":
        R = 2 * nl[:, None] * np.array([0, 0, 1], dtype=dt) - L
        re = np.sum(R * E, 1)
        g["x"] = np.where(re > 0, re, 0)
        g["lnx"] = np.log(np.where(re > 0, re, 1))
        return g
    H = L + E
    H /= np.sqrt(np.sum(H * H, 1))[:, None]
    nh, eh = H[:, 2], np.sum(E * H, 1)
    if model == "blinn-phong":
        g["x"] = nh
        g["lnx"] = np.log(nh)
        return g
    g["eh"] = eh
    if model.startswith("ts-"):
        G = np.minimum(1, np.minimum(2 * nh * ne / eh, 2 * nh * nl / eh))
        g["k"] = G / (g["pi"] * nl * ne)
        if model == "ts-d1":
            g["nh"], g["lnnh"] = nh, np.log(nh)
        elif model == "ts-d2":
            g["a2"] = np.arccos(np.minimum(nh, 1)) ** 2
        elif model == "ts-d3":
            g["x"] = nh * nh
        else:
            g["w"] = 1 - nh
        return g
    # GGX–Smith: tan² of θh, θi, θo and 1/(4 N·L N·E).
    g["t2h"] = (1 - nh * nh) / (nh * nh)
    g["inv_nh4"] = 1 / (nh * nh * nh * nh)
    g["t2l"] = (1 - nl * nl) / (nl * nl)
    g["t2e"] = (1 - ne * ne) / (ne * ne)
    g["k"] = 1 / (4 * nl * ne)
    return g


def fresnel(n, c):
    """Exact unpolarised Fresnel reflectance (Blinn 1977, with the factor ½) and dF/dn."""
    g = np.sqrt(n * n + c * c - 1)
    A = ((g - c) / (g + c)) ** 2
    u, v = c * (g + c) - 1, c * (g - c) + 1
    B = (u / v) ** 2
    F = A * (1 + B) / 2
    # dA/dg = 4c(g−c)/(g+c)³; dB/dg = 4c(1−c²)u/v³ (v − u = 2 − 2c²); dg/dn = n/g.
    dA = 4 * c * (g - c) / (g + c) ** 3
    dB = 4 * c * (1 - c * c) * u / v ** 3
    return F, (dA * (1 + B) + A * dB) / 2 * n / g


def ggx_lobe(alpha, g):
    """D G1(L) G1(E) / (4 N·L N·E) (Walter et al. 2007, eqs. 33–34) and its derivative in α."""
    a2 = alpha * alpha
    q = a2 + g["t2h"]
    D = a2 * g["inv_nh4"] / (g["pi"] * q * q)
    dD = D * (2 / alpha - 4 * alpha / q)
    sl, se = np.sqrt(1 + a2 * g["t2l"]), np.sqrt(1 + a2 * g["t2e"])
    Gl, Ge = 2 / (1 + sl), 2 / (1 + se)
    # dG1/dα = −2/(1 + s)² · α tan²θ / s.
    dGl = -2 / (1 + sl) ** 2 * alpha * g["t2l"] / sl
    dGe = -2 / (1 + se) ** 2 * alpha * g["t2e"] / se
    return D * Gl * Ge * g["k"], (dD * Gl * Ge + D * (dGl * Ge + Gl * dGe)) * g["k"]


def brdf(model, g, p, want_grad=False):
    """f_r at parameters p (declared order) and, if asked, df/dθ for each parameter (list)."""
    pi = g["pi"]
    if model == "lambert":
        (pd,) = p
        f = pd / pi + 0 * g["nl"]
        return f, [np.full_like(f, 1 / pi)] if want_grad else None
    if model in ("phong", "blinn-phong"):
        c1, ps, pd = p
        w = 1 / (pi * g["nl"])
        s = np.where(g["x"] > 0, g["x"] ** c1, 0)
        f = pd / pi + ps * s * w
        if not want_grad:
            return f, None
        return f, [ps * s * g["lnx"] * w, s * w, np.full_like(f, 1 / pi)]
    if model.startswith("ts-"):
        n, *shape, ps, pd = p
        if model == "ts-d1":
            D = g["nh"] ** shape[0]
            dD = [D * g["lnnh"]]
        elif model == "ts-d2":
            c2 = shape[0]
            D = np.exp(-(c2 * c2) * g["a2"])
            dD = [-2 * c2 * g["a2"] * D]
        elif model == "ts-d3":
            s = shape[0] ** 2
            den = g["x"] * (s - 1) + 1
            D = (s / den) ** 2
            dD = [4 * shape[0] ** 3 * (1 - g["x"]) / den ** 3]
        else:
            b, c = shape
            u = 1 + b * g["w"]
            D = u ** -c
            dD = [-c * g["w"] * D / u, -np.log(u) * D]
        F, dF = fresnel(n, g["eh"])
        k = g["k"]
        f = pd / pi + ps * D * F * k
        if not want_grad:
            return f, None
        return f, [ps * D * dF * k] + [ps * d * F * k for d in dD] + [D * F * k,
                                                                   np.full_like(f, 1 / pi)]
    if model == "ggx-smith":
        alpha, n, ps, pd = p
        S, dS = ggx_lobe(alpha, g)
        F, dF = fresnel(n, g["eh"])
        f = pd / pi + ps * F * S
        if not want_grad:
            return f, None
        return f, [ps * F * dS, ps * dF * S, F * S, np.full_like(f, 1 / pi)]
    a1, ps1, a2, ps2, n, pd = p
    S1, dS1 = ggx_lobe(a1, g)
    S2, dS2 = ggx_lobe(a2, g)
    F, dF = fresnel(n, g["eh"])
    f = pd / pi + F * (ps1 * S1 + ps2 * S2)
    if not want_grad:
        return f, None
    return f, [ps1 * F * dS1, F * S1, ps2 * F * dS2, F * S2, dF * (ps1 * S1 + ps2 * S2),
               np.full_like(f, 1 / pi)]


def to_params(model, u):
    """Parameters θ from solver variables u, and dθ/du."""
    th, d = [], []
    for (_, kind), v in zip(MODELS[model][0], u):
        if kind == "log":
            th.append(np.exp(v)); d.append(np.exp(v))
        elif kind == "log1":
            th.append(1 + np.exp(v)); d.append(np.exp(v))
        else:
            th.append(v); d.append(1.0)
    return th, d


def to_vars(model, theta):
    """Solver variables u of parameters θ."""
    out = []
    for (name, kind), v in zip(MODELS[model][0], theta):
        if (kind == "log" and v <= 0) or (kind == "log1" and v <= 1):
            sys.exit(f"--start: {name} = {v} is outside the model's domain; fix: {name} > "
                     f"{0 if kind == 'log' else 1}")
        out.append(np.log(v) if kind == "log" else np.log(v - 1) if kind == "log1" else v)
    return np.array(out, dtype=float)


def residual(model, g, target, p, loss="log"):
    """r at parameters p: ln(1 + cosθi f) − target (log) or f − target (linear)."""
    f = brdf(model, g, p)[0]
    return np.log1p(g["nl"] * f) - target if loss == "log" else f - target


def problem(model, g, y, loss):
    """Residual and Jacobian functions of the solver variables."""
    target = np.log1p(g["nl"] * y) if loss == "log" else y

    def res(u):
        return residual(model, g, target, to_params(model, u)[0], loss)

    def jac(u):
        th, d = to_params(model, u)
        f, df = brdf(model, g, th, want_grad=True)
        J = np.stack([dfi * di for dfi, di in zip(df, d)], 1)
        if loss == "log":
            J *= (g["nl"] / (1 + g["nl"] * f))[:, None]
        return J

    return res, jac


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("data")
    ap.add_argument("--model", required=True, choices=list(MODELS))
    ap.add_argument("--loss", default="log", choices=["log", "linear"])
    ap.add_argument("--start", help="NAME=VALUE,... (every parameter)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--channel", default="brdf")
    ap.add_argument("--check-jac", action="store_true",
                    help="compare the Jacobian with central differences at the start, then exit")
    a = ap.parse_args()
    # A trial point far out (n → 1e8 on the Fresnel plateau) overflows harmlessly: its cost is
    # then inf or nan and MINPACK rejects it.
    np.seterr(all="ignore")
    names = [nm for nm, _ in MODELS[a.model][0]]
    start = dict(kv.split("=") for kv in a.start.split(",")) if a.start else {}
    if set(start) != set(names):
        sys.exit(f"--start: {a.model} takes {', '.join(names)}; fix: give each once, NAME=VALUE")
    x0 = to_vars(a.model, [float(start[nm]) for nm in names])
    ang, y = load(a.data, a.channel)

    if a.check_jac:
        res, jac = problem(a.model, geometry(a.model, *ang), y, a.loss)
        J = jac(x0)
        worst = 0.0
        for j in range(len(x0)):
            h = 1e-6 * max(1.0, abs(x0[j]))
            e = np.zeros_like(x0); e[j] = h
            fd = (res(x0 + e) - res(x0 - e)) / (2 * h)
            err = np.max(np.abs(fd - J[:, j])) / max(np.max(np.abs(fd)), 1e-300)
            print(f"{names[j]}: max |analytic − central difference| / max |column| = {err:.2e}")
            worst = max(worst, err)
        sys.exit(0 if worst < 1e-5 else 1)

    def run():
        t0 = time.perf_counter()
        # The parameter-free per-sample terms and the data's side of r, computed once per fit.
        res, jac = problem(a.model, geometry(a.model, *ang), y, a.loss)
        t1 = t2 = time.perf_counter()
        r = least_squares(res, x0, jac=jac, method="lm", xtol=1e-10, ftol=1e-10, gtol=1e-10)
        return r, time.perf_counter() - t2, t1 - t0

    times, geo, r = [], [], None
    for _ in range(max(1, a.repeat)):
        r, t, tg = run()
        times.append(t)
        geo.append(tg)
    theta = to_params(a.model, r.x)[0]
    print(json.dumps({"peer": "scipy.optimize.least_squares(method='lm')", "model": a.model,
                      "loss": a.loss, "params": {nm: float(v) for nm, v in zip(names, theta)},
                      "cost": float(r.cost), "nfev": int(r.nfev), "status": int(r.status),
                      "samples": int(y.size), "seconds": statistics.median(times),
                      "geometry_seconds": statistics.median(geo)}))


if __name__ == "__main__":
    main()

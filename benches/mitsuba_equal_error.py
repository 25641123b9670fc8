#!/usr/bin/env python3
"""brdfit's Whitted renderer against Mitsuba 3 at equal image error: one scene, one shared
reference, both programs timed in the same run.

Scene: data/scenes/mitsuba-front.toml (or -edge) for brdfit; for Mitsuba the same scene built by
blinn_whitted.py in the folder PEERS names (Blinn's Torrance–Sparrow plugin + Whitted integrator),
with three changes so both render the *same* picture: the aluminium sphere gets brdfit's real
index n = 200 instead of Mitsuba's complex 'Al' index, its mirror ray the constant weight
ks = 0.5 of Whitted's equation (the plugin multiplies by F(N·E)), and the floor brdfit's
checker phase (world-space squares). Before timing anything the
script checks the two converged images agree (RMSE between brdfit's stratified 32×32 render and Mitsuba's
high-spp render), so the comparison is of speed, not of different pictures.

Error: RMSE of linear RGB over all pixels against Mitsuba's high-spp render (stratified, box
filter = the pixel-area average; brdfit's stratified 32×32 render converges to the same).
Times: Mitsuba = mi.render + sync, median of runs after a warm-up (JIT compiled once, as its own
bench does); brdfit = the render time it reports (in-process, without scene parsing or writing),
median of runs. Both on THREADS threads (default 2). For each Mitsuba sample count, brdfit's time
at the same error is interpolated (log-log) on the time/error front of all its settings (none,
uniform and stratified n×n, adaptive threshold/level/block/jitter); the ratio is printed.

usage: PEERS=/path/to/mitsuba-plugins THREADS=2 PYTHON benches/mitsuba_equal_error.py \
           [front|edge] [--ref-spp N] [--runs N]
needs: PEERS (no default: the folder of blinn_whitted.py); pip install mitsuba numpy;
llvm_ad_rgb needs LLVM ≥ 19 (DRJIT_LIBLLVM_PATH).
"""
import json, math, os, re, statistics, subprocess, sys, tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
PEERS = os.environ.get("PEERS", "")
if not PEERS or not os.path.isfile(os.path.join(PEERS, "blinn_whitted.py")):
    sys.exit("PEERS must name the folder of blinn_whitted.py (the Mitsuba Blinn/Whitted plugins); "
             f"got {PEERS!r}. fix: PEERS=/path/to/mitsuba-plugins")
BRDFIT = os.environ.get("BRDFIT", os.path.join(ROOT, "target", "release", "brdfit"))
THREADS = int(os.environ.setdefault("THREADS", "2"))

args = sys.argv[1:]
light = args[0] if args and not args[0].startswith("--") else "front"
def opt(name, default):
    return int(args[args.index(name) + 1]) if name in args else default
REF_SPP = opt("--ref-spp", 4096)
RUNS = opt("--runs", 5)

sys.path.insert(0, PEERS)
import numpy as np  # noqa: E402
import blinn_whitted as bw  # noqa: E402  (sets the variant and the thread count)
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402


class ConstantMirror(bw.BlinnTS):
    """The peer plugin with Whitted's constant mirror weight ks (no Fresnel factor)."""

    def sample(self, ctx, si, sample1, sample2, active=True):
        bs, _ = super().sample(ctx, si, sample1, sample2, active)
        ok = mi.Bool(active) & (mi.Frame3f.cos_theta(si.wi) > 0) & (self.kr > 0)
        return bs, dr.select(ok, mi.Color3f(self.kr), 0.0)


class WorldChecker(mi.Texture):
    """brdfit's checker: colour0 where ⌊x⌋ + ⌊z⌋ is even on the floor (world units, 1-unit
    squares); Mitsuba's own checkerboard texture has another phase and a seam at x = 0."""

    def __init__(self, props):
        mi.Texture.__init__(self, props)

    def eval(self, si, active=True):
        k = dr.floor(si.p.x) + dr.floor(si.p.z)
        odd = (k - 2.0 * dr.floor(0.5 * k)) > 0.5
        return mi.Color3f(dr.select(odd, 0.8 / math.pi, 0.2 / math.pi))

    def traverse(self, callback):
        pass


mi.register_bsdf("blinn_ts_kr", lambda p: ConstantMirror(p))
mi.register_texture("world_checker", lambda p: WorldChecker(p))
bw.FLOOR["kd"] = {"type": "world_checker"}
bw.AL.update(type="blinn_ts_kr", eta_r=200.0, eta_g=200.0, eta_b=200.0, k_r=0.0, k_g=0.0, k_b=0.0)


def rmse(a, b):
    d = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    return float(np.sqrt(np.mean(d * d)))


def mitsuba(spp, runs):
    scene = bw.make_scene(spp, light, "ts", 4)
    img = mi.render(scene, spp=spp, seed=1)  # warm-up: JIT compilation
    dr.eval(img); dr.sync_thread()
    times = []
    for i in range(runs):
        t = __import__("time").perf_counter()
        img = mi.render(scene, spp=spp, seed=100 + i)
        dr.eval(img); dr.sync_thread()
        times.append(__import__("time").perf_counter() - t)
    return np.array(img)[:, :, :3], statistics.median(times)


def brdfit(aa, runs, tmp):
    base = open(os.path.join(ROOT, "data", "scenes", f"mitsuba-{light}.toml")).read()
    toml = re.sub(r"\[antialias\][^\[]*", "[antialias]\n" + aa + "\n\n", base, count=1)
    path = os.path.join(tmp, "scene.toml")
    open(path, "w").write(toml)
    times = []
    for _ in range(runs):
        r = subprocess.run([BRDFIT, "render", path, "-o", os.path.join(tmp, "img.png")],
                           capture_output=True, text=True, check=True,
                           env=dict(os.environ, RAYON_NUM_THREADS=str(THREADS)))
        m = re.search(r"in ([0-9.]+) s: ([0-9.]+) primary", r.stderr)
        times.append(float(m.group(1)))
    b = mi.Bitmap(os.path.join(tmp, "img.exr"))
    return np.array(b, dtype=np.float64)[:, :, :3], statistics.median(times), float(m.group(2))


def front(points):
    """The Pareto front of (time, error) points: faster or more accurate than every other."""
    out = []
    for t, e in sorted(points):
        if not out or e < out[-1][1]:
            out.append((t, e))
    return out


def interpolate(curve, err):
    """Time at which a (time, error) front reaches `err`, log-log between bracketing points."""
    pts = front(curve)
    if pts and pts[0][1] <= err:
        return pts[0][0]
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e1 <= err <= e0:
            w = (math.log(err) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + w * (math.log(t1) - math.log(t0)))
    return None


def main():
    with tempfile.TemporaryDirectory() as tmp:
        ref, t_ref = mitsuba(REF_SPP, 1)
        own_ref, t_own, _ = brdfit('mode = "stratified"\nsamples = 32', 1, tmp)
        print(json.dumps(dict(scene=light, threads=THREADS, reference=f"mitsuba {REF_SPP} spp",
                              reference_seconds=round(t_ref, 2),
                              rmse_brdfit_stratified_32x32_vs_reference=rmse(own_ref, ref),
                              max_abs_diff=float(np.max(np.abs(own_ref - ref))))))
        peer = []
        for spp in [1, 4, 16, 64, 256]:
            img, t = mitsuba(spp, RUNS)
            peer.append((t, rmse(img, ref)))
            print(json.dumps(dict(program="mitsuba llvm_ad_rgb", spp=spp, seconds=round(t, 4),
                                  rmse=peer[-1][1])))
        ours = []
        settings = ['mode = "none"'] + [
            f'mode = "{m}"\nsamples = {n}' for m, ns in [("uniform", (2, 4)), ("stratified", (2, 4, 8))]
            for n in ns] + [
            f'mode = "adaptive"\nthreshold = {th}\nmax_level = {lv}\nblock = {b}\njitter = {j}'
            for b in (1, 2, 4)
            for th, lv in [(0.1, 0), (0.05, 1), (0.05, 2), (0.02, 3), (0.02, 4), (0.01, 4), (0.005, 5)]
            for j in ("false", "true") if lv >= 2 or j == "false"]
        for aa in settings:
            img, t, rpp = brdfit(aa, RUNS, tmp)
            e = rmse(img, ref)
            print(json.dumps(dict(program="brdfit", antialias=aa.replace("\n", " "), seconds=round(t, 4),
                                  primary_per_pixel=rpp, rmse=e)))
            ours.append((t, e))
        floor = rmse(own_ref, ref)
        print(f"equal error: brdfit's fastest setting (time interpolated on its time/error front) at the "
              f"error of each Mitsuba render; errors below ~3x the disagreement of the two converged "
              f"images ({floor:.1e}) are not resolved by this reference:")
        for (t, e), spp in zip(peer, [1, 4, 16, 64, 256]):
            tb = interpolate(ours, e)
            note = "" if e >= 3 * floor else "  (below the reference's resolution)"
            if tb is None:
                print(f"  mitsuba {spp:>3} spp: rmse {e:.2e} in {t:.4f} s; brdfit does not reach it{note}")
            else:
                print(f"  mitsuba {spp:>3} spp: rmse {e:.2e} in {t:.4f} s; brdfit {tb:.4f} s; "
                      f"ratio {t / tb:.2f}x{note}")


if __name__ == "__main__":
    main()

"""Makes the ꟻLIP test pairs and their reference values with NVIDIA's flip-evaluator.

Run once (python3 with numpy, pillow and flip-evaluator 1.7 from PyPI):
    python3 make_pairs.py > reference.csv
The Rust test (tests/it/choose.rs) compares brdfit's ꟻLIP with reference.csv.
"""
import numpy as np
from PIL import Image
import flip_evaluator as flip

n = 96
y, x = np.mgrid[0:n, 0:n] + 0.5
u, v = (x - n / 2) / (0.4 * n), (y - n / 2) / (0.4 * n)
r2 = u * u + v * v
inside = r2 < 1
nz = np.sqrt(np.clip(1 - r2, 0, 1))
lam = np.where(inside, 0.7 * nz, 0.0)
hl = np.where(inside, 0.6 * np.clip(nz * 0.8 + u * 0.3 + v * 0.5, 0, 1) ** 40, 0.0)


def srgb(c):
    c = np.clip(c, 0, 1)
    e = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    return (e * 255 + 0.5).astype(np.uint8)


def grey(a):
    return np.repeat(a[:, :, None], 3, axis=2)


rng = np.random.default_rng(7)
noise = rng.random((n, n, 3))
pairs = {
    "brighter": (grey(lam + hl), grey(1.1 * (lam + hl))),
    "highlight": (grey(lam + hl), grey(lam)),
    "colour": (noise * grey(lam + 0.3), np.roll(noise, 1, axis=1) * grey(lam + 0.3)),
}
print("pair,mean,p99,max")
for name, (a, b) in pairs.items():
    a8, b8 = srgb(a), srgb(b)
    Image.fromarray(a8).save(f"{name}-ref.png")
    Image.fromarray(b8).save(f"{name}-test.png")
    err, mean, _ = flip.evaluate(a8 / 255.0, b8 / 255.0, "LDR", applyMagma=False,
                                 parameters={"ppd": 67.0})
    e = np.sort(err.reshape(-1))
    p99 = e[int(np.ceil(0.99 * e.size)) - 1]
    print(f"{name},{mean:.6f},{p99:.6f},{e[-1]:.6f}")

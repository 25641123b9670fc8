"""brdfit from Python: fit reflection models to measured reflectance with numpy arrays in and out.

The work is done by brdfit's Rust library (the same code as the ``brdfit`` command line), with the
GIL released while it loads, fits, simulates, chooses and renders. Angles are in radians; errors
raise :class:`BrdfitError` with the command line's message (the file, the line and the fix).

>>> import brdfit
>>> data = brdfit.load("data/blinn-mgo.csv")
>>> result = brdfit.fit(data, model="torrance-sparrow", verify=4)
>>> result.params["n"], result.stderr["n"], result.usable
"""

from __future__ import annotations

import json
import os
import warnings as _warnings
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _brdfit
from ._brdfit import BrdfitError, Dataset, FitResult

__version__ = _brdfit.__version__

__all__ = [
    "BrdfitError",
    "Dataset",
    "FitResult",
    "load",
    "from_arrays",
    "fit",
    "fit_all",
    "eval",
    "simulate",
    "choose",
    "render",
    "export",
    "to_json",
    "read_fits",
    "model_names",
    "nbrdf_materials",
    "keep_freed_memory",
]

PathLike = Union[str, "os.PathLike[str]"]


def _warn(data: Dataset) -> Dataset:
    for w in data.warnings:
        _warnings.warn(w, stacklevel=3)
    return data


def load(
    path: PathLike,
    channel: Optional[str] = None,
    format: Optional[str] = None,
    negative: str = "mask",
) -> Dataset:
    """Read a data file: brdfit CSV, ASTM E1392, Cornell spectral text or MERL ``.binary``.

    ``channel`` reduces it to one channel (a name such as ``g`` or ``550nm``, an index, a
    wavelength, or ``cie-y``); ``format`` forces ``csv|astm|cornell|merl``; ``negative`` says
    what to do with negative values (``mask``, ``clamp`` or ``error``). The loader's warnings
    are issued as Python warnings.
    """
    return _warn(_brdfit.load(os.fspath(path), channel, format, negative))


def from_arrays(
    directions: Any,
    values: Any,
    channels: Optional[Sequence[str]] = None,
    quantity: str = "brdf",
    weights: Any = None,
    negative: str = "mask",
) -> Dataset:
    """A data set from arrays: ``directions`` (N, 4) of (θi, φi, θo, φo) in radians and
    ``values`` (N,) or (N, C) of f_r (or ``quantity`` ``brdf_cos``, ``rfactor``), validated as
    a file's rows are. ``channels`` names the columns (default ``brdf`` for one, else
    ``c0``, ``c1``, …)."""
    d = np.asarray(directions, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    if v.ndim == 1:
        v = v.reshape(-1, 1)
    if d.ndim != 2 or v.ndim != 2:
        raise BrdfitError(
            "directions must be (N, 4) and values (N,) or (N, C)\n"
            "  fix: give one row (θi, φi, θo, φo) in radians per sample"
        )
    if channels is None:
        channels = ["brdf"] if v.shape[1] == 1 else [f"c{k}" for k in range(v.shape[1])]
    w = None if weights is None else np.asarray(weights, dtype=np.float64)
    return _brdfit.from_arrays(d, v, list(channels), quantity, w, negative)


def _dataset(data: Any) -> Dataset:
    if isinstance(data, Dataset):
        return data
    if isinstance(data, (str, os.PathLike)):
        return load(data)
    if isinstance(data, tuple) and len(data) == 2:
        return from_arrays(*data)
    raise TypeError(
        "data must be a brdfit.Dataset, a path, or a tuple (directions (N, 4), values (N,) or (N, C))"
    )


def _pairs(d: Optional[Mapping[str, float]]) -> List[Tuple[str, float]]:
    return [] if d is None else [(str(k), float(v)) for k, v in d.items()]


def _fit(data: Any, model: str, **kw: Any) -> List[List[FitResult]]:
    return _brdfit.fit(
        _dataset(data),
        model,
        kw.get("distribution", "d3"),
        kw.get("loss", "log"),
        kw.get("method", "lm"),
        kw.get("robust"),
        kw.get("max_theta"),
        kw.get("weights", "file"),
        _pairs(kw.get("fix")),
        _pairs(kw.get("start")),
        list(kw.get("shared") or []),
        bool(kw.get("local_only", False)),
        float(kw.get("resolution", 1e-6)),
        int(kw.get("verify", 0)),
        int(kw.get("verify_seed", 1)),
        kw.get("fast_pow"),
    )


_FIT_OPTIONS = {
    "distribution",
    "loss",
    "method",
    "robust",
    "max_theta",
    "weights",
    "fix",
    "start",
    "shared",
    "local_only",
    "resolution",
    "verify",
    "verify_seed",
    "fast_pow",
}


def _check(kw: Mapping[str, Any]) -> None:
    unknown = sorted(set(kw) - _FIT_OPTIONS)
    if unknown:
        raise TypeError(f"unknown fit option(s) {', '.join(unknown)}; options: {', '.join(sorted(_FIT_OPTIONS))}")


def fit(
    data: Any, model: str = "torrance-sparrow", **options: Any
) -> Union[FitResult, List[FitResult]]:
    """Fit ``model`` to every channel of ``data`` (a Dataset, a path, or a tuple
    ``(directions, values)``), as ``brdfit fit`` does: one :class:`FitResult` for one channel
    (or a joint fit with ``shared``), else a list, one per channel. ``model="all"`` is
    :func:`fit_all`.

    Options, named as the command line's flags: ``distribution`` (d1, d2, d3, abc), ``loss``
    (log, linear), ``method`` (lm, gn, nm, …), ``robust`` (huber, cauchy), ``max_theta``
    (degrees), ``weights`` (file, solid-angle), ``fix`` and ``start`` (dicts name → value),
    ``shared`` (names fitted jointly across channels), ``local_only``, ``resolution``,
    ``verify`` (random starts that must not end lower), ``verify_seed``, ``fast_pow``.
    """
    _check(options)
    if model == "all":
        return fit_all(data, **options)
    fits = _fit(data, model, **options)[0]
    return fits[0] if len(fits) == 1 else fits


def fit_all(data: Any, **options: Any) -> List[FitResult]:
    """Every model, as ``brdfit fit --model all``: a flat list, each model's fits (one per
    channel) in turn, in the order of the command line's JSON; rank them by ``bic``."""
    _check(options)
    return [r for fits in _fit(data, "all", **options) for r in fits]


def eval(
    model: str,
    params: Mapping[str, float],
    directions: Any,
    distribution: Optional[str] = None,
) -> np.ndarray:
    """f_r of ``model`` with ``params`` (a dict) at ``directions`` (N, 4) of (θi, φi, θo, φo)
    in radians: an (N,) array. A C-contiguous float64 array is read in place."""
    d = np.asarray(directions, dtype=np.float64)
    if d.ndim == 1 and d.shape[0] == 4:
        d = d.reshape(1, 4)
    return _brdfit.eval(model, _pairs(params), d, distribution)


def simulate(
    model: Optional[str] = None,
    params: Optional[Mapping[str, float]] = None,
    grid: str = "hemisphere:10000",
    directions: Any = None,
    distribution: str = "d3",
    noise: float = 0.0,
    seed: int = 1,
    nbrdf: Optional[PathLike] = None,
    material: Optional[str] = None,
    symmetric: bool = False,
) -> Dataset:
    """Synthetic samples, as ``brdfit simulate``: of ``model`` with ``params`` and
    multiplicative Gaussian noise ``v(1 + noise ε)``, or of the Neural-BRDF network
    ``material`` of the weights file ``nbrdf`` (RGB; ``symmetric`` makes it reciprocal and
    mirror-symmetric). ``grid`` is ``hemisphere:N``, ``plane:θ1,θ2`` (degrees),
    ``goniometer`` or ``merl``; ``directions`` (N, 4) in radians replaces it."""
    d = None if directions is None else np.asarray(directions, dtype=np.float64)
    return _brdfit.simulate(
        model,
        _pairs(params),
        grid,
        d,
        distribution,
        float(noise),
        int(seed),
        None if nbrdf is None else os.fspath(nbrdf),
        material,
        bool(symmetric),
    )


def choose(
    data: Any,
    scene: str = "fig7",
    threshold: str = "flip_p99=0.05",
    res: int = 512,
    verify: int = 4,
    allow_large_image: bool = False,
    output: Optional[PathLike] = None,
) -> Dict[str, Any]:
    """Which model a scene needs, as ``brdfit choose``: the structure of ``choose.json`` (a
    dict). ``scene`` is ``fig7`` or a scene TOML file; ``threshold`` is ``METRIC=VALUE`` with
    METRIC one of flip_mean, flip_p99, delta_e_itp_mean, delta_e_itp_p99, rmse. One channel
    is judged: CIE Y of spectral data, green of RGB (select another first). With ``output``
    the command's files (renders, sheets, charts, choose.json, choose.md) are written there
    too."""
    metric, sep, value = str(threshold).partition("=")
    try:
        v = float(value) if sep else float("nan")
    except ValueError:
        v = float("nan")
    if not sep or not np.isfinite(v) or v < 0:
        raise BrdfitError(
            f"threshold '{threshold}' is not METRIC=VALUE with a value ≥ 0\n"
            "  fix: e.g. threshold=\"flip_p99=0.05\""
        )
    text, _written = _brdfit.choose(
        _dataset(data),
        scene,
        metric,
        v,
        int(res),
        int(verify),
        bool(allow_large_image),
        None if output is None else os.fspath(output),
    )
    return json.loads(text)


def render(scene: PathLike, allow_large_image: bool = False) -> np.ndarray:
    """Render a scene file (TOML) with Whitted's ray tracer, as ``brdfit render``: linear RGB
    radiance, a float32 array of shape (height, width, 3). The scene's warnings are issued as
    Python warnings."""
    image, notes = _brdfit.render(os.fspath(scene), bool(allow_large_image))
    for n in notes:
        if n.startswith("warning: "):
            _warnings.warn(n[len("warning: "):], stacklevel=2)
    return image


def export(
    fits: Union[FitResult, Iterable[FitResult]],
    to: str = "mitsuba",
    model: Optional[str] = None,
    distribution: Optional[str] = None,
    channel: Optional[str] = None,
    allow_unusable: bool = False,
    id: str = "brdfit",
) -> str:
    """A fitted material for another renderer, as ``brdfit export`` prints it: ``mitsuba``
    (Mitsuba 3 BSDF XML; Torrance–Sparrow is refitted as GGX–Smith, the error stated),
    ``pbrt`` or ``brdf-explorer``. From several fits (``fit_all``, or one per RGB channel)
    the same pick as the command line: the recommended model unless ``model`` is given, every
    RGB channel as colour unless ``channel`` is given."""
    if isinstance(fits, FitResult):
        fits = [fits]
    return _brdfit.export(list(fits), to, model, distribution, channel, bool(allow_unusable), id)


def to_json(fits: Union[FitResult, Iterable[FitResult]]) -> str:
    """The fit JSON ``brdfit fit --json`` writes for these fits: one fit as its object,
    several under ``fits``."""
    if isinstance(fits, FitResult):
        return fits.to_json()
    return _brdfit.fits_json(list(fits))


def read_fits(path_or_text: Union[PathLike, str]) -> List[FitResult]:
    """Every fit of a fit JSON file (or of its text, when it starts with ``{``)."""
    s = os.fspath(path_or_text)
    if s.lstrip().startswith("{"):
        return _brdfit.read_fits(s)
    with open(s, encoding="utf-8") as f:
        text = f.read()
    try:
        return _brdfit.read_fits(text)
    except BrdfitError as e:
        raise BrdfitError(f"{s}: {e}") from None


def model_names() -> List[Tuple[str, str]]:
    """The (model, distribution) pairs ``fit_all`` fits, in order."""
    return _brdfit.model_names()


def nbrdf_materials(path: PathLike) -> List[str]:
    """The network names in a Neural-BRDF weights file (e.g. ``merl/steel``), in file order."""
    return _brdfit.nbrdf_materials(os.fspath(path))


def keep_freed_memory() -> None:
    """Tell the C allocator (glibc) to keep freed memory for reuse, as the ``brdfit`` program
    does at its start: repeated fits then reuse pages already touched instead of faulting in
    fresh ones. It changes the allocator of the whole process (freed memory is not handed back
    to the system while it runs), so call it in processes that do mostly fitting, such as Dask
    workers. Elsewhere than glibc it does nothing."""
    _brdfit.keep_freed_memory()


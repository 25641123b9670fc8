#!/usr/bin/env python3
"""Fit a whole database of materials on a Dask cluster: one task per material.

Each material is a Neural-BRDF network of a weights file (sampled on the goniometer grid, as a
goniometer would measure it) or a data file. Each task fits every model to every channel, with
``verify`` random starts as a certificate, and returns its rows and its fit JSON; the script
gathers them in input order and writes one table (CSV, and Parquet when pyarrow is installed),
the fit JSON of each material, and the tasks' times. A material that fails is reported (in
``failed.csv`` and on stderr), not fatal. ``--choose`` runs ``brdfit.choose`` for every
material and scene in the same way (one task per pair).

    python examples/fit_database.py --weights nbrdf_weights.json -o fitted           # LocalCluster
    python examples/fit_database.py --weights W.json --scheduler tcp://host:8786 -o fitted
    python examples/fit_database.py data/*.csv --serial -o fitted                      # no Dask

Outputs in ``-o DIR``: ``fits.csv`` (one row per material, channel and model; no times, so the
same inputs give the same bytes), ``fits.parquet``, ``fits/<material>.json`` (the command line's
fit JSON), ``times.csv`` (seconds per task), ``failed.csv``; with ``--choose``:
``choose.csv`` and ``choose/<material>--<scene>.json``.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import os
import sys
import time
from typing import Any, Dict, List, Optional, Sequence

# The fit table's columns before the parameters; the parameters follow in order of first
# appearance, then AFTER.
BEFORE = ["material", "channel", "model", "distribution"]
AFTER = ["cost", "rmse", "bic", "n_free", "samples_used", "usable", "verified", "flags", "unusable"]


def material_data(source: Dict[str, Any], grid: str):
    """The samples of one material: a network sampled on `grid`, or a data file."""
    import brdfit

    # A process that does mostly fitting: freed memory kept for the next fit, as the command
    # line keeps it.
    brdfit.keep_freed_memory()
    if source["kind"] == "nbrdf":
        return brdfit.simulate(nbrdf=source["weights"], material=source["name"], grid=grid)
    return brdfit.load(source["path"])


def fit_material(source: Dict[str, Any], grid: str, verify: int) -> Dict[str, Any]:
    """One task: every model on every channel of one material. Returns its rows, its fit JSON
    and its time, or the error."""
    import brdfit

    t, cpu = time.perf_counter(), time.process_time()
    try:
        data = material_data(source, grid)
        fits = brdfit.fit_all(data, verify=verify)
        rows = [
            {
                "material": source["name"],
                "channel": r.channel,
                "model": r.model,
                "distribution": r.distribution,
                "params": r.params,
                "cost": r.cost,
                "rmse": r.rmse,
                "bic": r.bic,
                "n_free": r.n_free,
                "samples_used": r.samples_used,
                "usable": r.usable,
                "verified": r.verified,
                "flags": " ".join(r.flags),
                "unusable": "; ".join(r.unusable),
            }
            for r in fits
        ]
        return {
            "name": source["name"],
            "rows": rows,
            "json": brdfit.to_json(fits),
            "seconds": time.perf_counter() - t,
            "cpu_seconds": time.process_time() - cpu,
        }
    except Exception as e:  # reported in failed.csv, not fatal
        return {"name": source["name"], "error": f"{type(e).__name__}: {e}", "seconds": time.perf_counter() - t}


def choose_material(
    source: Dict[str, Any], grid: str, scene: str, res: int, verify: int
) -> Dict[str, Any]:
    """One task: `brdfit.choose` of one material in one scene."""
    import brdfit

    t = time.perf_counter()
    name = f"{source['name']}--{scene_name(scene)}"
    try:
        answer = brdfit.choose(material_data(source, grid), scene=scene, res=res, verify=verify)
        rows = [
            {
                "material": source["name"],
                "scene": scene_name(scene),
                "case": c["case"],
                "verdict": c["verdict"],
                "chosen": c["chosen"] or "",
                "closest": c["closest"],
                "channel": answer["channel"],
            }
            for c in answer["cases"]
        ]
        return {"name": name, "rows": rows, "json": json.dumps(answer, indent=2) + "\n",
                "seconds": time.perf_counter() - t}
    except Exception as e:
        return {"name": name, "error": f"{type(e).__name__}: {e}", "seconds": time.perf_counter() - t}


def scene_name(scene: str) -> str:
    return "fig7" if scene == "fig7" else os.path.splitext(os.path.basename(scene))[0]


def safe(name: str) -> str:
    """A file name for a material (merl/steel → merl-steel)."""
    return "".join(c if c.isalnum() or c in "-_." else "-" for c in name)


def number(v: Any) -> str:
    """A float as Python's shortest round-trip repr (inf and nan as written by float)."""
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else str(v)
    return "" if v is None else str(v)


def fit_table(results: Sequence[Dict[str, Any]]) -> List[Dict[str, str]]:
    """One row per material, channel and model, a column per parameter name."""
    rows = [r for res in results if "rows" in res for r in res["rows"]]
    pnames: List[str] = []
    for r in rows:
        for k in r["params"]:
            if k not in pnames:
                pnames.append(k)
    table = []
    for r in rows:
        row = {k: number(r[k]) for k in BEFORE}
        row.update({k: number(r["params"].get(k)) for k in pnames})
        row.update({k: number(r[k]) for k in AFTER})
        table.append(row)
    return table


def write_atomic(path: str, text: str) -> None:
    """Write to a temporary name and rename, so a crash never leaves half a file."""
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    tmp = f"{path}.tmp-{os.getpid()}"
    with open(tmp, "w", encoding="utf-8", newline="") as f:
        f.write(text)
    os.replace(tmp, path)
    print(f"wrote {path}", file=sys.stderr)


def csv_text(rows: List[Dict[str, str]], columns: Optional[List[str]] = None) -> str:
    buf = io.StringIO()
    cols = columns if columns is not None else (list(rows[0]) if rows else [])
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    return buf.getvalue()


def write_outputs(out: str, stem: str, folder: str, results: Sequence[Dict[str, Any]], table) -> int:
    """The table (CSV, Parquet when pyarrow is there), each task's JSON, times and failures;
    the number of failures."""
    write_atomic(os.path.join(out, f"{stem}.csv"), csv_text(table))
    try:
        import pandas as pd
        import pyarrow  # noqa: F401  (pandas' Parquet engine)

        path = os.path.join(out, f"{stem}.parquet")
        pd.DataFrame(table).to_parquet(path + ".tmp", index=False)
        os.replace(path + ".tmp", path)
        print(f"wrote {path}", file=sys.stderr)
    except ImportError:
        pass
    for res in results:
        if "json" in res:
            write_atomic(os.path.join(out, folder, safe(res["name"]) + ".json"), res["json"])
    # Wall seconds of each task, and the CPU seconds of its process while it ran (every thread
    # of the worker: the fits' and the worker's own).
    times = [
        {"task": r["name"], "seconds": f"{r['seconds']:.3f}", "cpu_seconds": f"{r.get('cpu_seconds', float('nan')):.3f}"}
        for r in results
    ]
    write_atomic(os.path.join(out, f"{stem}-times.csv"), csv_text(times, ["task", "seconds", "cpu_seconds"]))
    failed = [{"task": r["name"], "error": r["error"]} for r in results if "error" in r]
    write_atomic(os.path.join(out, f"{stem}-failed.csv"), csv_text(failed, ["task", "error"]))
    for f in failed:
        print(f"failed: {f['task']}: {f['error']}", file=sys.stderr)
    return len(failed)


def run_tasks(client, fn, items: List[tuple]) -> List[Dict[str, Any]]:
    """`fn(*item)` for each item, on the cluster (one task each) or here in turn; results in
    item order. A task whose worker died is reported as failed."""
    if client is None:
        return [fn(*it) for it in items]
    futures = [client.submit(fn, *it, pure=False) for it in items]
    out = []
    for it, fut in zip(items, futures):
        try:
            out.append(fut.result())
        except Exception as e:  # the worker died or the task could not run
            out.append({"name": it[0]["name"], "error": f"{type(e).__name__}: {e}", "seconds": float("nan")})
    return out


def sources(args) -> List[Dict[str, Any]]:
    import brdfit

    items: List[Dict[str, Any]] = []
    if args.weights:
        names = args.material or brdfit.nbrdf_materials(args.weights)
        names = [n for n in names if n.startswith(args.prefix)]
        if args.limit:
            names = names[: args.limit]
        items += [{"kind": "nbrdf", "weights": args.weights, "name": n} for n in names]
    for p in args.files:
        items.append({"kind": "file", "path": p, "name": os.path.splitext(os.path.basename(p))[0]})
    return items


def client_for(args):
    """A Dask client: the scheduler given, or a LocalCluster of `--workers` processes with one
    task at a time each and `--threads` threads for the fits in each."""
    if args.serial:
        return None, None
    from dask.distributed import Client, LocalCluster

    if args.scheduler:
        return Client(args.scheduler), None
    cluster = LocalCluster(
        n_workers=args.workers,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        env={"RAYON_NUM_THREADS": str(args.threads)},
    )
    return Client(cluster), cluster


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="*", help="data files, one material each")
    ap.add_argument("--weights", help="Neural-BRDF weights file: each network is a material")
    ap.add_argument("--material", action="append", help="only this network (repeat)")
    ap.add_argument("--prefix", default="", help="only networks whose name starts so (e.g. merl/)")
    ap.add_argument("--limit", type=int, help="only the first N networks")
    ap.add_argument("--grid", default="goniometer", help="where networks are sampled (default goniometer)")
    ap.add_argument("--verify", type=int, default=8, help="random starts per fit (default 8)")
    ap.add_argument("--choose", metavar="SCENES", help="also choose, for each scene: fig7,FILE.toml,…")
    ap.add_argument("--choose-res", type=int, default=128, help="fig7 resolution for --choose (default 128)")
    ap.add_argument("--no-fit", action="store_true", help="only --choose")
    ap.add_argument("--scheduler", help="address of a Dask scheduler (default: a LocalCluster)")
    ap.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes (default 2)")
    ap.add_argument("--threads", type=int, default=1, help="threads for the fits in each worker (default 1)")
    ap.add_argument("--serial", action="store_true", help="no Dask: a plain loop in this process")
    ap.add_argument("-o", "--output", default="fitted", help="output folder (default fitted)")
    args = ap.parse_args(argv)
    items = sources(args)
    if not items:
        ap.error("give --weights FILE or data files")
    client, cluster = client_for(args)
    failures = 0
    try:
        t = time.perf_counter()
        if not args.no_fit:
            results = run_tasks(client, fit_material, [(s, args.grid, args.verify) for s in items])
            failures += write_outputs(args.output, "fits", "fits", results, fit_table(results))
            print(f"fitted {len(items)} materials in {time.perf_counter() - t:.1f} s", file=sys.stderr)
        if args.choose:
            scenes = [s for s in args.choose.split(",") if s]
            pairs = [(s, args.grid, sc, args.choose_res, min(args.verify, 4)) for s in items for sc in scenes]
            results = run_tasks(client, choose_material, pairs)
            table = [r for res in results if "rows" in res for r in res["rows"]]
            failures += write_outputs(args.output, "choose", "choose", results, table)
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

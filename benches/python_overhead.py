#!/usr/bin/env python3
"""The cost of calling brdfit from Python: brdfit.fit's wall time per call against the time the
library spends in the fit (FitResult.seconds: geometry, solve and statistics, measured inside
the library), median of N calls on one data set loaded once. The command line's in-process time
of the same fit (`brdfit fit FILE --repeat N`, its `seconds`) is printed beside it when a binary
is given.

    python benches/python_overhead.py data/blinn-mgo.csv 50 [target/release/brdfit]
"""

import json
import statistics
import subprocess
import sys
import tempfile
import time

import brdfit


def main() -> None:
    path = sys.argv[1] if len(sys.argv) > 1 else "data/blinn-mgo.csv"
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 50
    cli = sys.argv[3] if len(sys.argv) > 3 else None
    data = brdfit.load(path)
    brdfit.fit(data)  # warm: the thread pool started, pages touched
    walls, inside = [], []
    for _ in range(n):
        t = time.perf_counter()
        r = brdfit.fit(data)
        walls.append(time.perf_counter() - t)
        inside.append(r.seconds)
    wall, lib = statistics.median(walls), statistics.median(inside)
    print(f"{path}: {len(data)} samples, {r.label}, median of {n} calls")
    print(f"  brdfit.fit wall per call   {1e3 * wall:8.3f} ms")
    print(f"  inside the library         {1e3 * lib:8.3f} ms")
    print(f"  Python's overhead          {1e3 * (wall - lib):8.3f} ms ({100 * (wall - lib) / lib:.1f} %)")
    if cli:
        with tempfile.TemporaryDirectory() as d:
            out = f"{d}/fit.json"
            subprocess.run([cli, "-q", "fit", path, "--repeat", str(n), "--json", out], check=True)
            seconds = json.load(open(out))["seconds"]
        print(f"  command line, in process   {1e3 * seconds:8.3f} ms (fit --repeat {n}: median seconds)")


if __name__ == "__main__":
    main()

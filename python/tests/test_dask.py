"""examples/fit_database.py: the Dask run on the 8 bundled networks writes the same table as a
plain loop, byte for byte, and a material that fails is reported while the others are fitted."""

import csv
import subprocess
import sys

import pytest

pytest.importorskip("dask.distributed")


def run_example(root, out, *args):
    p = subprocess.run(
        [sys.executable, str(root / "examples" / "fit_database.py"), "-o", str(out), *args],
        capture_output=True,
        text=True,
        timeout=1200,
    )
    return p


def test_dask_equals_serial(root, tmp_path):
    weights = str(root / "tests" / "data" / "nbrdf" / "weights-merl8.json")
    missing = str(tmp_path / "missing.csv")
    common = ["--weights", weights, missing, "--verify", "4", "--choose", "fig7", "--choose-res", "64"]
    serial = run_example(root, tmp_path / "serial", *common, "--serial")
    dask = run_example(root, tmp_path / "dask", *common, "--workers", "2")
    for p in (serial, dask):
        assert p.returncode == 1, p.stderr  # one material failed
        assert f"failed: missing: " in p.stderr
    for name in ("fits.csv", "choose.csv", "fits-failed.csv", "choose-failed.csv"):
        a = (tmp_path / "serial" / name).read_bytes()
        assert a == (tmp_path / "dask" / name).read_bytes(), name
    rows = list(csv.DictReader(open(tmp_path / "dask" / "fits.csv")))
    # 8 networks × 3 channels × 9 models.
    assert len(rows) == 8 * 3 * 9
    assert len({r["material"] for r in rows}) == 8
    choose = list(csv.DictReader(open(tmp_path / "dask" / "choose.csv")))
    assert len(choose) == 8 * 2  # fig7: front and edge
    for name in (tmp_path / "serial" / "fits").iterdir():
        assert (tmp_path / "dask" / "fits" / name.name).exists()
    failed = list(csv.DictReader(open(tmp_path / "dask" / "fits-failed.csv")))
    assert [f["task"] for f in failed] == ["missing"]

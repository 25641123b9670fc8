"""Shared fixtures: the repository's root and the command line as the peer program."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="package")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="package")
def cli() -> str:
    """The brdfit binary the Python results are compared with: $BRDFIT_CLI, else the release
    build of this checkout (cargo build --release; cargo test --release builds it too)."""
    path = os.environ.get("BRDFIT_CLI", str(ROOT / "target" / "release" / "brdfit"))
    if not os.access(path, os.X_OK):
        pytest.fail(f"{path}: no brdfit binary to compare with\n  fix: cargo build --release, or set BRDFIT_CLI")
    return path


def run(cli: str, *args: str, check: bool = True) -> subprocess.CompletedProcess:
    """Run the command line quietly; its output as text."""
    p = subprocess.run([cli, "--quiet", *args], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(f"brdfit {' '.join(args)} failed:\n{p.stderr}")
    return p

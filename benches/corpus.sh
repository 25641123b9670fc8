#!/usr/bin/env bash
# The full corpus table: every real data file at every channel (all 31 wavelengths
# of the spectral files) × every model, the default pipeline's cost against the best of 64
# seeded random local starts. CI runs the same test on every 6th wavelength.
set -euo pipefail
cd "$(dirname "$0")/.."
BRDFIT_CORPUS=full cargo test --release --test it corpus:: -- --nocapture

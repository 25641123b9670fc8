#!/usr/bin/env bash
# brdfit's Whitted renderer on the Mitsuba peer scene (data/scenes/mitsuba-front.toml, the
# scene of ../shared/peers/mitsuba/scene.xml), and Mitsuba 3 with the Blinn/Whitted plugins
# where it is installed, in one run.
#
#   PYTHON=/tmp/peers/bin/python benches/compare_mitsuba.sh
#
# brdfit: image error (RMSE on linear values against its own 16×16-supersampled reference)
# against time and rays per pixel, uniform and adaptive anti-aliasing (brdfit study render).
# Mitsuba (pip install mitsuba; llvm_ad_rgb needs LLVM ≥ 19, see ../shared/peers/README.md):
# ../shared/peers/mitsuba/blinn_whitted.py at 16 and 64 spp, 2 threads.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
PEERS=${PEERS:-../shared/peers/mitsuba}
cargo build --release -q
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
echo "== brdfit (2 threads), data/scenes/mitsuba-front.toml, 512×512"
target/release/brdfit study render --scene data/scenes/mitsuba-front.toml -o "$OUT"
if $PYTHON -c "import mitsuba" 2>/dev/null && [ -f "$PEERS/blinn_whitted.py" ]; then
  echo "== Mitsuba 3 (llvm_ad_rgb, Blinn/Whitted plugins, 2 threads)"
  for spp in 16 64; do
    (cd "$PEERS" && THREADS=2 $PYTHON blinn_whitted.py llvm_ad_rgb $spp 5 "$OUT/mitsuba-$spp.png" front ts 4) | tail -1
  done
  echo "Compare the median times above at equal RMSE (Mitsuba's error_vs_ref.py gives its RMSE)."
else
  echo "== Mitsuba 3 is not installed for $PYTHON: only brdfit was measured."
fi

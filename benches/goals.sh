#!/usr/bin/env bash
# brdfit's speed goals, every one measured in one run, for one binary or several side by side
# (say, this checkout's build and a saved build of an earlier version), the binaries
# alternating in each of ROUNDS repetitions so that both see the same minutes of a noisy
# machine:
#
#   scipy 10k, 1M   benches/compare_scipy.sh (TS-d3, default pipeline, REPEAT fits in process,
#                   the peer script PEER as reference where it is given, else
#                   benches/scipy_models.py): total and solve ratios
#   models          `fit data/merl-alumina-oxide.csv --channel g --model M --repeat 31` for
#                   every model: its `seconds` (the median in process) over TS-d3's, same
#                   repetition
#   model all       `fit FILE --channel C --model all --repeat 5` on every channel of both
#                   bundled MERL files (16,512 rows each; a metal's fits take the most steps):
#                   the wall of the nine fits in process, the median of 5 (as `fit` prints it)
#   choose          `choose FILE --scene fig7` on every bundled file, wall
#   report          `report` on data/ (30-40 s a binary a repetition) on a pseudo-terminal of
#                   160 columns, as a user sees it: the wall, and the longest time in which
#                   nothing moved on: no line printed, the bar's percentage and message
#                   unchanged (its clock and estimate ticking do not count; a fit's message
#                   counts its evaluations, so a running fit moves it)
#
#   PYTHON=/tmp/peers/bin/python [PEER=/path/to/scipy_fit.py] [ROUNDS=3] [REPEAT=11]
#     [PARTS="scipy models all choose report"] benches/goals.sh [BIN...] [> LOG]
#
# Without BIN the script builds this checkout and measures that. Every measurement is printed
# as a raw line (`raw BIN PART KEY VALUE`) as it is taken (compare_scipy.sh's tables as
# comments, `# ...`), then the summary: per binary and goal the median over the repetitions, the
# range, and whether the median meets the goal (the ratios against scipy as compare_scipy.sh
# prints them, to 0.1). Any command that fails stops the run with its message. The scipy peer
# needs numpy and scipy for PYTHON (python3 -m venv /tmp/peers && /tmp/peers/bin/pip install
# numpy scipy). Its outputs go to a temporary directory. With MARKDOWN=FILE (for instance
# MARKDOWN=docs/performance.md) it also replaces the part of FILE between the lines
# `<!-- goals.sh begins -->` and `<!-- goals.sh ends -->` with the summary as a Markdown table,
# headed by the machine, the date, the load and the command; nothing else is written.
set -euo pipefail
# The binaries as absolute paths (given relative to where the script was run).
bins=()
for b in "$@"; do
  [ -x "$b" ] || { echo "$b is not an executable; fix: give the path of a built brdfit binary" >&2; exit 2; }
  bins+=("$(realpath "$b")")
done
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
ROUNDS=${ROUNDS:-3}
REPEAT=${REPEAT:-11}
PARTS=${PARTS:-scipy models all choose report}
MARKDOWN=${MARKDOWN:-}
if [ -n "$MARKDOWN" ] && ! grep -q '^<!-- goals.sh begins -->$' "$MARKDOWN" 2>/dev/null; then
  echo "MARKDOWN=$MARKDOWN has no line '<!-- goals.sh begins -->'; fix: add the two marker lines where the table goes" >&2
  exit 2
fi
START_LOAD=$(cut -d' ' -f1-3 /proc/loadavg)
if [ ${#bins[@]} -eq 0 ]; then
  cargo build --release -q
  bins=("$PWD/target/release/brdfit")
fi
if [ -z "${PEER:-}" ]; then
  echo "note: PEER is not set: the scipy ratios are against benches/scipy_models.py (set PEER=/path/to/scipy_fit.py to use another Torrance–Sparrow D3 peer script)" >&2
elif [ ! -f "$PEER" ]; then
  echo "PEER=$PEER is not a file; fix: give the path of a scipy peer script, or leave PEER unset to use benches/scipy_models.py" >&2
  exit 2
fi
has() { case " $PARTS " in *" $1 "*) return 0 ;; *) return 1 ;; esac; }
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
REAL=data/merl-alumina-oxide.csv
MODELS=("torrance-sparrow --distribution d3" "lambert" "torrance-sparrow --distribution d1"
  "torrance-sparrow --distribution d2" "torrance-sparrow --distribution abc" "phong"
  "blinn-phong" "ggx-smith" "ggx-smith-2")
# Wall seconds of a command (its output dropped; its errors shown, and the run stopped, if it
# fails).
wall() {
  local s e
  s=$(date +%s%N)
  "$@" > /dev/null 2> "$TMP/err" || { cat "$TMP/err" >&2; return 1; }
  e=$(date +%s%N)
  awk -v ns=$((e - s)) 'BEGIN { printf "%.4f\n", ns / 1e9 }'
}
# A number of a fit JSON file (one fit, or the first of several).
field() {
  $PYTHON -c "import json,sys; d=json.load(open(sys.argv[1])); d=d[0] if isinstance(d,list) else d; print(d[sys.argv[2]])" "$1" "$2"
}

echo "goals.sh: $(date -u '+%F %T') UTC, load average $(cut -d' ' -f1-3 /proc/loadavg), $(nproc) cores"
for _ in $(seq "$ROUNDS"); do
  for b in "${bins[@]}"; do
    if has scipy; then
      REPEAT=$REPEAT MODELS=ts-d3 REAL='' BRDFIT=$b PYTHON=$PYTHON PEER=${PEER:-} benches/compare_scipy.sh 10000 1000000 \
        > "$TMP/scipy.txt"
      sed 's/^/# /' "$TMP/scipy.txt"
      # "SIZE ts-d3 brdfit default SOLVE STATS GEOMETRY TOTAL OWN COMMON SOLVEx TOTALx ..."
      awk -v b="$b" '$3 == "brdfit" && $4 == "default" {
        sub("x", "", $11); sub("x", "", $12);
        print "raw", b, "scipy", $1 "-total", $12; print "raw", b, "scipy", $1 "-solve", $11;
        print "raw", b, "scipy", $1 "-seconds", $8 }' "$TMP/scipy.txt"
    fi
    if has models; then
      for m in "${MODELS[@]}"; do
        # shellcheck disable=SC2086
        "$b" fit "$REAL" --channel g --model $m --repeat 31 -q --json "$TMP/m.json" > /dev/null
        t=$(field "$TMP/m.json" seconds)
        echo "raw $b models ${m#torrance-sparrow --distribution } $t"
      done
    fi
    if has all; then
      # The wall of the nine fits in process, median of 5 ("9 models fitted in 16.4 ms ...").
      for f in data/merl-*.csv; do
        for c in r g b; do
          out=$("$b" fit "$f" --channel $c --model all --repeat 5 2>&1) || { echo "$out" >&2; exit 1; }
          ms=$(echo "$out" | sed -n 's/.* fitted in \([0-9.]*\) ms.*/\1/p')
          [ -n "$ms" ] || { echo "no 'fitted in ... ms' line from $b fit --model all:" >&2; echo "$out" >&2; exit 1; }
          echo "raw $b all $(basename "$f" .csv):$c $(awk -v ms="$ms" 'BEGIN { printf "%.5f\n", ms / 1e3 }')"
        done
      done
    fi
    if has choose; then
      for f in data/*.csv data/*.astm; do
        t=$(wall "$b" choose "$f" --scene fig7 -q -o "$TMP/choose")
        echo "raw $b choose $(basename "$f") $t"
      done
    fi
    if has report; then
      # On a terminal (a pseudo-terminal here), as a user sees it: the wall, and the longest
      # time in which nothing on the screen moved on: no line printed, and the bar's percentage
      # and message (what is running) unchanged (its clock and estimate ticking do not count).
      $PYTHON - "$b" report -o "$TMP/report" << 'PTY' | sed "s|^|raw $b report |"
import codecs, fcntl, os, pty, re, select, signal, struct, sys, termios, time
pid, fd = pty.fork()
if pid == 0:
    os.execvp(sys.argv[1], sys.argv[1:])
fcntl.ioctl(fd, termios.TIOCSWINSZ, struct.pack("HHHH", 50, 160, 0, 0))
start = last = time.monotonic()
silent, seen, tail = 0.0, None, ""
decode = codecs.getincrementaldecoder("utf-8")("replace").decode
bar = re.compile(r"\]\s*(\d+) % · .* left · (.*)$")
while True:
    ready, _, _ = select.select([fd], [], [], 0.5)
    if time.monotonic() - start > 900:
        os.kill(pid, signal.SIGTERM)
        sys.exit(f"{sys.argv[1]} report took over 900 s: stopped")
    if not ready:
        continue
    try:
        data = os.read(fd, 65536)
    except OSError:
        break
    if not data:
        break
    now = time.monotonic()
    text = tail + decode(data)
    *screens, tail = re.split(r"[\r\n]", text)
    screens = [re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", x) for x in screens]
    for line in filter(str.strip, screens):
        m = bar.search(line)
        key = (m[1], m[2].strip()) if m else line.strip()
        if key != seen:
            silent, last, seen = max(silent, now - last), now, key
_, status = os.waitpid(pid, 0)
now = time.monotonic()
if os.waitstatus_to_exitcode(status) != 0:
    sys.exit(f"{sys.argv[1]} report failed ({status})")
print(f"seconds {now - start:.2f}")
print(f"silent {max(silent, now - last):.2f}")
PTY
    fi
  done
done | tee "$TMP/raw.txt"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
CPU=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
COMMAND="ROUNDS=$ROUNDS REPEAT=$REPEAT PARTS=\"$PARTS\"${PEER:+ PEER=$PEER} benches/goals.sh"
$PYTHON - "$TMP/raw.txt" "$MARKDOWN" "$(nproc) cores, $CPU" "$(date -u '+%F')" \
  "$START_LOAD" "$(cut -d' ' -f1-3 /proc/loadavg)" "$COMMAND" << 'EOF'
import os, statistics as st, sys
from collections import defaultdict
v = defaultdict(list)  # (bin, part, key) -> values in repetition order
for line in open(sys.argv[1]):
    w = line.split()
    if w and w[0] == "raw":
        if len(w) != 5:
            print(f"warning: a raw line not of 5 fields, left out: {line.strip()}", file=sys.stderr)
            continue
        v[(w[1], w[2], w[3])].append(float(w[4]))
bins = list(dict.fromkeys(k[0] for k in v))
def med(xs):
    return st.median(xs), min(xs), max(xs)
table = []
print(f"{'binary':<28} {'goal':<48} {'median':>9} {'range':>19}  met")
for b in bins:
    rows = []
    for size, goal in (("10000", 10.0), ("1000000", 40.0)):
        for kind in ("total", "solve"):
            xs = v.get((b, "scipy", f"{size}-{kind}"))
            if xs:
                rows.append((f"{size} vs scipy, {kind} (≥ {goal:g}×)", xs, goal, True, "×"))
        if v.get((b, "scipy", f"{size}-seconds")):
            rows.append((f"{size}: brdfit total", v[(b, "scipy", f"{size}-seconds")], None, False, " s"))
    d3 = v.get((b, "models", "d3"))
    if d3:
        for (bb, part, key), xs in v.items():
            if bb == b and part == "models" and key != "d3":
                ratio = [x / t for x, t in zip(xs, d3)]
                rows.append((f"{key} / TS-d3 (≤ 3×)", ratio, 3.0, False, "×"))
        rows.append(("TS-d3 seconds (in process)", d3, None, False, " s"))
    for (bb, part, key), xs in v.items():
        if bb == b and part == "all":
            rows.append((f"--model all {key} (≤ 0.030 s)", xs, 0.030, False, " s"))
    for (bb, part, key), xs in v.items():
        if bb == b and part == "choose":
            rows.append((f"choose {key} (≤ 3 s)", xs, 3.0, False, " s"))
    if v.get((b, "report", "seconds")):
        rows.append(("report (≤ 60 s)", v[(b, "report", "seconds")], 60.0, False, " s"))
        rows.append(("report, longest still screen (≤ 5 s)", v[(b, "report", "silent")], 5.0, False, " s"))
    for name, xs, goal, above, unit in rows:
        m, lo, hi = med(xs)
        met = "" if goal is None else ("yes" if (m >= goal if above else m <= goal) else "NO")
        print(f"{b:<28} {name:<48} {m:>8.4g}{unit} {lo:>8.4g}–{hi:<8.4g}  {met}  (n={len(xs)})")
        table.append((b, name, m, lo, hi, unit, met, len(xs)))
markdown, machine, day, load0, load1, command = sys.argv[2:8]
if markdown:
    one = len(bins) == 1
    out = [
        f"Machine: {machine}. Date: {day}. Load average (1, 5, 15 min) {load0} at the start, "
        f"{load1} at the end. Command:",
        "",
        "```sh",
        command,
        "```",
        "",
        "| goal | median | range | met | n |" if one else "| binary | goal | median | range | met | n |",
        "|---|---|---|---|---|" if one else "|---|---|---|---|---|---|",
    ]
    for b, name, m, lo, hi, unit, met, n in table:
        cells = [name, f"{m:.4g}{unit}", f"{lo:.4g}–{hi:.4g}", met or "–", str(n)]
        if not one:
            cells.insert(0, os.path.basename(os.path.dirname(os.path.dirname(os.path.dirname(b)))) or b)
        out.append("| " + " | ".join(cells) + " |")
    text = open(markdown, encoding="utf-8").read().split("\n")
    a = text.index("<!-- goals.sh begins -->")
    z = text.index("<!-- goals.sh ends -->")
    new = "\n".join(text[: a + 1] + out + text[z:])
    tmp = markdown + ".goals-tmp"
    open(tmp, "w", encoding="utf-8").write(new)
    os.replace(tmp, markdown)
    print(f"wrote {markdown}")
EOF

#!/usr/bin/env bash
# Whole runs of trial 16 (557 generations of the guided GA), alternated
# round by round: OLD's `--threads 1`, then NEW's `--threads 1`,
# `--threads 2` and `--workers 2`; prints each one's median wall time and
# the round-by-round ratios docs/performance.md reports.
#
#   scripts/whole-runs.sh OLD_BINDIR NEW_BINDIR [ROUNDS]
set -euo pipefail
old=${1:?usage: whole-runs.sh OLD_BINDIR NEW_BINDIR [ROUNDS]}
new=${2:?usage: whole-runs.sh OLD_BINDIR NEW_BINDIR [ROUNDS]}
rounds=${3:-7}
times=$(mktemp)
out=$(mktemp -d)
for ((i = 1; i <= rounds; i++)); do
    for mode in "old1 $old --threads 1" "new1 $new --threads 1" \
        "new2 $new --threads 2" "neww2 $new --workers 2"; do
        set -- $mode
        name=$1 bin=$2
        shift 2
        rm -rf "$out/run"
        start=$(date +%s.%N)
        "$bin/lander" run --method guided --seed 1 --trial 16 "$@" --out "$out/run" >/dev/null 2>&1
        end=$(date +%s.%N)
        echo "$name $(echo "$end - $start" | bc)" >>"$times"
    done
done
rm -rf "$out"
python3 - "$times" <<'PY'
import statistics, sys
d = {}
for line in open(sys.argv[1]):
    name, t = line.split()
    d.setdefault(name, []).append(float(t))
for name, v in d.items():
    print(f"{name}: median {statistics.median(v):.3f} s ({min(v):.3f}-{max(v):.3f})")
for a, b in [("old1", "new1"), ("new1", "new2"), ("neww2", "new2")]:
    r = [x / y for x, y in zip(d[a], d[b])]
    print(f"{a} over {b}: median {statistics.median(r):.2f} ({min(r):.2f}-{max(r):.2f})")
PY

#!/usr/bin/env bash
# Writes the outputs that must not change from one build to the next into
# DIR, with the `lander` (and `lander-worker`) in BIN: ga, guided and
# qlearning runs, a guided run on 2 workers, and the paper's experiment.
# Compare two builds' DIRs with scripts/same-outputs.py.
#
#   scripts/outputs.sh BIN DIR      (run from the repository's root)
set -euo pipefail
if [ $# -ne 2 ]; then
    echo "usage: $0 BIN DIR" >&2
    exit 2
fi
bin=$1
out=$2
rm -rf "$out"
mkdir -p "$out"
for method in ga guided qlearning; do
    extra=()
    [ "$method" = qlearning ] && extra=(--episodes 400)
    "$bin/lander" run --method "$method" --seed 3 --trial 2 "${extra[@]}" \
        --out "$out/run-$method" --json > "$out/run-$method.json"
done
"$bin/lander" run --method guided --seed 5 --trial 4 --workers 2 \
    --out "$out/run-guided-w2" --json > "$out/run-guided-w2.json"
"$bin/lander" experiment experiments/paper.toml --out "$out/paper" > /dev/null 2>&1

#!/usr/bin/env bash
# How a sweep's wall time compares with running its settings one by one:
# 8 settings (ga.mutation_rate) × 25 paired trials of the general and the
# guided GA, no trial shared between settings. Each round times, in an
# order that alternates between rounds:
#   - the 8 experiments, one `lander experiment` each, in-process (summed);
#   - `lander sweep` in-process;
#   - `lander sweep --workers 2`, which also says how busy its workers were.
#
#   scripts/sweep-speed.sh [BINDIR] [ROUNDS]      (BINDIR: target/release)
set -euo pipefail
bin=${1:-target/release}
rounds=${2:-3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
rates=(0.02 0.03 0.04 0.05 0.06 0.07 0.08 0.1)
base='seed = 1
trials = 25
methods = ["ga", "guided"]'
{
    echo "name = \"speed\""
    echo "$base"
    echo "[grids.mutation]"
    echo "\"ga.mutation_rate\" = [$(IFS=,; echo "${rates[*]}")]"
} > "$work/sweep.toml"
for r in "${rates[@]}"; do
    printf 'name = "m%s"\n%s\n[ga]\nmutation_rate = %s\n' "$r" "$base" "$r" > "$work/m$r.toml"
done

seconds() { # command... → wall seconds on stdout
    local t0 t1
    t0=$(date +%s.%N)
    "$@" > /dev/null 2>> "$work/err"
    t1=$(date +%s.%N)
    echo "$t1 - $t0" | bc
}
experiments() {
    local sum=0
    for r in "${rates[@]}"; do
        rm -rf "$work/out-m$r"
        sum=$(echo "$sum + $(seconds "$bin/lander" experiment "$work/m$r.toml" --out "$work/out-m$r")" | bc)
    done
    echo "$sum"
}
sweep() {
    rm -rf "$work/out-sweep"
    seconds "$bin/lander" sweep "$work/sweep.toml" --out "$work/out-sweep" "$@"
}

echo "round  experiments_s  sweep_inproc_s  sweep_workers2_s  workers_busy"
for i in $(seq 1 "$rounds"); do
    : > "$work/err"
    if (( i % 2 )); then
        e=$(experiments); s=$(sweep); w=$(sweep --workers 2)
    else
        w=$(sweep --workers 2); s=$(sweep); e=$(experiments)
    fi
    busy=$(grep -o 'busy [0-9.]*%' "$work/err" | tail -1)
    echo "$i  $e  $s  $w  ${busy#busy }"
done

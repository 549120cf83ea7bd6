#!/usr/bin/env bash
# What --metrics costs: `lander bench` over 2 iceoryx2 workers, 8 trials in
# flight, without and with --metrics, alternated ROUNDS times, printing for
# each the iceoryx2-2 throughput and the coordinator's CPU per chunk, then
# the median on/off ratio. A third build to compare with (one without
# metrics at all) can be given as OTHER_BINDIR; it runs first in each round.
#
#   scripts/metrics-cost.sh BINDIR [ROUNDS] [OTHER_BINDIR]
set -euo pipefail
bin=${1:?usage: metrics-cost.sh BINDIR [ROUNDS] [OTHER_BINDIR]}
rounds=${2:-5}
other=${3:-}
one() { # label bindir extra-flags...
    local label=$1 dir=$2
    shift 2
    "$dir/lander" bench --workers 2 --in-flight 8 --generations 30 --rounds 3 \
        --transports iceoryx2 --json "$@" 2>/dev/null |
        python3 -c "
import json, sys
m = [x for x in json.load(sys.stdin)['modes'] if x['name'] == 'iceoryx2-2'][0]
print('$label', round(m['genomes_per_s']), round(m['coordinator_cpu_us_per_chunk'], 2))"
}
out=$(mktemp)
for ((i = 1; i <= rounds; i++)); do
    [[ -z $other ]] || one other "$other" | tee -a "$out"
    one off "$bin" | tee -a "$out"
    one on "$bin" --metrics 127.0.0.1:0 | tee -a "$out"
done
python3 - "$out" <<'PY'
import statistics, sys
runs = {}
for line in open(sys.argv[1]):
    label, rate, cpu = line.split()
    runs.setdefault(label, []).append((float(rate), float(cpu)))
for label, r in runs.items():
    print(f"{label}: median {statistics.median(x for x, _ in r):,.0f} genomes/s, "
          f"{statistics.median(c for _, c in r):.1f} µs coordinator CPU per chunk")
ratios = [on[0] / off[0] for on, off in zip(runs["on"], runs["off"])]
print("on/off throughput, per round:", " ".join(f"{x:.3f}" for x in ratios),
      f"median {statistics.median(ratios):.3f}")
PY
rm -f "$out"

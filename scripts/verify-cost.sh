#!/usr/bin/env bash
# What --verify costs: `lander bench` over 2 iceoryx2 workers, 8 trials in
# flight, at each RATE in turn, alternated ROUNDS times, printing the
# iceoryx2-2 throughput and the coordinator's CPU per chunk (a sampled
# chunk is flown again on the other worker), then the medians and each
# rate's throughput over rate 0's.
#
#   scripts/verify-cost.sh BINDIR [ROUNDS] [RATES...]
set -euo pipefail
bin=${1:?usage: verify-cost.sh BINDIR [ROUNDS] [RATES...]}
rounds=${2:-5}
shift $(($# < 2 ? $# : 2))
rates=("$@")
((${#rates[@]} > 0)) || rates=(0 0.01 0.05 0.2)
out=$(mktemp)
for ((i = 1; i <= rounds; i++)); do
    for rate in "${rates[@]}"; do
        "$bin/lander" bench --workers 2 --in-flight 8 --generations 30 --rounds 3 \
            --transports iceoryx2 --json --verify "$rate" 2>/dev/null |
            python3 -c "
import json, sys
m = [x for x in json.load(sys.stdin)['modes'] if x['name'] == 'iceoryx2-2'][0]
print('$rate', round(m['genomes_per_s']), round(m['coordinator_cpu_us_per_chunk'], 2))" |
            tee -a "$out"
    done
done
python3 - "$out" "${rates[0]}" <<'PY'
import statistics, sys
runs = {}
for line in open(sys.argv[1]):
    rate, speed, cpu = line.split()
    runs.setdefault(rate, []).append((float(speed), float(cpu)))
base = runs[sys.argv[2]]
for rate, r in runs.items():
    ratios = [x[0] / b[0] for x, b in zip(r, base)]
    print(f"rate {rate}: median {statistics.median(x for x, _ in r):,.0f} genomes/s, "
          f"{statistics.median(c for _, c in r):.1f} µs coordinator CPU per chunk, "
          f"throughput over rate {sys.argv[2]} {min(ratios):.3f}–{max(ratios):.3f} "
          f"(median {statistics.median(ratios):.3f})")
PY
rm -f "$out"

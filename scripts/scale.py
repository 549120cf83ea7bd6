#!/usr/bin/env python3
"""How many workers one coordinator feeds: `lander bench` over iceoryx2 and
zenoh at chunk sizes of about 0.1, 1 and 10 ms of compute, with 1 to 8
workers. For each, the coordinator process's CPU time per chunk answered
(all its threads, the transport's included) and the mean compute time of a
chunk; one coordinator keeps at most compute / CPU workers busy.

    scripts/scale.py [BIN]     (run from the repository's root; BIN is the
                                folder of `lander`, target/release by default)

Prints a Markdown table, one row per transport, chunk size and worker count.
"""
import json
import subprocess
import sys

BIN = sys.argv[1] if len(sys.argv) > 1 else "target/release"
CHUNKS_PER_WORKER = 4
# Genomes per chunk, and generations to fly: about 0.1, 1 and 10 ms of a
# guided chunk's compute on one core.
SIZES = [(30, 20), (300, 6), (3000, 3)]
WORKERS = [1, 2, 4, 8]


def bench(workers, genomes, generations):
    population = workers * CHUNKS_PER_WORKER * genomes
    out = subprocess.run(
        [f"{BIN}/lander", "bench", "--workers", str(workers),
         "--transports", "iceoryx2,zenoh", "--population", str(population),
         "--generations", str(generations), "--rounds", "1",
         "--chunks-per-worker", str(CHUNKS_PER_WORKER), "--json"],
        check=True, capture_output=True, text=True,
    ).stdout
    return json.loads(out)


print("| transport | genomes a chunk | workers | chunk compute | coordinator CPU a chunk | workers one coordinator feeds |")
print("|---|---|---|---|---|---|")
rows = []
for genomes, generations in SIZES:
    for workers in WORKERS:
        report = bench(workers, genomes, generations)
        for mode in report["modes"]:
            # The bench also flies 1 worker beside N; keep the N.
            if mode["workers"] != workers:
                continue
            transport = mode["name"].split("-")[0]
            cpu = mode["coordinator_cpu_us_per_chunk"]
            compute = mode["generation"]["compute_us"] / CHUNKS_PER_WORKER
            rows.append((transport, genomes, workers, compute, cpu))
for transport, genomes, workers, compute, cpu in sorted(rows):
    print(f"| {transport} | {genomes} | {workers} | {compute / 1000:.2f} ms | "
          f"{cpu:.1f} µs | {compute / cpu:.0f} |")

#!/usr/bin/env python3
"""Sums up where an in-process generation's time goes, from the pipeline's
trace (coordinator/src/evaluator/pipeline.rs, `PHASES`):

    RUST_LOG=lander::pipeline=trace lander run --method guided --seed 1 \\
        --trial 16 --threads 2 --out DIR --log-format json 2> trace.jsonl
    scripts/pipeline-phases.py trace.jsonl

Prints the mean of each phase per generation, in microseconds, and how
many genomes of each generation the breeder flew itself."""
import json
import statistics
import sys

FIELDS = ["between_us", "breed_us", "fly_us", "collect_us", "breeder_flew"]


def main(path):
    seen = {f: [] for f in FIELDS}
    try:
        lines = open(path, encoding="utf-8").read().splitlines()
    except OSError as e:
        sys.exit(f"{path}: {e.strerror}")
    for line in lines:
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            continue
        if not isinstance(record, dict) or record.get("target") != "lander::pipeline":
            continue
        for field in FIELDS:
            value = record.get("fields", {}).get(field)
            if value is not None:
                seen[field].append(float(value))
    generations = len(seen["breed_us"])
    if generations == 0:
        sys.exit(f"{path}: no lines of target lander::pipeline (was RUST_LOG=lander::pipeline=trace set, with --log-format json?)")
    print(f"{generations} generations flown as bred")
    for field in FIELDS:
        values = seen[field]
        print(f"  {field:13} mean {statistics.mean(values):8.1f}  median {statistics.median(values):8.1f}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])

#!/usr/bin/env python3
"""Compares two trees written by scripts/outputs.sh, wall times aside.

    scripts/same-outputs.py OLD_DIR NEW_DIR

Exits 1, naming each file that differs, unless every file is the same once
its wall-time fields (any key, column or line naming "wall") are left out;
plots and every other file must match byte for byte. `events.jsonl` is left
out whole: it tells what happened when, under a random run id, and holds no
result.
"""
import json, sys, re, os, csv, io
a, b = sys.argv[1], sys.argv[2]
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if "wall" not in k}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
def norm(path):
    data = open(path, "rb").read()
    if path.endswith(".jsonl"):
        return [strip(json.loads(l)) for l in data.decode().splitlines()]
    if path.endswith(".json"):
        return strip(json.loads(data))
    if path.endswith(".csv"):
        rows = list(csv.reader(io.StringIO(data.decode())))
        drop = [i for i, h in enumerate(rows[0]) if "wall" in h]
        return [[c for i, c in enumerate(r) if i not in drop] for r in rows]
    if path.endswith((".md", ".html")):
        t = data.decode()
        t = re.sub(r'"?[a-z_]*wall[a-z_]*"?\s*[:=]\s*[0-9.e+-]+', "WALL", t)
        return [l for l in t.splitlines() if "wall" not in l.lower()]
    return data
bad = 0; n = 0
for root, _, files in os.walk(a):
    for f in files:
        if f == "events.jsonl":
            continue
        pa = os.path.join(root, f); pb = os.path.join(b, os.path.relpath(pa, a)); n += 1
        if not os.path.exists(pb):
            print("missing", pb); bad += 1
        elif norm(pa) != norm(pb):
            print("differs", os.path.relpath(pa, a)); bad += 1
print(f"{n} files compared, {bad} differ")
sys.exit(1 if bad else 0)

#!/usr/bin/env python3
"""Compares two folders written by scripts/outputs_set.sh (or two results
folders) file by file: every file byte for byte, but summary.json and
manifest.json as JSON without their timings, run id and input paths (and the
manifest's size of summary.json). Prints each file that differs; exit 1 if any.

Usage: scripts/cmp_outputs.py OLD NEW
"""
import filecmp
import json
import os
import re
import sys

SKIP = re.compile(r"^(run_id|run_time_s|time_.*|.*_wall_s|.*cpu_s|sweep_time_s|job|program|path|paths)$")
NOT_OUTPUTS = (".log", ".time", ".toml")


def norm(x):
    if isinstance(x, dict):
        return {k: norm(v) for k, v in x.items() if not SKIP.match(k)}
    if isinstance(x, list):
        return [norm(v) for v in x]
    return x


def files(top):
    for root, _, names in os.walk(top):
        for f in names:
            rel = os.path.relpath(os.path.join(root, f), top)
            if f == "times.txt" or (f.endswith(NOT_OUTPUTS) and os.sep not in rel):
                continue
            if rel.startswith("bench_programs" + os.sep):
                continue
            yield rel


def main(a, b):
    bad = 0
    seen = set(files(a))
    for rel in sorted(seen):
        pa, pb = os.path.join(a, rel), os.path.join(b, rel)
        if not os.path.exists(pb):
            print("missing in", b, rel)
            bad += 1
            continue
        name = os.path.basename(rel)
        if name in ("summary.json", "manifest.json"):
            ja, jb = json.load(open(pa)), json.load(open(pb))
            if name == "manifest.json":
                for j in (ja, jb):
                    j.pop("run_id", None)
                    j.get("files", {}).pop("summary.json", None)
            same = norm(ja) == norm(jb)
        else:
            same = filecmp.cmp(pa, pb, shallow=False)
        if not same:
            print("differs", rel)
            bad += 1
    for rel in sorted(set(files(b)) - seen):
        print("only in", b, rel)
        bad += 1
    print(f"{len(seen)} files compared, {bad} differ")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))

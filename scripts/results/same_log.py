#!/usr/bin/env python3
"""Whether a rerun reproduces a committed training log bit for bit.

    python3 scripts/results/same_log.py docs/results/runs/run-cpu-s0/log.jsonl.gz runs/rerun/log.jsonl

Compares the rerun's rows (it may be shorter: a rerun stopped early) with the reference's rows of
the same iterations, every field but the timings (keys ending in ``_s`` and ``samples_per_s``),
as JSON values: a float reproduces only if it prints the same. Prints one JSON line (rows
compared, the first differing iteration and its differing fields) and exits 1 when a row differs
or the rerun has more rows than the reference. Either file may be gzipped (``.gz``).
"""

from __future__ import annotations

import gzip
import json
import sys
from pathlib import Path


def rows(path: Path) -> list[dict]:
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt") as f:
        return [json.loads(line) for line in f if line.strip()]


def without_timings(row: dict) -> dict:
    return {k: v for k, v in row.items() if not (k.endswith("_s") or k == "samples_per_s")}


def compare(reference: list[dict], rerun: list[dict]) -> dict:
    out: dict = {"reference_rows": len(reference), "rerun_rows": len(rerun), "identical_rows": 0}
    for i, row in enumerate(rerun):
        if i >= len(reference):
            out["first_difference"] = {"iteration": row.get("iteration"), "fields": ["<no reference row>"]}
            return out
        a, b = without_timings(reference[i]), without_timings(row)
        if a != b:
            fields = sorted(k for k in a.keys() | b.keys() if a.get(k) != b.get(k))
            out["first_difference"] = {"iteration": row.get("iteration"), "fields": fields}
            return out
        out["identical_rows"] += 1
    out["first_difference"] = None
    return out


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    result = compare(rows(Path(argv[0])), rows(Path(argv[1])))
    result["reference"], result["rerun"] = argv
    print(json.dumps(result))
    return 0 if result["first_difference"] is None else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Summary of scripts/experiments/multi_assign_cost.sh: per assignment, the environment time per
1000 samples and the samples per second of iterations 2-6, and the peak resident memory."""

import json
import pathlib
import re
import sys

out = pathlib.Path(sys.argv[1])
print("| env.multi.assign | env s / 1000 samples (it. 2-6) | samples/s (it. 2-6) | peak memory (MiB) |")
print("|---|---|---|---|")
for v in ("fixed", "per_episode"):
    rows = [json.loads(x) for x in (out / v / "log.jsonl").read_text().splitlines()][1:6]
    samples = sum(r["samples"] for r in rows)
    env_s = sum(r["env_s"] for r in rows)
    total = sum(r["samples"] / r["samples_per_s"] for r in rows)
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", (out / f"{v}.time").read_text()).group(1))
    print(f"| {v} | {1000 * env_s / samples:.3f} | {samples / total:.0f} | {rss / 1024:.0f} |")

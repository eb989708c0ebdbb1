#!/usr/bin/env python3
"""Two hsi_follow training logs side by side (e.g. the two motion-prior schedules,
ppo.amp.schedule), as means over windows of iterations: training episode length, the follow,
power and style terms per step, and the discriminator's mean logits on reference and simulated
windows. Reads log.jsonl or log.jsonl.gz.

Usage: hsi_amp_schedule_compare.py LOG_A LABEL_A LOG_B LABEL_B [WINDOW] [LAST]
"""
import gzip
import json
import sys


def rows(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        return [json.loads(line) for line in f if line.strip()]


def term(row, name):
    return dict(row["reward_terms"]).get(name, float("nan"))


def summary(rs, lo, hi):
    sel = [r for r in rs if lo <= r["iteration"] <= hi]
    if not sel:
        return None
    mean = lambda f: sum(f(r) for r in sel) / len(sel)
    return {
        "ep_len": mean(lambda r: r["episode_length"]),
        "follow": mean(lambda r: term(r, "follow")),
        "power": mean(lambda r: term(r, "power")),
        "style": mean(lambda r: term(r, "style")),
        "disc_ref": mean(lambda r: r["disc_ref"]),
        "disc_sim": mean(lambda r: r["disc_sim"]),
    }


def main():
    a, la, b, lb = sys.argv[1:5]
    window = int(sys.argv[5]) if len(sys.argv) > 5 else 25
    ra, rb = rows(a), rows(b)
    last = int(sys.argv[6]) if len(sys.argv) > 6 else min(ra[-1]["iteration"], rb[-1]["iteration"])
    keys = ["ep_len", "follow", "power", "style", "disc_ref", "disc_sim"]
    print("| iterations | run | " + " | ".join(keys) + " |")
    print("|---|---|" + "---|" * len(keys))
    for lo in range(1, last + 1, window):
        hi = min(lo + window - 1, last)
        for label, rs in ((la, ra), (lb, rb)):
            s = summary(rs, lo, hi)
            if s:
                print(f"| {lo}–{hi} | {label} | " + " | ".join(f"{s[k]:.3f}" for k in keys) + " |")


if __name__ == "__main__":
    main()

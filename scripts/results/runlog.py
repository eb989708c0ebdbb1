"""A run's training log (`log.jsonl`, one JSON object per iteration), read from a run folder as the
trainer writes it or from its committed, gzipped copy (`log.jsonl.gz`, docs/results/)."""

from __future__ import annotations

import gzip
import json
import pathlib


def read_run_log(folder: pathlib.Path) -> list[dict] | None:
    """Every iteration's row of `folder/log.jsonl`, else of `folder/log.jsonl.gz`; None if neither
    exists."""
    for name, opener in (("log.jsonl", open), ("log.jsonl.gz", gzip.open)):
        path = pathlib.Path(folder) / name
        if path.exists():
            with opener(path, "rt") as f:
                return [json.loads(line) for line in f if line.strip()]
    return None


def reward_term(row: dict, name: str) -> float:
    """One per-step reward term of a log row (`reward_terms` is a list of [name, value] pairs);
    a KeyError if the row has no such term."""
    return dict(row["reward_terms"])[name]

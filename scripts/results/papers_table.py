"""The papers' metrics of committed results runs as a Markdown table (issue 40, docs/results.md):
one row per run folder and skill, from the files scripts/results/evidence.sh writes there.

    python3 scripts/results/papers_table.py docs/results/runs/run-cpu-s0 docs/results/runs/run-small-s0

Columns (every number from the folder's eval-papers.json unless named otherwise):
  - settings: environments, network, mini-epochs and learning rate of the run's config.toml;
  - samples: the evaluated checkpoint's (checkpoint.txt);
  - SkillMimic success: §6.2.4's rate per skill over 10-s trials from distinct reference starts,
    with its 95 % interval, and the share of those trials that fell;
  - SkillMimic-V2: SR and TSR (600 steps from frame 2, sampled actions), εNSR (ε 0.1), NR;
  - random frames: Acc (with the replay ceiling: the share of frames where the clip's own
    kinematic replay matches its contact labels), E_b/E_o-mpjpe (mm), E_cg;
  - completion from the start: the project's test (eval-start-eps0.01.json), not a paper metric,
    with the clip frame where its falls ended (median and quartiles) where the file has them.
"""

from __future__ import annotations

import json
import pathlib
import sys
import tomllib


def settings(cfg: dict) -> str:
    env, ppo = cfg["env"], cfg["ppo"]
    hidden = ", ".join(str(h) for h in ppo["hidden"])
    return f"{env['num_envs']} envs, [{hidden}], {ppo['mini_epochs']} ep., lr {ppo['lr']:g}"


def checkpoint_info(folder: pathlib.Path) -> dict:
    info = {}
    for line in (folder / "checkpoint.txt").read_text().splitlines():
        key, _, value = line.partition(":")
        info[key.strip()] = value.strip()
    return info


def pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.1f}"


def rows(folder: pathlib.Path) -> list[str]:
    ev = json.loads((folder / "eval-papers.json").read_text())
    cfg = tomllib.loads((folder / "config.toml").read_text())
    info = checkpoint_info(folder)
    start_path = folder / "eval-start-eps0.01.json"
    start = json.loads(start_path.read_text())["nominal"] if start_path.exists() else None
    n, v2, sm = ev["nominal"], ev["v2"], ev["skillmimic"]
    out = []
    for skill, s in sorted(sm["per_skill"].items()):
        lo, hi = s["ci95"]
        samples = info.get("samples", "?")
        samples = f"{int(samples) / 1e6:.2f} M" if samples.isdigit() else samples
        tsr = v2["tsr_mean"]
        completion = "–" if start is None else f"{100 * (1 - start['fall_rate']):.1f}"
        if q := (start or {}).get("per_skill", {}).get(skill, {}).get("fall_frames"):
            completion += f"; falls at frame {q['median']} ({q['q1']}–{q['q3']})"
        out.append(
            f"| {folder.name} | {skill} | {settings(cfg)} | {samples} "
            f"| {pct(s['success_rate'])} ({pct(lo)}–{pct(hi)}), falls {pct(s['fall_rate'])} "
            f"| {pct(v2['sr'].get(skill))} | {pct(tsr)} | {pct(v2['eps_nsr'].get(skill))} | {v2['nr'].get(skill, float('nan')):.3f} "
            f"| {n['acc_percent']:.1f} ({n['acc_ceiling_percent']:.1f}) | {n['e_b_mpjpe_mm']:.0f} | {n['e_o_mpjpe_mm']:.0f} "
            f"| {n['e_cg']:.3f} | {completion} |"
        )
    return out


def main() -> None:
    folders = [pathlib.Path(a) for a in sys.argv[1:]]
    if not folders:
        sys.exit(__doc__)
    for f in folders:
        if not (f / "eval-papers.json").is_file():
            sys.exit(f"papers_table.py: {f}/eval-papers.json not found (scripts/results/evidence.sh writes it)")
    print(
        "| run | skill | settings | samples | SkillMimic success % (95 % interval), 10-s falls % | V2 SR % | V2 TSR % "
        "| V2 εNSR % | NR | Acc % (replay ceiling) | E_b mm | E_o mm | E_cg | completion from the start, ±0.01 (project test) %; falls' clip frame, median (quartiles) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for f in folders:
        for r in rows(f):
            print(r)


if __name__ == "__main__":
    main()

#!/usr/bin/env bash
# Results protocol (issue 22, docs/results.md): train the clip of configs/results/NAME.toml, resuming
# from OUT/NAME/latest.safetensors when it exists, then evaluate the latest checkpoint:
#   - eval-start.json: the deterministic (mean-action) episode from the clip's first usable frame
#     (2: frames 0 and 1 have no velocity) to its end: completion and falls. Physics and policy are
#     deterministic, so its 64 episodes are one trajectory (falls 0 % or 100 %);
#   - eval-start-sampled.json: 64 episodes from frame 2 with sampled actions (the policy's σ);
#   - eval-start-eps{0.01,0.02,0.05,0.1}.json: 64 mean-action episodes from frame 2 whose start
#     states are perturbed by ε per component (`--init-noise`; 0.1 = SkillMimic-V2's εNSR setting):
#     the completion rate over episodes that differ;
#   - eval.json: 64 deterministic episodes from random frames (the paper's Acc, E_b/E_o-mpjpe,
#     E_cg, NR) plus the SkillMimic-V2 metrics (SR over 10 s from frame 2, TSR, εNSR);
#   - curve.png, the metrics of every 25th checkpoint (checkpoint_evals.jsonl, metrics.png) and a
#     GIF of 5 s from the clip's start (mean action).
#   scripts/results/train_clip.sh run            # to the config's run.iterations
#   ITERS=400 scripts/results/train_clip.sh run  # a chunk: stop at iteration 400 (resume later)
set -euo pipefail
cd "$(dirname "$0")/../.."
NAME=${1:?usage: train_clip.sh NAME (configs/results/NAME.toml)}
BIN=${BIN:-target/release/skillmimic}
OUT=${OUT:-runs/results}/$NAME
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
mkdir -p "$OUT"
args=(train --preset small --config "configs/results/$NAME.toml" --out "$OUT" --no-video --set run.eval_episodes=0)
[ -n "${ITERS:-}" ] && args+=(--iterations "$ITERS")
[ -f "$OUT/latest.safetensors" ] && args+=(--resume "$OUT/latest.safetensors")
target=${ITERS:-$(sed -n 's/^iterations = //p' "configs/results/$NAME.toml")}
done_iters=$( [ -f "$OUT/log.jsonl" ] && tail -n 1 "$OUT/log.jsonl" | python3 -c 'import json, sys; print(json.loads(sys.stdin.read())["iteration"])' || echo 0)
if [ "$done_iters" -lt "$target" ]; then
  "$BIN" "${args[@]}" >> "$OUT/train.log" 2>&1
fi
# the whole clip: the episode ends at the clip's last frame or a fall (not after env.episode_length)
"$BIN" eval --checkpoint "$OUT/latest.safetensors" --episodes 64 --seed 7 --start-frame 2 --set env.episode_length=100000 \
  --out "$OUT/eval-start.json" >> "$OUT/train.log" 2>&1
"$BIN" eval --checkpoint "$OUT/latest.safetensors" --episodes 64 --seed 7 --start-frame 2 --stochastic --set env.episode_length=100000 \
  --out "$OUT/eval-start-sampled.json" >> "$OUT/train.log" 2>&1
for eps in 0.01 0.02 0.05 0.1; do
  "$BIN" eval --checkpoint "$OUT/latest.safetensors" --episodes 64 --seed 7 --start-frame 2 --init-noise "$eps" --set env.episode_length=100000 \
    --out "$OUT/eval-start-eps$eps.json" >> "$OUT/train.log" 2>&1
done
"$BIN" eval --checkpoint "$OUT/latest.safetensors" --episodes 64 --seed 7 --v2 --out "$OUT/eval.json" >> "$OUT/train.log" 2>&1
"$BIN" plot --log "$OUT/log.jsonl" --out "$OUT/curve.png" >> "$OUT/train.log" 2>&1
# the metrics along the run: every 25th checkpoint (scripts/results/eval_checkpoints.py), plotted
BIN="$BIN" OUT="$(dirname "$OUT")" python3 scripts/results/eval_checkpoints.py "$NAME" >> "$OUT/train.log" 2>&1
"$BIN" plot --evals "$OUT/checkpoint_evals.jsonl" --label "$NAME" --out "$OUT/metrics.png" >> "$OUT/train.log" 2>&1
# 5 s from the clip's start with the mean action (episodes restart at frame 2 when the clip ends)
"$BIN" play --checkpoint "$OUT/latest.safetensors" --steps 300 --set 'env.state_init={frame=2}' --set env.episode_length=100000 \
  --video "$OUT/episode.gif" >> "$OUT/train.log" 2>&1 || echo "no video (renderer unavailable)" >> "$OUT/train.log"
python3 - "$OUT" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
# the log may run past the newest checkpoint (a run killed between saves): keep its rows up to it
last_ck = max(int(p.stem.removeprefix("iter_")) for p in (out / "checkpoints").glob("iter_*.safetensors"))
rows = [r for r in (json.loads(l) for l in (out / "log.jsonl").read_text().splitlines() if l.strip()) if r["iteration"] <= last_ck]
start = json.loads((out / "eval-start.json").read_text())["nominal"]
sampled = json.loads((out / "eval-start-sampled.json").read_text())["nominal"]
ev = json.loads((out / "eval.json").read_text())
n = ev["nominal"]
print(f"{out.name}: {rows[-1]['iteration']} iterations, {rows[-1]['samples']} samples; reward/step last 25 it. "
      f"{sum(r['mean_reward'] for r in rows[-25:]) / len(rows[-25:]):.4f}; from frame 2: mean action falls {100 * start['fall_rate']:.0f} %, "
      f"length {start['mean_episode_length']:.1f}, E_b {start['e_b_mpjpe_mm']:.0f} mm; sampled actions: completed {100 * (1 - sampled['fall_rate']):.1f} %, "
      f"E_b {sampled['e_b_mpjpe_mm']:.0f} mm; random frames: Acc {n['acc_percent']:.1f} %, E_b {n['e_b_mpjpe_mm']:.0f} mm, "
      f"E_o {n['e_o_mpjpe_mm']:.0f} mm, E_cg {n['e_cg']:.3f}, NR {n['nr']:.4f}, falls {100 * n['fall_rate']:.1f} %")
eps = {e: json.loads((out / f"eval-start-eps{e}.json").read_text())["nominal"] for e in ("0.01", "0.02", "0.05", "0.1")}
print("mean action from frame 2, start perturbed by eps: " + ", ".join(f"eps {e}: completed {100 * (1 - r['fall_rate']):.1f} %" for e, r in eps.items()))
# plateau rule of docs/results.md: the mean reward of the last 200 iterations within 2 % of the 200 before
if len(rows) >= 400:
    last, before = (sum(r["mean_reward"] for r in rows[a:b]) / 200 for a, b in ((-200, None), (-400, -200)))
    change = (last - before) / before
    print(f"plateau: reward/step {before:.4f} -> {last:.4f} over the last 2 x 200 iterations ({100 * change:+.1f} %): "
          + ("plateaued (within 2 %)" if abs(change) <= 0.02 else "still changing"))
PY

#!/usr/bin/env bash
# Issue 40: commit the evidence of a results run beside the numbers that come from it.
#   scripts/results/evidence.sh NAME RUN_DIR [CHECKPOINT]
# writes docs/results/runs/NAME/ (CHECKPOINT defaults to RUN_DIR/latest.safetensors):
#   - log.jsonl.gz: the training log (every iteration's rewards, losses, timings), gzipped;
#   - config.toml: the run's effective configuration;
#   - checkpoint_evals.jsonl: the metrics along the run (scripts/results/eval_checkpoints.py);
#   - eval-papers.json: the checkpoint under the papers' metrics, seed 7, 64 trials per measure:
#     random frames as in training (Acc with its replay ceiling, E_b/E_o-mpjpe, E_cg, NR, falls);
#     SkillMimic's success per skill (§6.2.4: 10-s trials from distinct reference starts,
#     deterministic actions, with the 95 % interval); SkillMimic-V2's SR and TSR (600 steps from
#     frame 2, sampled actions, distinct trials counted), εNSR (ε 0.1) and NR;
#   - eval-start-eps0.01.json: the project's completion test (mean action from frame 2, start
#     states perturbed by 0.01, to the clip's end), not a paper metric;
#   - episode.mp4: 5 s of the mean action from the clip's start (frame 2; episodes restart there
#     when the clip ends or the character falls), the reference beside it (`skillmimic play`);
#     skipped with a line in checkpoint.txt where no renderer is available, or with VIDEO=0;
#   - checkpoint.txt: which checkpoint, its iteration and samples, and the commands.
# scripts/results/papers_table.py prints the table of docs/results.md from these folders.
set -euo pipefail
cd "$(dirname "$0")/../.."
name=${1:?usage: evidence.sh NAME RUN_DIR [CHECKPOINT]}
run=${2:?usage: evidence.sh NAME RUN_DIR [CHECKPOINT]}
ck=${3:-$run/latest.safetensors}
BIN=${BIN:-target/release/skillmimic}
[ -x "$BIN" ] || cargo build --release -p skillmimic-cli
for f in "$ck" "$run/log.jsonl" "$run/config.toml"; do
  [ -f "$f" ] || { echo "evidence.sh: $f not found" >&2; exit 2; }
done
dest=docs/results/runs/$name
mkdir -p "$dest"
papers=(eval --checkpoint "$ck" --episodes 64 --seed 7 --skillmimic --v2 --out "$dest/eval-papers.json")
start=(eval --checkpoint "$ck" --episodes 64 --seed 7 --start-frame 2 --init-noise 0.01
  --set env.episode_length=100000 --out "$dest/eval-start-eps0.01.json")
video=(play --checkpoint "$ck" --steps 300 --set 'env.state_init={frame=2}' --set env.episode_length=100000
  --ghost beside --video "$dest/episode.mp4")
"$BIN" "${papers[@]}"
"$BIN" "${start[@]}"
if [ "${VIDEO:-1}" = 0 ]; then video_line="no video (VIDEO=0)"
elif "$BIN" "${video[@]}" > /dev/null 2>&1; then video_line="$BIN ${video[*]}"
else video_line="no video (the renderer failed: $BIN ${video[*]})"; fi
gzip -9 -n -c "$run/log.jsonl" > "$dest/log.jsonl.gz"
cp "$run/config.toml" "$dest/config.toml"
[ -f "$run/checkpoint_evals.jsonl" ] && cp "$run/checkpoint_evals.jsonl" "$dest/checkpoint_evals.jsonl"
# the checkpoint's iteration and samples, from its safetensors metadata (read with the standard
# library: skillmimic_rs.policy.checkpoint_metadata needs PyTorch, which the results scripts do not)
meta=$(python3 - "$ck" <<'PY'
import json, struct, sys
with open(sys.argv[1], "rb") as f:
    meta = json.loads(f.read(struct.unpack("<Q", f.read(8))[0])).get("__metadata__", {})
print(f"iteration: {meta.get('iteration', '?')}\nsamples: {meta.get('samples', '?')}")
PY
)
{
  echo "checkpoint: $ck"
  echo "$meta"
  echo "made by: scripts/results/evidence.sh $name $run $ck ($(git rev-parse --short HEAD))"
  echo "commands: $BIN ${papers[*]}"
  echo "          $BIN ${start[*]}"
  echo "video: $video_line"
} > "$dest/checkpoint.txt"
python3 scripts/results/papers_table.py "$dest"

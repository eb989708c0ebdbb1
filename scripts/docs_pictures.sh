#!/usr/bin/env bash
# Make the tutorials' pictures (docs/tutorials/img/): run every tutorial of the guide top to bottom
# at its own budget (tests/test_tutorials.py with SKILLMIMIC_TUTORIAL_FULL=1; about an hour on 2
# cores), keeping each page's folder under target/tutorials/<page>, then copy the videos and
# curves the pages show, and the evidence of the numbers they print (docs/tutorials/evidence/:
# the runs' summaries, evaluation JSON and reports, and outputs.log, every command's output). Needs `scripts/setup.sh --tests`, the package installed in .venv and the
# BallPlay-M clips (../shared or $SKILLMIMIC_SHARED).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
work=target/tutorials
evidence=docs/tutorials/evidence
mkdir -p "$evidence"
SKILLMIMIC_TUTORIAL_FULL=1 SKILLMIMIC_TUTORIAL_DIR="$work" SKILLMIMIC_SHOW_TUTORIALS=1 \
  .venv/bin/python -m pytest -q -s -x tests/test_tutorials.py -k test_tutorial_runs "$@" \
  | tee "$evidence/outputs.log"
img=docs/tutorials/img
mkdir -p "$img"
while read -r from to; do
  cp "$work/$from" "$img/$to"
  echo "docs_pictures: $img/$to <- $work/$from"
done <<'LIST'
train-a-skill/runs/first/curve_400.png first-curve.png
train-a-skill/runs/first/policy.mp4 first-policy.mp4
your-motion/my_clips/walk.mp4 your-motion-bvh.mp4
your-motion/my_clips/walk_amass.mp4 your-motion-amass.mp4
your-motion/my_smpl/walk_amass.mp4 your-motion-amass-smpl.mp4
evaluate/runs/dribble/trial.mp4 evaluate-trial.mp4
skill-reuse/runs/heading/heading.mp4 skill-reuse-heading.mp4
several-machines/runs/dp/curve.png several-machines-curve.png
onnx/runs/first/onnx.mp4 onnx-policy.mp4
gymnasium/runs/sb3_recipe.mp4 gymnasium-sb3.mp4
add-a-task/runs/stand/stand.mp4 add-a-task-stand.mp4
add-a-character/runs/smpl_stand/stand.mp4 add-a-character-smpl.mp4
LIST
while read -r from to; do
  mkdir -p "$(dirname "$evidence/$to")"
  cp "$work/$from" "$evidence/$to"
done <<'LIST'
train-a-skill/runs/first/log.jsonl train-a-skill/first_log.jsonl
train-a-skill/runs/first/summary.json train-a-skill/first_summary.json
your-motion/my_clips/walk.retarget.json your-motion/my_clips_walk.retarget.json
your-motion/my_clips/walk_amass.retarget.json your-motion/my_clips_walk_amass.retarget.json
your-motion/runs/walk/summary.json your-motion/walk_summary.json
evaluate/runs/dribble/eval_skillmimic.json evaluate/dribble_eval_skillmimic.json
evaluate/runs/dribble/eval_v2.json evaluate/dribble_eval_v2.json
evaluate/runs/dribble/summary.json evaluate/dribble_summary.json
skill-reuse/runs/heading/eval.json skill-reuse/heading_eval.json
skill-reuse/runs/heading/summary.json skill-reuse/heading_summary.json
several-machines/runs/dp/summary.json several-machines/dp_summary.json
onnx/runs/first/policy.onnx.json onnx/first_policy.onnx.json
add-a-task/runs/stand/eval.json add-a-task/stand_eval.json
add-a-task/runs/stand/summary.json add-a-task/stand_summary.json
add-a-character/runs/smpl_stand/summary.json add-a-character/smpl_stand_summary.json
LIST
echo "docs_pictures: evidence in $evidence"

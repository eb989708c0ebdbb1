#!/usr/bin/env bash
# Make the tutorials' pictures (docs/tutorials/img/): run every tutorial of the guide top to bottom
# at its own budget (tests/test_tutorials.py with SKILLMIMIC_TUTORIAL_FULL=1; about an hour on 2
# cores), keeping each page's folder under target/tutorials/<page>, then copy the videos and
# curves the pages show. Needs `scripts/setup.sh --tests`, the package installed in .venv and the
# BallPlay-M clips (../shared or $SKILLMIMIC_SHARED).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
work=target/tutorials
SKILLMIMIC_TUTORIAL_FULL=1 SKILLMIMIC_TUTORIAL_DIR="$work" \
  .venv/bin/python -m pytest -q -x tests/test_tutorials.py -k test_tutorial_runs "$@"
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
evaluate/runs/dribble/trial.mp4 evaluate-trial.mp4
skill-reuse/runs/heading/heading.mp4 skill-reuse-heading.mp4
several-machines/runs/dp/curve.png several-machines-curve.png
onnx/runs/first/onnx.mp4 onnx-policy.mp4
gymnasium/runs/sb3_recipe.mp4 gymnasium-sb3.mp4
add-a-task/runs/stand/stand.mp4 add-a-task-stand.mp4
add-a-character/runs/smpl_stand/stand.mp4 add-a-character-smpl.mp4
LIST

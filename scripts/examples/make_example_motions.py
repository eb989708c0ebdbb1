"""Write two small stand-ins for a user's motion files, for the tutorial "Bring your own motion"
(docs/tutorials/your-motion.md): a 2-second walk in place

- `walk.bvh`: the CMU BVH layout (joint names of the shipped `cmu` map, Y-up, centimetres,
  facing +z with the left side at +x, channels Z X Y in degrees), and
- `walk_amass.npz`: the AMASS layout (`poses` (T, 156) SMPL-H axis-angle rows in radians,
  `trans` (T, 3) metres, Z-up, `mocap_framerate`).

The motion is made up (hips swing ±25°, knees bend on the back swing); it only has to be a valid
file of each format. Usage: python scripts/examples/make_example_motions.py OUT_DIR
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

FPS, FRAMES = 60, 120

# CMU layout: name, parent, offset from the parent (cm, Y-up, left = +x)
JOINTS = [
    ("Hips", None, (0, 0, 0)),
    ("LeftUpLeg", "Hips", (9, -5, 0)), ("LeftLeg", "LeftUpLeg", (0, -42, 0)),
    ("LeftFoot", "LeftLeg", (0, -41, 0)), ("LeftToeBase", "LeftFoot", (0, -6, 13)),
    ("RightUpLeg", "Hips", (-9, -5, 0)), ("RightLeg", "RightUpLeg", (0, -42, 0)),
    ("RightFoot", "RightLeg", (0, -41, 0)), ("RightToeBase", "RightFoot", (0, -6, 13)),
    ("LowerBack", "Hips", (0, 8, 0)), ("Spine", "LowerBack", (0, 12, 0)),
    ("Spine1", "Spine", (0, 14, 0)), ("Neck", "Spine1", (0, 14, 0)), ("Head", "Neck", (0, 10, 0)),
    ("LeftShoulder", "Spine1", (4, 12, 0)), ("LeftArm", "LeftShoulder", (14, 0, 0)),
    ("LeftForeArm", "LeftArm", (28, 0, 0)), ("LeftHand", "LeftForeArm", (25, 0, 0)),
    ("RightShoulder", "Spine1", (-4, 12, 0)), ("RightArm", "RightShoulder", (-14, 0, 0)),
    ("RightForeArm", "RightArm", (-28, 0, 0)), ("RightHand", "RightForeArm", (-25, 0, 0)),
]


def swing(t: int) -> float:
    """Hip swing angle (degrees) at frame t: one stride per second."""
    return 25.0 * float(np.sin(2 * np.pi * t / FPS))


def bvh_text() -> str:
    lines: list[str] = ["HIERARCHY"]

    def joint(name: str, depth: int) -> None:
        ind = "  " * depth
        offset = next(o for n, _, o in JOINTS if n == name)
        lines.append(f"{ind}{'ROOT' if depth == 0 else 'JOINT'} {name}")
        lines.append(ind + "{")
        lines.append(f"{ind}  OFFSET {offset[0]} {offset[1]} {offset[2]}")
        position = "Xposition Yposition Zposition " if depth == 0 else ""
        lines.append(f"{ind}  CHANNELS {6 if depth == 0 else 3} {position}Zrotation Xrotation Yrotation")
        children = [n for n, p, _ in JOINTS if p == name]
        for child in children:
            joint(child, depth + 1)
        if not children:
            lines.extend([f"{ind}  End Site", ind + "  {", f"{ind}    OFFSET 0 -5 0", ind + "  }"])
        lines.append(ind + "}")

    joint("Hips", 0)
    lines.extend(["MOTION", f"Frames: {FRAMES}", f"Frame Time: {1 / FPS:.6f}"])
    for t in range(FRAMES):
        s = swing(t)
        x = {"LeftUpLeg": s, "RightUpLeg": -s, "LeftLeg": 1.5 * max(0.0, -s), "RightLeg": 1.5 * max(0.0, s)}
        z = {"LeftArm": -75.0, "RightArm": 75.0}  # arms down from the T-pose
        row: list[float] = [0.0, 93.0, 0.0]  # root position (cm)
        for name, _, _ in JOINTS:
            row += [z.get(name, 0.0), x.get(name, 0.0), 0.0]
        lines.append(" ".join(f"{v:.4f}" for v in row))
    return "\n".join(lines) + "\n"


def amass_arrays() -> dict[str, np.ndarray]:
    """SMPL-H rows: 52 joints × 3 axis-angle values; joints 1/2 = left/right hip, 4/5 = knees,
    16/17 = shoulders."""
    poses = np.zeros((FRAMES, 156), np.float64)
    poses[:, 0] = np.pi / 2  # AMASS roots are Z-up: turn SMPL's Y-up body upright
    for t in range(FRAMES):
        s = np.radians(swing(t))
        poses[t, 3] = -s  # left hip about its x axis (forward swing is negative in SMPL)
        poses[t, 6] = s
        poses[t, 12] = 1.5 * max(0.0, s)
        poses[t, 15] = 1.5 * max(0.0, -s)
    poses[:, 16 * 3 + 2] = -1.3  # left shoulder about z: the arm down from the T-pose
    poses[:, 17 * 3 + 2] = 1.3
    trans = np.tile([0.0, 0.0, 0.93], (FRAMES, 1))
    return {"poses": poses, "trans": trans, "mocap_framerate": np.array(float(FPS))}


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    out = Path(argv[1])
    out.mkdir(parents=True, exist_ok=True)
    (out / "walk.bvh").write_text(bvh_text())
    np.savez(out / "walk_amass.npz", **amass_arrays())
    print(f"wrote {out / 'walk.bvh'} and {out / 'walk_amass.npz'} ({FRAMES} frames at {FPS} fps)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

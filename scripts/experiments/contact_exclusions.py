"""Issue 21: can contact exclusions make the physics cheaper at equal fidelity?

1. Kinematic replay of every BallPlay-M clip into the project's scene (PyPI mujoco, every geom's
   margin set to 1 cm): for every pair of humanoid bodies, the smallest distance seen and the number
   of frames in which the two bodies penetrate. Pairs never within 1 cm never touch in the clips.
2. Raw ``mj_step`` rate (one thread, interleaved rounds) of the scene as shipped, with every
   never-within-1-cm pair excluded, and with every finger pair of the same hand excluded; the
   workload is the benchmarks' (upright at rest, random PD targets of ±0.15·π).

    .venv/bin/python scripts/experiments/contact_exclusions.py [--shared ../shared] [--out runs/contacts.json]
"""

import argparse
import collections
import itertools
import json
import pathlib
import sys
import time

import mujoco
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
import reference_env as ref  # noqa: E402
import skillmimic_rs  # noqa: E402

FINGERS = ("Index", "Middle", "Ring", "Pinky", "Thumb")


def replay_distances(xml: str, files: list[pathlib.Path]):
    m = mujoco.MjModel.from_xml_string(xml)
    m.geom_margin[:] = 0.01
    d = mujoco.MjData(m)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(m.nbody)]
    mind, touch, frames = {}, collections.Counter(), 0
    for f in files:
        clip = ref.load_clip(f)
        derived = ref.derive_reference(clip)
        for t in range(len(clip["root_pos"])):
            d.qpos[:] = ref.reset_qpos_qvel(m, clip, derived, t)[0]
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            mujoco.mj_collision(m, d)
            frames += 1
            for c in d.contact[: d.ncon]:
                pair = tuple(sorted((names[m.geom_bodyid[c.geom1]], names[m.geom_bodyid[c.geom2]])))
                mind[pair] = min(mind.get(pair, 1.0), float(c.dist))
                touch[pair] += c.dist < 0
    humanoid = [n for n in names if n and n not in ("world", "Ball")]
    parent = {names[b]: names[m.body_parentid[b]] for b in range(m.nbody)}
    candidates = [tuple(sorted(p)) for p in itertools.combinations(humanoid, 2) if parent[p[0]] != p[1] and parent[p[1]] != p[0]]
    never = [p for p in candidates if p not in mind]
    hand = [p for p in candidates if all(any(f in b for f in FINGERS) for b in p) and p[0][:2] == p[1][:2]]
    return frames, mind, touch, candidates, never, hand


def with_excludes(xml: str, pairs) -> str:
    ex = "".join(f'<exclude body1="{a}" body2="{b}"/>' for a, b in pairs)
    return xml.replace("</mujoco>", f"<contact>{ex}</contact></mujoco>")


def rates(variants: dict, qpos, qvel, steps=300, rounds=6, seed=0):
    base = next(iter(variants.values()))
    acts = np.pi * 0.15 * np.random.default_rng(seed).uniform(-1, 1, (steps, base.nu))
    spent, ncon = collections.defaultdict(float), collections.defaultdict(list)
    for r in range(rounds):
        for name, m in variants.items():
            d = mujoco.MjData(m)
            d.qpos[:], d.qvel[:] = qpos, qvel
            t0 = time.perf_counter()
            for k in range(steps):
                d.ctrl[:] = acts[k]
                mujoco.mj_step(m, d)
                mujoco.mj_step(m, d)
                ncon[name].append(d.ncon)
            if r:  # the first round warms up
                spent[name] += time.perf_counter() - t0
    first = next(iter(variants))
    return {n: {"mj_step_per_s": 2 * steps * (rounds - 1) / spent[n], "vs_shipped": spent[first] / spent[n], "mean_contacts": float(np.mean(ncon[n]))} for n in variants}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--shared", default=str(ROOT.parent / "shared"))
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    files = sorted((pathlib.Path(a.shared) / "data" / "ballplay_m").rglob("*.pt"))
    env = skillmimic_rs.VecEnv(num_envs=1, autoreset_mode="disabled", threads=1)
    env.reset(seed=3)
    xml = env.mjcf_xml
    qpos, qvel = env.get_state(0)
    frames, mind, touch, candidates, never, hand = replay_distances(xml, files)
    near = {p: mind[p] for p in candidates if p in mind}
    touching = {p for p in near if touch[p] > 0}
    hand_touching = [p for p in hand if p in touching]
    print(f"{len(files)} clips, {frames} frames; {len(candidates)} humanoid body pairs that MuJoCo may collide (parent-child excluded)")
    print(f"within 1 cm in some frame: {len(near)}; penetrating in some frame: {len(touching)} ({len(hand_touching)} of the {len(hand)} same-hand finger pairs)")
    print(f"never within 1 cm: {len(never)}")
    variants = {
        "shipped": mujoco.MjModel.from_xml_string(xml),
        f"exclude the {len(never)} never-near pairs": mujoco.MjModel.from_xml_string(with_excludes(xml, never)),
        f"exclude the {len(hand)} same-hand finger pairs": mujoco.MjModel.from_xml_string(with_excludes(xml, hand)),
    }
    result = rates(variants, qpos, qvel)
    for name, r in result.items():
        print(f"{name:42s} {r['mj_step_per_s']:7.0f} mj_step/s  x{r['vs_shipped']:.3f}  mean contacts {r['mean_contacts']:.2f}")
    if a.out:
        top = sorted(near.items(), key=lambda kv: kv[1])[:20]
        out = {
            "clips": len(files), "frames": frames, "pairs": len(candidates), "near": len(near), "touching": len(touching),
            "hand_pairs": len(hand), "hand_touching": len(hand_touching), "never": len(never),
            "deepest": [{"pair": p, "min_dist_m": v, "frames_penetrating": touch[p]} for p, v in top], "rates": result,
        }
        pathlib.Path(a.out).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()

"""The results scripts' arithmetic on hand-built runs whose answers are known: time to the skill
criterion and the preset comparison (scripts/experiments/time_to_skill.py, issue 41) and the
papers'-metrics table (scripts/results/papers_table.py, issue 40)."""

from __future__ import annotations

import importlib.util
import json
import math
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def load(rel: str):
    spec = importlib.util.spec_from_file_location(pathlib.Path(rel).stem, ROOT / rel)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


tts = load("scripts/experiments/time_to_skill.py")


def make_run(root: pathlib.Path, name: str, per_iter: int, evals: list[tuple[int, float, float]]) -> pathlib.Path:
    """A run folder: checkpoint evaluations (samples, completion %, E_b mm) and a log of every
    iteration up to the last evaluation (reward = samples in millions / 10)."""
    d = root / name
    d.mkdir()
    rows = [
        {"iteration": s // per_iter, "samples": s, "reward_per_step": s / 1e7, "start_eps001_completed_pct": c, "e_b_mm": e,
         "acc_pct": 30.0 - e / 100}
        for s, c, e in evals
    ]
    (d / "checkpoint_evals.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    last = evals[-1][0] // per_iter
    log = [
        {"iteration": i, "samples": i * per_iter, "mean_reward": i * per_iter / 1e7, "rollout_s": 1.0, "update_s": 0.5,
         "approx_kl": 0.01 * (i % 3), "clip_frac": 0.1}
        for i in range(1, last + 1)
    ]
    (d / "log.jsonl").write_text("".join(json.dumps(r) + "\n" for r in log))
    return d


@pytest.fixture()
def runs(tmp_path: pathlib.Path) -> list[pathlib.Path]:
    small = 1_000_000
    cpu = 500_000
    return [
        # completion and E_b must hold at the same checkpoint: 1 M fails E_b, 2 M fails completion
        make_run(tmp_path, "run-small-s0", small, [(1_000_000, 95.0, 250.0), (2_000_000, 80.0, 150.0), (3_000_000, 95.0, 190.0),
                                                   (4_000_000, 96.0, 180.0), (5_000_000, 90.0, 170.0), (6_000_000, 92.0, 160.0)]),
        make_run(tmp_path, "run-small-s1", small, [(2_000_000, 50.0, 300.0), (4_000_000, 90.0, 200.0), (5_000_000, 100.0, 150.0),
                                                   (6_000_000, 94.0, 175.0)]),
        make_run(tmp_path, "run-cpu-s0", cpu, [(1_500_000, 89.9, 100.0), (2_000_000, 91.0, 199.0), (2_500_000, 95.0, 160.0),
                                               (3_000_000, 93.0, 150.0), (3_500_000, 99.0, 140.0)]),
        make_run(tmp_path, "run-cpu-s1", cpu, [(3_000_000, 90.0, 190.0), (3_500_000, 92.0, 170.0), (4_000_000, 92.0, 165.0),
                                               (4_500_000, 93.0, 160.0)]),
    ]


def test_time_to_criterion_and_comparison(runs, tmp_path):
    s = [tts.summary(r, rate) for r, rate in zip(runs, [1000.0, 1000.0, 2000.0, 2000.0])]
    assert [x["criterion_samples"] for x in s] == [3_000_000, 4_000_000, 2_000_000, 3_000_000]
    assert s[0]["criterion_hours"] == round(3e6 / 1000 / 3600, 3)
    # plateau: the mean of the last four checkpoints
    assert s[0]["plateau_completion_pct"] == round((96 + 90 + 92 + 95) / 4, 2)
    assert s[0]["plateau_e_b_mm"] == round((190 + 180 + 170 + 160) / 4, 2)
    assert s[0]["plateau_checkpoints"] == [3, 4, 5, 6]
    # logged time up to the criterion: 3 iterations of 1.5 s
    assert s[0]["criterion_logged_hours_shared_machine"] == round(4.5 / 3600, 3)
    c = tts.compare(s)["run"]
    # per seed: hours rounded to 3 decimals, then the median of the seeds
    small_med = (round(3e6 / 1000 / 3600, 3) + round(4e6 / 1000 / 3600, 3)) / 2
    cpu_med = (round(2e6 / 2000 / 3600, 3) + round(3e6 / 2000 / 3600, 3)) / 2
    assert c["median_hours"] == {"small": round(small_med, 4), "cpu": round(cpu_med, 4)}
    assert c["ratio"] == round(round(cpu_med, 4) / round(small_med, 4), 3)
    assert c["seeds"] == {"small": 2, "cpu": 2}
    # cpu's plateaus (completion 94.5 / 91.75, E_b 162.25 / 171.25) lie within small's spread or better
    assert c["cpu_plateau_within_small_spread_or_better"] is True


def test_comparison_flags_a_lower_plateau_and_an_unmet_seed(runs):
    s = [tts.summary(r, 1000.0) for r in runs]
    s[3]["plateau_e_b_mm"] = 500.0  # worse than small's worst seed
    s[1]["criterion_hours"] = None  # a small seed that never met the criterion
    c = tts.compare(s)["run"]
    assert c["cpu_plateau_within_small_spread_or_better"] is False
    assert c["median_hours"]["small"] is None and c["ratio"] is None
    # small seed 1 was evaluated to 6 M samples at 1000/s (1.667 h) without meeting it: small's
    # median is at least (0.833 + 1.667) / 2 h and the ratio at most cpu's median over that
    small_floor = round((round(3e6 / 1000 / 3600, 3) + 6e6 / 1000 / 3600) / 2, 4)
    assert c["median_hours_at_least"]["small"] == small_floor
    assert c["ratio_at_most"] == round(c["median_hours"]["cpu"] / small_floor, 3) and "ratio_at_least" not in c
    # the other way round: an unmet cpu seed bounds the ratio from below
    s[1]["criterion_hours"] = 4e6 / 1000 / 3600
    s[2]["criterion_hours"] = None
    c = tts.compare(s)["run"]
    cpu_floor = round((3.5e6 / 1000 / 3600 + round(3e6 / 1000 / 3600, 3)) / 2, 4)
    assert c["median_hours_at_least"]["cpu"] == cpu_floor
    assert c["ratio_at_least"] == round(cpu_floor / c["median_hours"]["small"], 3) and "ratio_at_most" not in c


def test_command_line_writes_the_comparison(runs, tmp_path):
    rates = tmp_path / "rates.json"
    rates.write_text(json.dumps({"run-small": 1000, "run-cpu": 2000}))
    out = tmp_path / "tts.json"
    p = subprocess.run([sys.executable, str(ROOT / "scripts/experiments/time_to_skill.py"), str(rates), *map(str, runs), "--json", str(out)],
                       capture_output=True, text=True, check=True)
    assert "ratio cpu/small" in p.stdout
    data = json.loads(out.read_text())
    assert [r["run"] for r in data["runs"]] == [r.name for r in runs]
    assert data["comparison"]["run"]["ratio"] is not None
    # the plateaus compare at equal samples: up to the 3.5 M of the shortest run (run-cpu-s0)
    assert {r["run"]: r["plateau_end_samples"] for r in data["runs"]} == {r.name: 3_500_000 for r in runs} | {"run-small-s0": 3_000_000, "run-small-s1": 2_000_000}
    small0 = next(r for r in data["runs"] if r["run"] == "run-small-s0")
    assert small0["plateau_completion_pct"] == round((95 + 80 + 95) / 3, 2) and small0["final_completion_pct"] == round((96 + 90 + 92 + 95) / 4, 2)
    # a run folder without a rate is an error that names it
    rates.write_text(json.dumps({"run-small": 1000}))
    p = subprocess.run([sys.executable, str(ROOT / "scripts/experiments/time_to_skill.py"), str(rates), str(runs[2])],
                       capture_output=True, text=True)
    assert p.returncode != 0 and "run-cpu-s0" in p.stderr


def test_papers_table_row(tmp_path):
    d = tmp_path / "layup-small-s0"
    d.mkdir()
    (d / "checkpoint.txt").write_text("checkpoint: x/iter_001000.safetensors\niteration: 1000\nsamples: 8192000\n")
    (d / "config.toml").write_text('[env]\nnum_envs = 256\n[ppo]\nhidden = [1024, 512, 512]\nmini_epochs = 6\nlr = 2e-5\n')
    ev = {
        "nominal": {"acc_percent": 40.04, "acc_ceiling_percent": 69.6, "e_b_mpjpe_mm": 151.4, "e_o_mpjpe_mm": 99.6, "e_cg": 0.1234,
                    "nr": 0.5, "fall_rate": 0.25},
        "v2": {"sr": {"031": 0.25}, "eps_nsr": {"031": 0.125}, "nr": {"031": 0.4321}, "tsr_mean": None},
        "skillmimic": {"per_skill": {"031": {"success_rate": 0.5, "ci95": [0.375, 0.625], "fall_rate": 0.0625}}},
    }
    (d / "eval-papers.json").write_text(json.dumps(ev))
    (d / "eval-start-eps0.01.json").write_text(json.dumps({"nominal": {"fall_rate": 0.125}}))
    p = subprocess.run([sys.executable, str(ROOT / "scripts/results/papers_table.py"), str(d)], capture_output=True, text=True, check=True)
    row = p.stdout.strip().splitlines()[-1]
    assert row == ("| layup-small-s0 | 031 | 256 envs, [1024, 512, 512], 6 ep., lr 2e-05 | 8.19 M | 50.0 (37.5–62.5), falls 6.2 "
                   "| 25.0 | – | 12.5 | 0.432 | 40.0 (69.6) | 151 | 100 | 0.123 | 87.5 |")
    # with the clip frames where the start test's falls ended (eval's per-skill fall_frames)
    q = {"count": 8, "min": 88, "q1": 90, "median": 93, "q3": 95, "max": 120}
    start = {"nominal": {"fall_rate": 0.125, "per_skill": {"031": {"fall_frames": q}}}}
    (d / "eval-start-eps0.01.json").write_text(json.dumps(start))
    p = subprocess.run([sys.executable, str(ROOT / "scripts/results/papers_table.py"), str(d)], capture_output=True, text=True, check=True)
    assert p.stdout.strip().splitlines()[-1].endswith("| 87.5; falls at frame 93 (90–95) |")
    # a folder without the evaluation is an error that names the file
    (d / "eval-papers.json").unlink()
    p = subprocess.run([sys.executable, str(ROOT / "scripts/results/papers_table.py"), str(d)], capture_output=True, text=True)
    assert p.returncode != 0 and "eval-papers.json" in p.stderr


def test_same_log_ignores_timings_and_names_the_first_difference(tmp_path):
    import gzip

    same_log = load("scripts/results/same_log.py")
    ref = [{"iteration": i, "mean_reward": 0.1 * i, "rollout_s": 1.0, "samples_per_s": 9.0} for i in (1, 2, 3)]
    with gzip.open(tmp_path / "ref.jsonl.gz", "wt") as f:
        f.write("".join(json.dumps(r) + "\n" for r in ref))
    # a shorter rerun with other timings reproduces
    rerun = [dict(r, rollout_s=5.0, samples_per_s=1.0) for r in ref[:2]]
    (tmp_path / "rerun.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rerun))
    cmd = [sys.executable, str(ROOT / "scripts/results/same_log.py"), str(tmp_path / "ref.jsonl.gz"), str(tmp_path / "rerun.jsonl")]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["identical_rows"] == 2 and out["first_difference"] is None
    # a last digit of one value differs: iteration 2 is named with its field
    rerun[1]["mean_reward"] = 0.2000000000000001
    got = same_log.compare(ref, rerun)
    assert got["identical_rows"] == 1 and got["first_difference"] == {"iteration": 2, "fields": ["mean_reward"]}
    # more rows than the reference is a difference
    got = same_log.compare(ref[:1], ref[:2])
    assert got["first_difference"]["iteration"] == 2


def test_follow_summary_blocks_and_evaluations(tmp_path):
    """hsi_follow_summary.py on a hand-built 60-iteration run: one block of 50 and one of 10, two
    evaluation files sorted by iteration, reference before rest; and the committed walks-20m
    summary is what the script prints from the committed log and evaluations."""
    terms = lambda i: [["follow", i / 100], ["power", -0.5], ["style", 1.0 if i <= 50 else 0.0]]  # noqa: E731
    log = [
        {"iteration": i, "samples": 100 * i, "samples_per_s": 10.0 * (1 + i % 2), "rollout_s": 30.0, "update_s": 6.0,
         "episode_length": float(i), "early_terminations": 1.0 if i <= 50 else 0.5, "reward_terms": terms(i)}
        for i in range(1, 61)
    ]
    (tmp_path / "log.jsonl").write_text("".join(json.dumps(r) + "\n" for r in log))
    ev = {"mean_episode_length": 123.45, "early_termination_rate": 0.25, "metrics": {"error_m": 0.3},
          "final_metrics": {"success": 0.75, "error_m": 0.5}}
    for name in ("eval_rest_start_it60.json", "eval_reference_start_it60.json", "eval_reference_start_it5.json"):
        (tmp_path / name).write_text(json.dumps(ev))
    (tmp_path / "eval_reference_start.json").write_text(json.dumps(ev))  # no iteration: not listed
    script = str(ROOT / "scripts/experiments/hsi_follow_summary.py")
    lines = subprocess.run([sys.executable, script, str(tmp_path)], capture_output=True, text=True, check=True).stdout.splitlines()
    assert lines[1] == "iters 60 samples 6000 mean samples/s 15 rollout + update 0.60 h"
    # block 1-50: mean length 25.5, follow mean 0.255; block 51-60: length 55.5, follow 0.555
    assert lines[2] == "it 1-50: eplen 25.5 early 1.000 follow 0.255 power -0.500 style 1.000"
    assert lines[3] == "it 51-60: eplen 55.5 early 0.500 follow 0.555 power -0.500 style 0.000"
    assert [ln.split(":")[0] for ln in lines[4:]] == ["it 5 reference starts", "it 60 reference starts", "it 60 rest starts"]
    assert lines[5].endswith("len 123.5 ended early 0.250 success 0.7500 error mean 0.300 at end 0.500")
    committed = ROOT / "docs/results/tokenhsi-follow/walks-20m"
    out = subprocess.run([sys.executable, script, str(committed)], capture_output=True, text=True, check=True).stdout
    assert out == (committed / "summary.txt").read_text()


def _merge_many(args: tuple[str, int, int]) -> None:
    table, first, count = args
    ev = load("scripts/results/eval_checkpoints.py")
    for it in range(first, first + count):
        ev.merge(pathlib.Path(table), it, {"iteration": it, "samples": it * 8, "x": it})


def test_checkpoint_table_writers_keep_each_others_rows(tmp_path):
    """scripts/results/eval_checkpoints.py: two evaluators of one run (a watcher beside
    time_to_skill.sh's own pass) rewrite the table whole after each checkpoint; each rewrite
    re-reads it under a lock, so neither drops the other's rows, and a later evaluation adds its
    fields to a row without losing the earlier ones."""
    import multiprocessing

    ev = load("scripts/results/eval_checkpoints.py")
    table = tmp_path / "checkpoint_evals.jsonl"
    ev.merge(table, 25, {"iteration": 25, "samples": 200, "reward_per_step": 0.1, "acc_pct": 5.0})
    row = ev.merge(table, 25, {"iteration": 25, "samples": 200, "reward_per_step": 0.2, "e_b_mm": 300.0})
    assert row == {"iteration": 25, "samples": 200, "reward_per_step": 0.2, "acc_pct": 5.0, "e_b_mm": 300.0}
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        pool.map(_merge_many, [(str(table), 1000, 60), (str(table), 2000, 60)])
    rows = ev.read_rows(table)
    assert sorted(rows) == [25, *range(1000, 1060), *range(2000, 2060)]
    assert all(rows[it]["x"] == it for it in rows if it != 25)
    assert [json.loads(line)["iteration"] for line in table.read_text().splitlines()] == sorted(rows)


def test_checkpoint_row_of_the_start_test_names_where_falls_ended():
    """eval_checkpoints.py's "eps" row: completion, E_b, the SkillMimic score and, per skill with
    falls, the median clip frame where they ended (eval's per-skill fall_frames)."""
    ev = load("scripts/results/eval_checkpoints.py")
    q = {"count": 3, "min": 80, "q1": 88, "median": 91, "q3": 97, "max": 99}
    n = {"fall_rate": 0.75, "e_b_mpjpe_mm": 212.34, "per_skill": {"031": {"v1_score": 0.5, "fall_frames": q},
                                                                   "013": {"v1_score": 1.0, "fall_frames": None}}}
    assert ev.fields("eps", n) == {"start_eps001_completed_pct": 25.0, "start_eps001_e_b_mm": 212.3, "start_eps001_v1_score": 0.75,
                                   "start_eps001_fall_frame_median": {"031": 91}}
    # a report written before eval had fall_frames: no medians, no error
    old = {**n, "per_skill": {"031": {"v1_score": 0.5}}}
    assert ev.fields("eps", old)["start_eps001_fall_frame_median"] == {}


def test_tab3_heading_waits_for_a_skill_policy_that_dribbles_for_10_s(tmp_path):
    """Issue 42 item 3: the heading policy is trained only once every dribble of the mixed policy
    reaches the 10-s success threshold; otherwise the script says where each stands and stops."""
    script = ROOT / "scripts/experiments/tab3_heading.sh"
    env = {"PATH": "/usr/bin:/bin", "OUT": str(tmp_path / "runs"), "EVIDENCE": str(tmp_path / "evidence"), "BIN": "/bin/true"}
    missing = subprocess.run(["bash", str(script), "3"], env=env, capture_output=True, text=True)
    assert missing.returncode == 2 and "tab3-mixed-cpu-s3/latest.safetensors not found" in missing.stderr, missing.stderr
    (tmp_path / "runs/tab3-mixed-cpu-s3").mkdir(parents=True)
    (tmp_path / "runs/tab3-mixed-cpu-s3/latest.safetensors").write_bytes(b"")
    (tmp_path / "evidence/tab3-mixed-cpu-s3").mkdir(parents=True)
    rates = {"013": 0.9, "011": 0.3, "012": 0.95}
    per_skill = {k: {"success_rate": r, "fall_rate": 1 - r} for k, r in rates.items()}
    (tmp_path / "evidence/tab3-mixed-cpu-s3/eval-papers.json").write_text(json.dumps({"skillmimic": {"per_skill": per_skill}}))
    p = subprocess.run(["bash", str(script), "3"], env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "dribble left (011): SkillMimic 10-s success 30.0 %, falls 70.0 %" in p.stdout, p.stdout
    assert "no high-level policy trained" in p.stdout and not (tmp_path / "runs/tab3-heading-cpu-s3").exists()


def test_trend_extrapolates_a_log_linear_curve_and_says_when_it_points_nowhere(tmp_path):
    """scripts/results/trend.py on hand-made curves: a metric rising by 20 per tenfold samples from
    10 at 1 M reaches 50 at 100 M; a falling error reaches its target where the line says; a flat
    or receding curve gives no budget; a reached target is named, not extrapolated."""
    tr = load("scripts/results/trend.py")
    rising = [(s, 10 + 20 * math.log10(s / 1e6)) for s in (1e6, 2e6, 4e6, 8e6)]
    got = tr.trend(rising, 50.0, last=1.0)
    assert got["why"] == "extrapolated" and abs(got["extrapolated_samples"] - 1e8) / 1e8 < 1e-9, got
    assert abs(got["slope_per_decade"] - 20) < 1e-9 and got["target_reached_at"] is None
    # only the last half is fitted: an early plateau does not flatten the line
    early = [(s, 0.0) for s in (1e5, 2e5, 3e5, 4e5)]
    assert abs(tr.trend(early + rising, 50.0)["extrapolated_samples"] - 1e8) / 1e8 < 1e-9
    # an error falling by 50 mm per decade from 400 mm at 1 M: 200 mm at 10^4 M
    falling = [(s, 400 - 50 * math.log10(s / 1e6)) for s in (1e6, 3e6, 5e6, 9e6)]
    assert abs(tr.trend(falling, 200.0)["extrapolated_samples"] - 1e10) / 1e10 < 1e-9
    # flat, receding, reached, too short
    assert tr.trend([(s, 30.0) for s in (1e6, 2e6, 3e6, 4e6)], 90.0)["why"] == "the trend does not move towards the target"
    assert tr.trend([(s, 60 - s / 1e6) for s in (1e6, 2e6, 3e6, 4e6)], 90.0)["extrapolated_samples"] is None
    reached = tr.trend(rising + [(9e6, 95.0)], 90.0, last=1.0)
    assert reached["why"] == "reached" and reached["target_reached_at"] == 9e6
    assert tr.trend(rising[:3], 50.0)["why"] == "fewer than 4 evaluated checkpoints"
    # the direction comes from the run's first evaluation, not the fitted window: an error that fell
    # from 400 to 150-160 mm has reached 200 mm at its second checkpoint
    err = [(1e6, 400.0), (2e6, 190.0), *[(s, 160 - s / 1e7) for s in (3e6, 4e6, 5e6, 6e6)]]
    assert tr.trend(err, 200.0)["target_reached_at"] == 2e6
    assert tr.trend(err, 200.0, lower_is_better=False)["target_reached_at"] == 1e6
    # the command line on a run folder, and a missing field named
    (tmp_path / "checkpoint_evals.jsonl").write_text("".join(json.dumps({"iteration": i, "samples": s, "m": m}) + "\n"
                                                               for i, (s, m) in enumerate(rising)))
    script = str(ROOT / "scripts/results/trend.py")
    out = subprocess.run([sys.executable, script, "--metric", "m", "--target", "50", "--last", "1", str(tmp_path)],
                         capture_output=True, text=True, check=True)
    assert json.loads(out.stdout)["extrapolated_samples"] == 100000000
    bad = subprocess.run([sys.executable, script, "--metric", "acc", "--target", "50", str(tmp_path)], capture_output=True, text=True)
    assert bad.returncode != 0 and "'acc'" in bad.stderr

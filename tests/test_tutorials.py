"""The guide's tutorials (docs/tutorials/*.md) run top to bottom, at a tiny budget, so the guide
cannot rot (issue 43).

Each page's fenced ``bash`` and ``python`` blocks run in order, in one fresh working folder per
page that holds links to the checkout's ``motions/``, ``scripts/`` and ``configs/`` (the
tutorials are written to be run from the repository's root). A block whose info string says
``norun`` (```` ```bash,norun ````) is shown, not run: install commands, multi-machine launches.
``skillmimic`` and ``python`` are the project's ``.venv`` ones.

The budget is cut by rewriting the commands' own flags, nothing else:

* ``--iterations N`` → max(2, N // 100) (so a resume to a larger N still has iterations left);
* ``--episodes N`` → 4, ``--steps N`` → 30, ``--epochs N`` → 2;
* Python ``iterations=N`` → 2 and ``.learn(N)`` → ``.learn(2)``.

`SKILLMIMIC_TUTORIAL_FULL=1` runs the pages at their own budget and `SKILLMIMIC_TUTORIAL_DIR=DIR`
keeps each page's folder as `DIR/<page>`: `scripts/docs_pictures.sh` makes the guide's pictures
that way.

Pages that read the BallPlay-M clips (``SKILLMIMIC_SHARED``) get the reference data folder and skip
without it (failing when ``CI`` is set, as every test that needs ``../shared``).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO, find_shared

TUTORIALS = sorted((REPO / "docs" / "tutorials").glob("*.md"))
BLOCK = re.compile(r"^```([a-z]+)([^\n]*)\n(.*?)^```", re.S | re.M)
LINKED = ("motions", "scripts", "configs")


def runnable_blocks(text: str) -> list[tuple[str, str]]:
    """(language, code) of every block the test runs, in page order."""
    return [(lang, code) for lang, info, code in BLOCK.findall(text) if lang in ("bash", "python") and "norun" not in info]


def tiny(code: str) -> str:
    """The block at the test's budget (see the module doc)."""
    if os.environ.get("SKILLMIMIC_TUTORIAL_FULL"):
        return code
    code = re.sub(r"--iterations (\d+)", lambda m: f"--iterations {max(2, int(m.group(1)) // 100)}", code)
    code = re.sub(r"--episodes \d+", "--episodes 4", code)
    code = re.sub(r"--steps \d+", "--steps 30", code)
    code = re.sub(r"--epochs \d+", "--epochs 2", code)
    code = re.sub(r"\biterations=\d[\d_]*", "iterations=2", code)
    return re.sub(r"\.learn\(\d[\d_]*", ".learn(2", code)


def test_every_tutorial_is_in_the_summary_and_has_a_picture_and_commands():
    summary = (REPO / "docs" / "SUMMARY.md").read_text()
    assert len(TUTORIALS) >= 9
    for page in TUTORIALS:
        text = page.read_text()
        assert f"(tutorials/{page.name})" in summary, f"{page.name} is not listed in docs/SUMMARY.md"
        picture = r"!\[[^\]]*\]\(img/[^)]+\)|<video [^>]*src=\"img/[^\"]+\""
        assert re.search(picture, text), f"{page.name} has no picture or video (img/...)"
        assert runnable_blocks(text), f"{page.name} has no command the test runs"


def test_budget_rewrite(monkeypatch):
    monkeypatch.delenv("SKILLMIMIC_TUTORIAL_FULL", raising=False)
    assert tiny("skillmimic train --iterations 400 --episodes 64") == "skillmimic train --iterations 4 --episodes 4"
    assert tiny("--iterations 100 --steps 240 --epochs 1000") == "--iterations 2 --steps 30 --epochs 2"
    assert tiny("sm.train(iterations=200); model.learn(204_800)") == "sm.train(iterations=2); model.learn(2)"


@pytest.mark.parametrize("page", TUTORIALS, ids=lambda p: p.stem)
def test_tutorial_runs(page: Path, tmp_path: Path):
    text = page.read_text()
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env.pop("SKILLMIMIC_TEST_WRITE_PAUSE_MS", None)
    if "SKILLMIMIC_SHARED" in text:
        shared = find_shared()
        if shared is None:
            msg = f"{page.name} needs the reference data (SKILLMIMIC_SHARED or ../shared)"
            if os.environ.get("CI"):
                pytest.fail(msg + " and CI is set")
            pytest.skip(msg)
        env["SKILLMIMIC_SHARED"] = str(shared)
    if os.environ.get("SKILLMIMIC_TUTORIAL_DIR"):
        tmp_path = Path(os.environ["SKILLMIMIC_TUTORIAL_DIR"]).resolve() / page.stem
        tmp_path.mkdir(parents=True, exist_ok=True)
    for name in LINKED:
        if not (tmp_path / name).exists():
            (tmp_path / name).symlink_to(REPO / name)
    for k, (lang, code) in enumerate(runnable_blocks(text)):
        code = tiny(code)
        cmd = ["bash", "-euo", "pipefail", "-c", code] if lang == "bash" else [sys.executable, "-c", code]
        r = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
        if os.environ.get("SKILLMIMIC_SHOW_TUTORIALS"):
            print(f"--- {page.name} block {k} ({lang})\n{code}\n--- output\n{r.stdout}{r.stderr}")
        assert r.returncode == 0, f"{page.name}, block {k} ({lang}) failed:\n{code}\n--- stdout\n{r.stdout[-4000:]}\n--- stderr\n{r.stderr[-4000:]}"

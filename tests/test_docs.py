"""The guide (docs/, issue 43): what the site build alone cannot catch.

* the README stays short, its links resolve, its commands are the ones CI and set-up run, and its
  Python example runs (at a tiny budget);
* every page under docs/ is in the guide's table of contents;
* the link checker of ``scripts/docs.sh`` finds broken links (tested on a crafted site);
* the built site's Python API reference covers every public name of ``skillmimic_rs``;
* the architecture picture matches the crates' dependencies; the observation-layout page matches
  the environments it describes.

The site itself is built, and its links checked, by ``scripts/docs.sh`` in the test command
before pytest runs; the tests of the built site skip when it is absent (failing when ``CI`` is
set).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "scripts"))
import check_links  # noqa: E402

from test_tutorials import runnable_blocks, tiny  # noqa: E402

SITE = REPO / "target" / "book"


def built_site() -> Path:
    if not (SITE / "index.html").is_file():
        msg = f"{SITE} is not built (./scripts/docs.sh builds it; scripts/test.sh runs it before pytest)"
        if os.environ.get("CI"):
            pytest.fail(msg + " and CI is set")
        pytest.skip(msg)
    return SITE


# ---------------------------------------------------------------- README


def test_readme_is_short_and_names_the_two_commands():
    text = (REPO / "README.md").read_text()
    assert len(text.splitlines()) <= 160, "README.md should stay about 150 lines; move detail into docs/"
    assert "./scripts/demo.sh" in text and "./scripts/test.sh" in text
    ci = (REPO / ".ci" / "run").read_text()
    assert "./scripts/test.sh" in ci, ".ci/run must run the README's test command"
    assert "train" in (REPO / "scripts" / "demo.sh").read_text()


def test_readme_links_resolve():
    text = (REPO / "README.md").read_text()
    targets = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text) + re.findall(r'src="([^"]+)"', text)
    local = [t for t in targets if not re.match(r"[a-z]+:", t)]
    assert local, "the README links into the guide"
    for t in local:
        assert (REPO / t).exists(), f"README.md links to {t}, which does not exist"


def test_readme_python_example_runs(tmp_path):
    blocks = [code for lang, code in runnable_blocks((REPO / "README.md").read_text()) if lang == "python"]
    assert blocks, "the README has a Python example"
    for code in blocks:
        r = subprocess.run([sys.executable, "-c", tiny(code)], cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, f"README example failed:\n{code}\n{r.stderr[-3000:]}"


# ---------------------------------------------------------------- the guide's pages


def test_every_page_is_in_the_table_of_contents():
    summary = (REPO / "docs" / "SUMMARY.md").read_text()
    listed = set(re.findall(r"\]\(([^)]+\.md)\)", summary))
    pages = {p.relative_to(REPO / "docs").as_posix() for p in (REPO / "docs").rglob("*.md")} - {"SUMMARY.md"}
    assert pages - listed == set(), f"pages missing from docs/SUMMARY.md: {sorted(pages - listed)}"
    assert listed - pages == set(), f"docs/SUMMARY.md lists missing pages: {sorted(listed - pages)}"


def _site(tmp_path: Path, pages: dict[str, str]) -> Path:
    for name, body in pages.items():
        p = tmp_path / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(f"<html><body>{body}</body></html>")
    return tmp_path


def test_link_checker_finds_every_kind_of_broken_link(tmp_path):
    site = _site(
        tmp_path,
        {
            "index.html": '<h2 id="top">t</h2><a href="a/page.html#sec">ok</a><a href="#top">self</a>'
            '<a href="https://example.org/x">external</a><img src="img/pic.png">',
            "a/page.html": '<h2 id="sec">s</h2><a href="../index.html">up</a><a href="missing.html">gone</a>'
            '<a href="../index.html#nowhere">bad anchor</a><a href="../../outside.html">out</a>',
            "img/pic.png": "",
        },
    )
    problems = check_links.broken_links(site)
    assert sorted(problems) == sorted(
        [
            "a/page.html: missing.html (no such file)",
            "a/page.html: ../index.html#nowhere (no anchor #nowhere)",
            "a/page.html: ../../outside.html (leaves the site)",
        ]
    ), problems
    (site / "a" / "page.html").write_text('<h2 id="sec">s</h2><a href="../index.html#top">up</a>')
    assert check_links.broken_links(site) == []


def test_built_site_has_no_broken_link():
    assert check_links.broken_links(built_site()) == []


def test_python_api_reference_covers_every_public_name():
    import pkgutil

    import skillmimic_rs

    site = built_site()
    page = (site / "api" / "python" / "skillmimic_rs.html").read_text()
    ids = set(re.findall(r'id="([^"]+)"', page))
    missing = [n for n in skillmimic_rs.__all__ if n not in ids]
    assert not missing, f"the Python API reference lacks {missing}"
    for m in pkgutil.iter_modules(skillmimic_rs.__path__):
        if not m.name.startswith("_"):
            assert (site / "api" / "python" / "skillmimic_rs" / f"{m.name}.html").is_file(), f"no page for skillmimic_rs.{m.name}"
    for crate in ("skillmimic_core", "skillmimic_sim", "skillmimic_motion", "skillmimic_nn", "skillmimic_env", "skillmimic_learn", "skillmimic_cli"):
        assert (site / "api" / "rust" / crate / "index.html").is_file(), f"no rustdoc for {crate}"


def test_importing_the_train_module_keeps_the_train_function():
    # `python -m skillmimic_rs.train` is the torchrun entry point; importing that submodule must
    # not replace the package's function `train` (Python's import system sets the attribute)
    r = subprocess.run(
        [sys.executable, "-c", "import skillmimic_rs, skillmimic_rs.train, sys; "
         "assert skillmimic_rs.train is skillmimic_rs.api.train, skillmimic_rs.train; "
         "assert sys.modules['skillmimic_rs.train'].__name__ == 'skillmimic_rs.train'"],
        capture_output=True, text=True,
    )
    assert r.returncode == 0, r.stderr


def test_architecture_picture_matches_the_crates():
    r = subprocess.run([sys.executable, str(REPO / "scripts" / "architecture_svg.py"), "--check"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


# ---------------------------------------------------------------- observation layouts


def _table(text: str, heading: str) -> list[list[str]]:
    """Rows (cells stripped) of the first table after `heading`."""
    section = text.split(heading, 1)[1]
    rows = []
    for line in section.splitlines()[1:]:
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not set(cells[0]) <= set("-"):
                rows.append(cells)
        elif rows:
            break
    return rows[1:]  # without the header


def _width(task: str, character: str = "") -> int:
    import skillmimic_rs

    cfg = {"env": {"character": character}} if character else None
    env = skillmimic_rs.VecEnv(1, cfg, task=task)
    try:
        return int(env.single_observation_space.shape[0])
    finally:
        env.close()


def test_observation_page_matches_the_environments():
    import skillmimic_rs

    text = (REPO / "docs" / "concepts" / "observations.md").read_text()
    rows = _table(text, "## SkillMimic's skill policy: 902")
    got = {r[0].strip("`"): tuple(int(x) for x in r[1].split(":")) for r in rows}
    assert got == {k: tuple(v) for k, v in skillmimic_rs.OBS_BLOCKS.items()}
    for r in rows:
        lo, hi = (int(x) for x in r[1].split(":"))
        assert int(r[2]) == hi - lo, r
    for name, width, blocks in _table(text, "## The character part (proprioception)"):
        character = re.search(r"`(\w+)`", name).group(1)
        assert _width("stand", character) == int(width) + 3, name  # stand adds 3 columns
        assert sum(int(w) for w in re.findall(r"` (\d+)", blocks)) == int(width), name
    for task, characters, widths, _ in _table(text, "## Task parts"):
        task = task.strip("`")
        for character, width in zip(characters.split(" / "), widths.split(" / ")):
            assert _width(task, character) == int(width), (task, character)


def test_observation_page_high_level_widths(tmp_path):
    import skillmimic_rs

    text = (REPO / "docs" / "concepts" / "observations.md").read_text()
    para = text.split("The high-level tasks observe", 1)[1].split("\n\n", 1)[0]
    assert "(838 columns" in para
    claims = dict(re.findall(r"`(\w+)` (\d+)", para))
    assert set(claims) == {"heading", "circling", "throwing", "scoring", "steering", "reach"}, claims
    skill = skillmimic_rs.train(preset="tiny", iterations=1, num_envs=8, out=str(tmp_path / "skill"), no_video=True)
    for task, w in claims.items():
        env = skillmimic_rs.VecEnv(1, task=task, llc=skill["checkpoint"])
        try:
            assert env.single_observation_space.shape[0] == 838 + int(w), task
        finally:
            env.close()

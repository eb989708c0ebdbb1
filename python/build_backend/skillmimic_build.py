"""PEP 517 build backend of skillmimic-rs: maturin, plus one preparation step.

The Rust core links the ``libmujoco.so.3.17.0`` shipped in the ``mujoco`` wheel (a build
requirement). mujoco-rs wants a folder holding a file named ``libmujoco.so``; this backend makes
one under ``target/`` that points at the build environment's library and hands it to cargo through
``MUJOCO_DYNAMIC_LINK_DIR``. At run time the extension finds the installed ``mujoco`` package's
library next to it (run-time path ``$ORIGIN/../mujoco``), so one copy is loaded per process.
"""

from __future__ import annotations

import os
import pathlib

import maturin
from maturin import get_requires_for_build_sdist, get_requires_for_build_wheel  # noqa: F401
from maturin import prepare_metadata_for_build_wheel, build_sdist  # noqa: F401

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _link_mujoco() -> None:
    import mujoco

    src = pathlib.Path(mujoco.__file__).parent / f"libmujoco.so.{mujoco.__version__}"
    if not src.exists():
        raise RuntimeError(f"{src} not found: the mujoco wheel does not ship the expected library")
    link_dir = ROOT / "target" / "pip-mujoco" / mujoco.__version__
    link_dir.mkdir(parents=True, exist_ok=True)
    for name in (src.name, "libmujoco.so"):
        target = link_dir / name
        if target.is_symlink() or target.exists():
            target.unlink()
        target.symlink_to(src)
    os.environ["MUJOCO_DYNAMIC_LINK_DIR"] = str(link_dir)


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    _link_mujoco()
    return maturin.build_wheel(wheel_directory, config_settings, metadata_directory)


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    _link_mujoco()
    return maturin.build_editable(wheel_directory, config_settings, metadata_directory)


def prepare_metadata_for_build_editable(metadata_directory, config_settings=None):
    return maturin.prepare_metadata_for_build_editable(metadata_directory, config_settings)


def get_requires_for_build_editable(config_settings=None):
    return maturin.get_requires_for_build_editable(config_settings)

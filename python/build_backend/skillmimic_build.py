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
import shutil

# Never let maturin fetch a Rust toolchain behind the user's back (it would otherwise download
# one into a temporary folder when cargo is missing, which looks like a hang), and silence its
# warning that `build-backend` is not maturin: this file is the backend and calls maturin.
os.environ.setdefault("MATURIN_NO_INSTALL_RUST", "1")
os.environ.setdefault("MATURIN_NO_MISSING_BUILD_BACKEND_WARNING", "1")

import maturin  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]


class RustMissing(RuntimeError):
    """Raised when cargo is not on PATH."""


def _require_cargo() -> None:
    """Fail at once, naming Rust, when cargo is not on PATH (a source build needs it)."""
    if shutil.which("cargo"):
        return
    hint = ""
    home_cargo = pathlib.Path.home() / ".cargo" / "bin" / "cargo"
    if home_cargo.exists():
        hint = f" ({home_cargo} exists: run `. \"$HOME/.cargo/env\"` to put it on PATH)"
    raise RustMissing(
        "skillmimic-rs builds its Rust core from source and needs Rust (cargo) on PATH, which was not found"
        f"{hint}. Install Rust from https://rustup.rs (then `. \"$HOME/.cargo/env\"`), or install a prebuilt "
        "wheel instead: `pip install skillmimic_rs-*.whl` (build one once with `pip wheel . --no-deps -w dist` "
        "on a machine with Rust; docs/getting-started/install.md)."
    )


def get_requires_for_build_wheel(config_settings=None):
    _require_cargo()
    return maturin.get_requires_for_build_wheel(config_settings)


def get_requires_for_build_editable(config_settings=None):
    _require_cargo()
    return maturin.get_requires_for_build_editable(config_settings)


def get_requires_for_build_sdist(config_settings=None):
    return []  # an sdist is the source tree: no Rust needed to write it


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    _require_cargo()
    return maturin.prepare_metadata_for_build_wheel(metadata_directory, config_settings)


def build_sdist(sdist_directory, config_settings=None):
    return maturin.build_sdist(sdist_directory, config_settings)


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
    _require_cargo()
    _link_mujoco()
    return maturin.build_wheel(wheel_directory, config_settings, metadata_directory)


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    _require_cargo()
    _link_mujoco()
    return maturin.build_editable(wheel_directory, config_settings, metadata_directory)


def prepare_metadata_for_build_editable(metadata_directory, config_settings=None):
    _require_cargo()
    return maturin.prepare_metadata_for_build_editable(metadata_directory, config_settings)


"""Make in-process rendering safe for a later ``import triton`` (PyTorch's compiler).

Headless rendering (MuJoCo over EGL, Python's ``mujoco.Renderer`` or the Rust video writer) loads
Mesa's driver, which brings the system ``libLLVM`` into the process with global symbols. Triton's
``libtriton`` carries its own LLVM; loaded after Mesa's, it binds to the wrong one and the process
dies with a segmentation fault (measured here: render a frame, then ``import triton.knobs`` —
which ``torch.compile`` and SB3 on recent PyTorch do — crashes; the other order works). So before
the first render in a process we load ``triton._C.libtriton`` when triton is installed and not
loaded yet (0.4 s, once). Without triton this does nothing.
"""

from __future__ import annotations

import importlib.util
import sys

_done = False


def before_rendering() -> None:
    """Call before anything in this process may start an EGL context."""
    global _done
    if _done:
        return
    _done = True
    if "triton" in sys.modules or importlib.util.find_spec("triton") is None:
        return
    try:
        importlib.import_module("triton._C.libtriton")
    except Exception:  # a broken triton install must not stop rendering
        pass

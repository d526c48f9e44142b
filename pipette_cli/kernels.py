"""Numeric kernels that are the same on every x86-64 CPU with AVX2: ``PIPETTE_PORTABLE=1``.

OpenBLAS (under ``numpy.linalg`` and ``@``), torch and oneDNN pick their kernels from the CPU they
start on, and kernels for other instruction sets round differently. A scripted demonstration
recorded on an AVX-512 machine then differs in the last bits from the same seed recorded on an
AVX2-only machine (measured: forcing OpenBLAS's AVX2 kernel changes ``pipette collect``'s actions
on this project's AVX-512 machine; numpy's own SIMD loops do not), and a policy trained on either
moves by several episodes in 50 (``docs/reproduction/plan.md``, amendment 8). On one machine every
run is deterministic either way.

With ``PIPETTE_PORTABLE=1`` the package sets, before numpy or torch load, what every such CPU
runs: OpenBLAS's Haswell kernels, torch's AVX2 kernels and oneDNN's AVX2 code
(:data:`PORTABLE`); a variable the user set already wins. It is opt-in: on an AVX-512 machine it
changes the last bits of what that machine made before. Where it cannot act (another
architecture, a CPU without AVX2 and FMA, numpy already imported) :func:`pin` says why.
"""

from __future__ import annotations

import ctypes
import os
import platform
import sys
from collections.abc import MutableMapping
from functools import cache
from pathlib import Path

REQUEST = "PIPETTE_PORTABLE"
PORTABLE = {"OPENBLAS_CORETYPE": "Haswell", "ATEN_CPU_CAPABILITY": "avx2", "ONEDNN_MAX_CPU_ISA": "AVX2"}
"""The kernels of an AVX2 + FMA x86-64 CPU, for OpenBLAS, torch's ATen and oneDNN."""
NEEDS = {"avx2", "fma"}


def cpu_field(name: str, cpuinfo: Path = Path("/proc/cpuinfo")) -> str | None:
    """Field ``name`` of the first CPU in ``cpuinfo`` (``flags``, ``model name``), or None where there is none."""
    try:
        text = cpuinfo.read_text()
    except OSError:
        return None
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == name:
            return value.strip()
    return None


def cpu_flags(cpuinfo: Path = Path("/proc/cpuinfo")) -> set[str]:
    """The instruction-set flags of the first CPU in ``cpuinfo`` (empty where there is none)."""
    return set((cpu_field("flags", cpuinfo) or "").split())


def pin(environ: MutableMapping[str, str] = os.environ, flags: set[str] | None = None) -> str | None:
    """Set :data:`PORTABLE` in ``environ`` when ``PIPETTE_PORTABLE=1`` asks for it; ``None`` when it
    did (or nothing was asked), else why it could not."""
    if environ.get(REQUEST, "") not in ("1", "true", "yes"):
        return None
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return f"{REQUEST}: the portable kernels are x86-64's; this is {platform.machine()}"
    missing = NEEDS - (cpu_flags() if flags is None else flags)
    if missing:
        return f"{REQUEST}: this CPU lacks {', '.join(sorted(missing))} (or /proc/cpuinfo cannot tell); kernels left as they are"
    if "numpy" in sys.modules:
        return f"{REQUEST}: numpy was imported before pipette_cli, so OpenBLAS chose its kernel already; set it before Python starts"
    for key, value in PORTABLE.items():
        environ.setdefault(key, value)
    return None


@cache
def blas_kernel() -> str:
    """The kernel OpenBLAS runs under numpy in this process (``SkylakeX``, ``Haswell``, ...), or ``unknown``."""
    import numpy  # noqa: F401  # deferred: numpy (loads OpenBLAS, which must not start before pin())

    try:
        maps = Path("/proc/self/maps").read_text()
        library = next(line.split()[-1] for line in maps.splitlines() if "openblas" in line.lower())
        handle = ctypes.CDLL(library)
    except (OSError, StopIteration):
        return "unknown"
    for name in ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename", "openblas_get_corename"):
        get = getattr(handle, name, None)
        if get is not None:
            get.restype = ctypes.c_char_p
            return (get() or b"unknown").decode()
    return "unknown"

"""PIPETTE_PORTABLE=1: the CPU kernels every x86-64 CPU with AVX2 runs, set before numpy and torch load."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from pipette_cli import kernels

PROBE = (
    "import json, os, pipette_cli, torch; from pipette_cli.kernels import blas_kernel; "
    "print(json.dumps({'blas': blas_kernel(), 'torch': torch.backends.cpu.get_cpu_capability(), "
    "'onednn': os.environ.get('ONEDNN_MAX_CPU_ISA')}))"
)


def probe(**env: str) -> tuple[dict[str, str], str]:
    clean = {k: v for k, v in os.environ.items() if k not in (*kernels.PORTABLE, kernels.REQUEST)}
    done = subprocess.run(
        [sys.executable, "-c", PROBE], env={**clean, **env}, capture_output=True, text=True, timeout=120, check=True
    )
    return json.loads(done.stdout.strip().splitlines()[-1]), done.stderr


def test_portable_kernels_are_the_avx2_ones_where_the_cpu_has_them() -> None:
    portable, warned = probe(PIPETTE_PORTABLE="1")
    if kernels.cpu_flags() >= kernels.NEEDS:
        assert portable == {"blas": "Haswell", "torch": "AVX2", "onednn": "AVX2"} and not warned
        native, _ = probe()
        assert native["onednn"] is None  # nothing pinned unless asked
    else:  # a CPU without AVX2: nothing pinned, and the run says why
        assert portable["onednn"] is None and "lacks" in warned


def test_a_kernel_the_user_chose_wins() -> None:
    chosen, _ = probe(PIPETTE_PORTABLE="1", OPENBLAS_CORETYPE="Nehalem")
    assert chosen["blas"] == "Nehalem"


def test_pin_sets_what_is_missing_or_says_why_it_cannot(monkeypatch: pytest.MonkeyPatch) -> None:
    import numpy  # noqa: F401  # loaded here, as in a script that imports numpy before pipette_cli

    env: dict[str, str] = {}
    assert kernels.pin(env, flags=set()) is None and env == {}  # not asked: nothing to do
    env = {kernels.REQUEST: "1"}
    assert "lacks avx2, fma" in (kernels.pin(env, flags={"sse2"}) or "")
    assert "numpy was imported before pipette_cli" in (kernels.pin(env, flags={"avx2", "fma"}) or "")
    assert set(env) == {kernels.REQUEST}
    monkeypatch.delitem(sys.modules, "numpy")  # as at the start of `pipette`
    env["OPENBLAS_CORETYPE"] = "Nehalem"
    assert kernels.pin(env, flags={"avx2", "fma"}) is None
    assert env == {**kernels.PORTABLE, kernels.REQUEST: "1", "OPENBLAS_CORETYPE": "Nehalem"}  # the user's choice kept
    monkeypatch.setattr(kernels.platform, "machine", lambda: "aarch64")
    assert "x86-64's; this is aarch64" in (kernels.pin({kernels.REQUEST: "1"}, flags={"avx2", "fma"}) or "")


def test_cpu_flags_come_from_the_first_cpu(tmp_path) -> None:
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nflags\t\t: fpu sse2 avx2 fma\n\nprocessor\t: 1\nflags\t\t: fpu\n")
    assert kernels.cpu_flags(info) == {"fpu", "sse2", "avx2", "fma"}
    info.write_text("model name\t: Some CPU @ 2 GHz\nflags\t\t: fpu\n")
    assert kernels.cpu_field("model name", info) == "Some CPU @ 2 GHz" and kernels.cpu_field("microcode", info) is None
    assert kernels.cpu_flags(tmp_path / "absent") == set()

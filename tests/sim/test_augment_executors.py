"""Augmentation executors: Ray on a loopback-only local cluster, and a SIGKILLed run that resumes."""

from __future__ import annotations

import numpy as np
import pytest
import ray  # a dev dependency: this test must run, not skip

from pipette_cli.augment.run import augment
from pipette_cli.augment.specs import AugmentSpec, VariantSpec
from pipette_cli.demos.collect import collect
from pipette_cli.demos.store import read_episode, scan
from pipette_cli.errors import plural
from pipette_cli.registry import load_registry
from pipette_cli.specs.perturbations import SpeedSpec

pytestmark = pytest.mark.render


def test_ray_and_local_executors_keep_identical_episodes(tmp_path) -> None:
    task = load_registry([]).get("PickUpTestTube")
    raw = tmp_path / "raw.h5"
    assert len(collect(task, raw, episodes=2, seed=3, image_size=16).added) == 2
    spec = AugmentSpec(variants=[VariantSpec(name="original"), VariantSpec(name="speed", perturbations=[SpeedSpec()])])
    local = augment(task, raw, tmp_path / "local.h5", spec, workers=1)
    remote = augment(task, raw, tmp_path / "ray.h5", spec, workers=2, executor="ray")
    assert not ray.is_initialized()  # the run started and stopped its own local cluster
    assert local.report == remote.report
    ours, theirs = scan(tmp_path / "local.h5").episodes, scan(tmp_path / "ray.h5").episodes
    assert len(ours) == len(theirs) == 4
    for a, b in zip(ours, theirs, strict=True):
        ea, eb = read_episode(a, images=True), read_episode(b, images=True)
        assert ea.attrs["augment_variant"] == eb.attrs["augment_variant"]
        np.testing.assert_array_equal(ea.arrays["sim_state"], eb.arrays["sim_state"])
        for camera in ea.images:
            np.testing.assert_array_equal(ea.images[camera], eb.images[camera])


def test_killed_augment_leaves_readable_output_and_resumes(tmp_path) -> None:
    """SIGKILL `pipette augment` after its first demo; the output stays readable, a rerun finishes."""
    import json
    import os
    import signal
    import subprocess
    import sys
    import time

    from pipette_cli.augment.run import ledger_path

    task = load_registry([]).get("PickUpTestTube")
    raw, out = tmp_path / "raw.h5", tmp_path / "aug.h5"
    assert len(collect(task, raw, episodes=3, seed=3, image_size=16).added) == 3
    command = [
        sys.executable,
        "-m",
        "pipette_cli.cli.main",
        "augment",
        "PickUpTestTube",
        "-i",
        str(raw),
        "-o",
        str(out),
        "--variants",
        "original,speed,light",
        "--workers",
        "1",
    ]
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env={**os.environ})
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:
        ledger = ledger_path(out)
        if ledger.exists() and len(json.loads(ledger.read_text())["demos"]) >= 1:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "augment finished before it could be killed; make the run longer"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    done = len(json.loads(ledger_path(out).read_text())["demos"])
    assert 1 <= done < 3
    before = scan(out).episodes if out.exists() else []  # a valid file, or none yet: never a broken one
    assert all(read_episode(ref).summary.success for ref in before)
    rerun = subprocess.run(command, capture_output=True, text=True, timeout=300, env={**os.environ})
    assert rerun.returncode == 0, rerun.stderr[-2000:]
    assert f"{plural(done, 'demo')} already augmented" in " ".join(rerun.stderr.split())
    episodes = scan(out).episodes
    assert len(episodes) == 3 * 3
    assert sorted(read_episode(ref).attrs["augment_variant"] for ref in episodes) == sorted(
        ["original", "speed", "light"] * 3
    )

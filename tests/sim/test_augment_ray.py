"""The Ray executor on a local, loopback-only cluster gives the same episodes as one process."""

from __future__ import annotations

import numpy as np
import pytest
import ray  # a dev dependency: this test must run, not skip

from pipette_cli.augment.run import augment
from pipette_cli.augment.specs import AugmentSpec, SpeedSpec, VariantSpec
from pipette_cli.demos.collect import collect
from pipette_cli.demos.store import read_episode, scan
from pipette_cli.registry import load_registry

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

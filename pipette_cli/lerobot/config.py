"""LeRobot's training config built from a ``lerobot-train`` command line, as ``lerobot-train`` builds
it, without training: how a planned command is checked against the installed LeRobot."""

from __future__ import annotations

import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any


@contextmanager
def _argv(argv: Sequence[str]) -> Iterator[None]:
    saved = sys.argv
    sys.argv = list(argv)
    try:
        yield
    finally:
        sys.argv = saved


def parse_train_config(argv: Sequence[str]) -> Any:
    """Build and validate LeRobot's ``TrainPipelineConfig`` from a ``lerobot-train`` argv, as
    ``lerobot-train`` does, without training (no dataset or weights are loaded; a ``--policy.path``
    must hold a ``config.json``). Returns the config; raises what LeRobot raises on a bad flag.
    """
    # deferred: lerobot, torch (~3 s; `pipette --help` imports this module)
    from lerobot.configs import parser
    from lerobot.configs.train import TrainPipelineConfig

    def build(cfg: TrainPipelineConfig) -> TrainPipelineConfig:
        cfg.validate()
        return cfg

    build.__annotations__["cfg"] = TrainPipelineConfig
    with _argv(argv):
        return parser.wrap()(build)()

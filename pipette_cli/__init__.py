"""Pipette: a MuJoCo platform for training robots to work in biomedical wet labs."""

import warnings
from importlib.metadata import PackageNotFoundError, version

from pipette_cli.kernels import pin

if (_unpinned := pin()) is not None:  # PIPETTE_PORTABLE=1, before anything loads numpy or torch
    warnings.warn(_unpinned, RuntimeWarning, stacklevel=2)

try:
    __version__ = version("pipette")
except PackageNotFoundError:  # running from a source tree without installing
    __version__ = "0.0.0+source"

__all__ = ["__version__"]

"""Pipette: a MuJoCo platform for training robots to work in biomedical wet labs."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("pipette")
except PackageNotFoundError:  # running from a source tree without installing
    __version__ = "0.0.0+source"

__all__ = ["__version__"]

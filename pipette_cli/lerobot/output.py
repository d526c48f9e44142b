"""What of ``lerobot-train``'s output reaches the terminal: all of it, except known library warnings
that are long and harmless, each shown as one line there (the training's log keeps them whole).

LeRobot probes torchcodec while it parses its command line, whatever ``--dataset.video_backend``
says; where the system's FFmpeg libraries are missing, that prints the loader's tracebacks (about
100 lines) before falling back to PyAV, which looks like a crash at the start of every training.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import IO


@dataclass(frozen=True)
class Noise:
    """A warning block: its first line, its last line, and the one line shown instead."""

    start: re.Pattern[str]
    end: re.Pattern[str]
    summary: str


NOISE = (
    Noise(
        re.compile(r"Could not load libtorchcodec"),
        re.compile(r"Falling back to 'pyav'"),
        "lerobot: torchcodec cannot be loaded here (no system FFmpeg libraries); PyAV decodes video "
        "instead (the whole warning is in the training's log)",
    ),
)
MAX_BLOCK = 400
"""Lines held back at most: a block whose end never comes is shown as it was."""


@dataclass
class Abridged:
    """A text stream that passes lines to ``out``, each :data:`NOISE` block as its summary."""

    out: IO[str]
    held: list[str] = field(default_factory=list)
    inside: Noise | None = None

    def write(self, line: str) -> None:
        if self.inside is None:
            self.inside = next((n for n in NOISE if n.start.search(line)), None)
            if self.inside is None:
                self.out.write(line)
                return
        self.held.append(line)
        if self.inside.end.search(line):
            self.out.write(self.inside.summary + "\n")
            self.held, self.inside = [], None
        elif len(self.held) > MAX_BLOCK:
            self.close()

    def flush(self) -> None:
        self.out.flush()

    def close(self) -> None:
        """Show what is held back (a block that did not end) as it was."""
        self.out.writelines(self.held)
        self.held, self.inside = [], None
        self.out.flush()

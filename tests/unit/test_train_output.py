"""The terminal copy of ``lerobot-train``'s output: known library warnings as one line each."""

from __future__ import annotations

import io

from pipette_cli.lerobot.output import MAX_BLOCK, Abridged

TORCHCODEC = [
    "WARNING:lerobot.utils.import_utils:Could not load libtorchcodec. Likely causes:\n",
    "          1. FFmpeg is not properly installed in your environment.\n",
    "Traceback (most recent call last):\n",
    "OSError: libavutil.so.60: cannot open shared object file: No such file or directory\n",
    "'torchcodec' is installed but cannot be loaded (see the error above). Falling back to 'pyav' as a default decoder.\n",
]


def shown(lines: list[str]) -> list[str]:
    out = io.StringIO()
    stream = Abridged(out)
    for line in lines:
        stream.write(line)
    stream.close()
    return out.getvalue().splitlines()


def test_the_torchcodec_warning_is_one_line_and_the_rest_passes() -> None:
    lines = shown(["INFO start\n", *TORCHCODEC, "INFO step:20 loss:0.5\n", *TORCHCODEC, "INFO end\n"])
    assert lines[0] == "INFO start" and lines[2] == "INFO step:20 loss:0.5" and lines[4] == "INFO end"
    assert len(lines) == 5 and lines[1] == lines[3] and "torchcodec cannot be loaded" in lines[1]
    assert not any("Traceback" in line for line in lines)


def test_a_block_that_never_ends_is_shown_whole() -> None:
    cut = TORCHCODEC[:3]
    assert shown(["a\n", *cut]) == ["a", *(line.rstrip("\n") for line in cut)]  # the process ended inside it
    long = [TORCHCODEC[0], *[f"line {i}\n" for i in range(MAX_BLOCK + 5)]]
    assert len(shown(long)) == len(long)  # nothing lost when the end does not come

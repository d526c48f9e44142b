"""The user guide and the README, executed and checked against the registry.

A command block marked runnable, an HTML comment on the line before its fence::

    <!-- runnable -->
    ```bash
    pipette tasks list --tag paper-benchmark
    ```

runs in the tests: the blocks of a page in order, each command in this process, in one temporary
folder per page that links the repository's ``registry/`` and ``assets/`` (so a path such as
``registry/pick_up_test_tube.yaml`` means what it does in a checkout), and each must exit 0. Only
``pipette ...`` and ``export NAME=VALUE`` lines may appear in such a block. A block that is too long
to run as written gets smaller sizes in its marker, ``OLD => NEW`` text replacements separated by
``;``, each of which must occur in the block::

    <!-- runnable: --episodes 50 => --episodes 4 --image-size 32 -->

Every count the pages state ("22 tasks", "117 assets", "tools 14", ...) is compared with the
registry, and a number before a counted noun that no rule knows fails too, so no stale count
survives.
"""

from __future__ import annotations

import os
import re
import shlex
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pytest

from pipette_cli.assets.library import load_asset_library
from pipette_cli.evaluation.suites import load_suites
from pipette_cli.registry import load_registry
from pipette_cli.resources import data_dir
from pipette_cli.specs.robot import ROBOTS_FOLDER

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", ROOT / "docs" / "guide.md"]
MARKER = re.compile(r"^\s*<!-- runnable(?::(?P<subs>.*?))? -->\s*$")
FENCE = re.compile(r"^\s*```")
LINKED = ("registry", "assets")
"""Repository folders linked into the temporary folder the commands run in."""


@dataclass(frozen=True)
class Command:
    line: int
    argv: list[str]


@dataclass(frozen=True)
class Block:
    page: Path
    line: int
    commands: list[Command]


def runnable_blocks(page: Path, text: str | None = None) -> list[Block]:
    """The marked command blocks of ``page`` (its text, or ``text``), their replacements applied.

    Raises:
        ValueError: a marker not followed by a fence, a replacement that does not occur in its
            block, or a line that is neither ``pipette ...`` nor ``export NAME=VALUE``.
    """
    lines = (page.read_text() if text is None else text).splitlines()
    blocks: list[Block] = []
    for i, line in enumerate(lines):
        marker = MARKER.match(line)
        if marker is None:
            continue
        where = f"{page.name}:{i + 1}"
        if i + 1 >= len(lines) or not re.match(r"^\s*```(bash|sh|console)?\s*$", lines[i + 1]):
            raise ValueError(f"{where}: a runnable marker must stand on the line before a ```bash fence")
        body: list[tuple[int, str]] = []
        for j in range(i + 2, len(lines)):
            if FENCE.match(lines[j]):
                break
            body.append((j + 1, lines[j]))
        else:
            raise ValueError(f"{where}: the block never closes")
        subs = [tuple(s.strip() for s in sub.split("=>")) for sub in (marker["subs"] or "").split(";") if sub.strip()]
        block_text = "\n".join(text for _, text in body)
        for sub in subs:
            if len(sub) != 2 or sub[0] not in block_text:
                raise ValueError(f"{where}: replacement {' => '.join(sub)!r} does not apply to the block")
        blocks.append(Block(page, i + 1, _commands(where, body, subs)))
    return blocks


def _commands(where: str, body: list[tuple[int, str]], subs: list[tuple[str, ...]]) -> list[Command]:
    commands: list[Command] = []
    pending, start = "", 0
    for number, raw in body:
        text = raw.strip()
        if not pending:
            start = number
        if text.endswith("\\"):
            pending += text[:-1] + " "
            continue
        text, pending = pending + text, ""
        for old, new in subs:
            text = text.replace(old, new)
        argv = shlex.split(text, comments=True)
        if not argv:
            continue
        if argv[0] not in ("pipette", "export") or (argv[0] == "export" and (len(argv) != 2 or "=" not in argv[1])):
            raise ValueError(f"{where}: line {start}: only pipette commands and export NAME=VALUE can run: {text}")
        commands.append(Command(start, argv))
    return commands


def _run_page(page: Path, run_cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[int, float]:
    """Run every marked block of ``page`` in order; the seconds each block took, by its line."""
    for name in LINKED:
        (tmp_path / name).symlink_to(ROOT / name, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PWD", str(tmp_path))
    for name in ("PIPETTE_REGISTRY_PATH", "PIPETTE_ASSET_PATH"):
        monkeypatch.delenv(name, raising=False)
    seconds: dict[int, float] = {}
    for block in runnable_blocks(page):
        start = time.perf_counter()
        for command in block.commands:
            if command.argv[0] == "export":
                name, _, value = command.argv[1].partition("=")
                monkeypatch.setenv(name, os.path.expandvars(value))
                continue
            result = run_cli(*command.argv[1:])
            assert result.exit_code == 0, (
                f"{page.relative_to(ROOT)}:{command.line}: {shlex.join(command.argv)} exited {result.exit_code}\n"
                f"{result.stderr[-3000:]}"
            )
        seconds[block.line] = time.perf_counter() - start
    print(", ".join(f"{page.name}:{line} {s:.0f} s" for line, s in seconds.items()))  # pytest -s shows it
    return seconds


def test_the_guides_runnable_blocks_run(run_cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every marked block of docs/guide.md, at the sizes its marker gives (about two minutes on 2 cores)."""
    page = ROOT / "docs" / "guide.md"
    seconds = _run_page(page, run_cli, tmp_path, monkeypatch)
    assert len(seconds) >= 20, "the guide's command blocks lost their runnable markers"
    # what the blocks made is where the guide says
    assert (tmp_path / "my_tasks" / "pick_up_cryovial.yaml").is_file() and (tmp_path / "data" / "tube.h5").is_file()
    assert (tmp_path / "datasets" / "pipette_PickUpTestTube-v1" / "raw" / "meta" / "info.json").is_file()


def test_the_readmes_two_commands_are_the_ones_ci_and_the_tests_run(
    run_cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The README's blocks install and run the full demo (minutes): CI runs its install and its test
    command as written (.ci/run), and ``pipette demo --fast`` runs every stage in tests/cli/test_demo_cli.py;
    a README block marked runnable would run here like the guide's."""
    readme = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```bash\n(.*?)```", readme, re.S)
    install, tests = blocks[0].strip(), blocks[1].strip()
    assert install == "bash .ci/install && .venv/bin/pipette demo"
    ci = (ROOT / ".ci" / "run").read_text()
    assert "bash .ci/install" in ci and f"{tests}\n" in ci
    assert "# README command 2:" in ci
    if runnable_blocks(ROOT / "README.md"):  # a block marked runnable runs as the guide's do
        _run_page(ROOT / "README.md", run_cli, tmp_path, monkeypatch)


def test_markers_are_parsed_with_their_replacements() -> None:
    text = (
        "<!-- runnable: --episodes 50 => --episodes 2; -n 9 => -n 1 -->\n```bash\n"
        "pipette collect PickUpTestTube --episodes 50 --out a.h5   # 50 demos\n"
        "pipette collect OpenCentrifugeLid -n 9 \\\n    --out b.h5\nexport X=$PWD/y\n```\n"
        "```bash\npipette not marked\n```\n"
    )
    (block,) = runnable_blocks(Path("page.md"), text)
    assert [c.argv for c in block.commands] == [
        ["pipette", "collect", "PickUpTestTube", "--episodes", "2", "--out", "a.h5"],
        ["pipette", "collect", "OpenCentrifugeLid", "-n", "1", "--out", "b.h5"],
        ["export", "X=$PWD/y"],
    ]
    assert [c.line for c in block.commands] == [3, 4, 6]
    with pytest.raises(ValueError, match="replacement '--steps 9 => --steps 1' does not apply"):
        runnable_blocks(Path("page.md"), text.replace("-n 9 => -n 1", "--steps 9 => --steps 1"))
    with pytest.raises(ValueError, match="only pipette commands"):
        runnable_blocks(Path("page.md"), "<!-- runnable -->\n```bash\nrm -rf /\n```\n")


# ------------------------------------------------------------------------------------------ counts


@cache
def facts() -> dict[str, int]:
    """Every number the pages may state, from the registry and the asset library."""
    registry = load_registry()
    specs = [registry.get(task_id) for task_id in registry.ids()]
    library = load_asset_library()
    categories = Counter(library.get(asset_id).category for asset_id in library.ids())
    robots = sorted((data_dir("registry") / ROBOTS_FOLDER).glob("*.yaml"))
    return {
        "tasks": len(specs),
        "benchmark tasks": sum("paper-benchmark" in s.tags for s in specs),
        "protocols": sum("protocol" in s.tags for s in specs),
        "evaluation suites": len(load_suites(registry).suites),
        "assets": len(library.ids()),
        "robots": len(robots),
        **categories,
    }


NOUNS = r"tasks|assets|protocols|suites|robots|tools|equipment|consumables|instruments"
CLAIMS: list[tuple[re.Pattern[str], Callable[[re.Match[str]], str]]] = [
    (re.compile(r"\b(?P<n>\d+) (?:paper[- ])?benchmark tasks\b"), lambda m: "benchmark tasks"),
    (re.compile(r"\b(?P<n>\d+) tasks\b"), lambda m: "tasks"),
    (re.compile(r"\b(?P<n>\d+) (?:lab )?protocols\b"), lambda m: "protocols"),
    (re.compile(r"\b(?P<n>\d+) evaluation suites\b"), lambda m: "evaluation suites"),
    (re.compile(r"\b(?P<n>\d+) assets\b"), lambda m: "assets"),
    (re.compile(r"\b\d+/(?P<n>\d+) assets\b"), lambda m: "assets"),
    (re.compile(r"\b(?P<n>\d+) robots\b"), lambda m: "robots"),
    (re.compile(r"\b(?P<what>tools|equipment|consumables|instruments) (?P<n>\d+)\b"), lambda m: m["what"]),
    (re.compile(r"\b(?P<n>\d+) (?P<what>tools|equipment|consumables|instruments)\b"), lambda m: m["what"]),
]
ANY_COUNT = re.compile(rf"\b\d+(?:/\d+)? (?:[\w-]+ ){{0,2}}(?:{NOUNS})\b|\b(?:{NOUNS}) \d+\b")
"""A number next to a counted noun: each must be one of ``CLAIMS``."""


def count_problems(page: str, text: str) -> list[str]:
    """``page:line: message`` for each stated count that differs from :func:`facts` or that no claim knows."""
    known = facts()
    problems: list[str] = []
    for number, line in enumerate(text.splitlines(), 1):
        checked: set[tuple[int, int]] = set()
        for pattern, key in CLAIMS:
            for m in pattern.finditer(line):
                checked.add(m.span())
                truth = known[key(m)]
                if int(m["n"]) != truth:
                    problems.append(f"{page}:{number}: {m[0]!r} states {m['n']} {key(m)}; the registry has {truth}")
        for m in ANY_COUNT.finditer(line):
            if not any((a <= m.start() and m.end() <= b) or (m.start() <= a and b <= m.end()) for a, b in checked):
                problems.append(f"{page}:{number}: {m[0]!r}: a count no rule checks; state it as a checked one")
    return problems


COUNTED = [*PAGES, *(ROOT / "docs" / name for name in ("tasks.md", "protocols.md", "assets.md"))]
COUNTED.append(ROOT / "docs" / "extending" / "adding_a_task.md")
"""Pages whose counts are checked (the pages that state the library's sizes; not the measurement records)."""


@pytest.mark.parametrize("page", COUNTED, ids=lambda p: p.name)
def test_every_count_a_page_states_is_the_registrys(page: Path) -> None:
    assert count_problems(page.name, page.read_text()) == []


def test_a_stale_count_fails() -> None:
    truth = facts()
    text = (
        f"{truth['tasks']} tasks and {truth['evaluation suites']} evaluation suites; "
        f"the {truth['benchmark tasks']} benchmark tasks\n"
        f"validate: {truth['tasks'] - 5} tasks and {truth['assets'] + 1} assets (tools {truth['tools']})\n"
        "the 4 wet-lab tasks\n"
    )
    assert count_problems("page.md", text) == [
        f"page.md:2: '{truth['tasks'] - 5} tasks' states {truth['tasks'] - 5} tasks; the registry has {truth['tasks']}",
        f"page.md:2: '{truth['assets'] + 1} assets' states {truth['assets'] + 1} assets; "
        f"the registry has {truth['assets']}",
        "page.md:3: '4 wet-lab tasks': a count no rule checks; state it as a checked one",
    ]

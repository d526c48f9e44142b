"""``pipette eval report``: the paper's kind of table (task x policy x raw/augmented) with the
statistics to read it by: Wilson 95 % intervals, stage progress, and raw-versus-augmented tests.

Results are read from run folders (:mod:`~pipette_cli.evaluation.results`): from the episode logs
when there are any (a missing or stale ``summary.json`` does not matter, and the episodes give
the paired comparison), else from ``summary.json`` alone. A report is written as markdown, JSON,
CSV and a bar chart with interval whiskers, all from the same numbers.
"""

from __future__ import annotations

import csv
import io
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from PIL import Image, ImageDraw

from pipette_cli.errors import DatasetError
from pipette_cli.evaluation.results import MANIFEST_FILE, SUMMARY_FILE, read_logs, summarize
from pipette_cli.evaluation.significance import ALPHA, Comparison, compare, holm, wilson_interval

VERSIONS = ("raw", "augmented")


@dataclass(frozen=True)
class RunRecord:
    """One evaluated cell: a summary and, when episode logs exist, each episode's outcome."""

    folder: Path
    summary: dict[str, Any]
    outcomes: dict[tuple[int, str], bool] | None

    @property
    def key(self) -> tuple[str, str, str]:
        s = self.summary
        return s["task"], s["policy_type"], s.get("dataset_version") or "raw"


def _run_folders(root: Path) -> list[Path]:
    """Folders under ``root`` (itself included) holding episode logs or a summary."""
    return sorted({p.parent for p in root.rglob("episode_*.json")} | {p.parent for p in root.rglob(SUMMARY_FILE)})


def load_runs(dirs: list[Path]) -> list[RunRecord]:
    """Every run folder under ``dirs``.

    Raises:
        DatasetError: a folder holds no results, a file is unreadable, or two runs fill one cell.
    """
    runs: list[RunRecord] = []
    for root in dirs:
        folders = _run_folders(Path(root)) if Path(root).is_dir() else []
        if not folders:
            raise DatasetError(
                f"{root}: no evaluation results (episode_XXXX.json or summary.json); "
                "write them with `pipette eval ... --out DIR`"
            )
        runs += [_load_run(folder) for folder in folders]
    seen: dict[tuple[str, str, str], Path] = {}
    for run in runs:
        if run.key in seen:
            raise DatasetError(
                f"{seen[run.key]} and {run.folder} both hold {run.key[1]} on {run.key[2]} data for "
                f"{run.key[0]}; report one of them"
            )
        seen[run.key] = run.folder
    return runs


def _load_run(folder: Path) -> RunRecord:
    if any(folder.glob("episode_*.json")):
        previous = _json(folder / SUMMARY_FILE) if (folder / SUMMARY_FILE).is_file() else {}
        summary = summarize(folder)
        if previous.get("episodes") == summary["episodes"]:
            summary["stopped"] = previous.get("stopped")
        if not (folder / MANIFEST_FILE).is_file():  # written before run.json existed: its label is in the summary
            summary["dataset_version"] = previous.get("dataset_version", "raw")
        outcomes = {
            (int(log["seed"]), str(log.get("instruction", ""))): bool(log["success"]) for log in read_logs(folder)
        }
        return RunRecord(folder, summary, outcomes)
    data = _json(folder / SUMMARY_FILE)
    try:
        n = int(data["episodes"])
        successes = int(data["successes"]) if "successes" in data else round(float(data["success_rate"]) * n)
        summary = {
            **data,
            "task": data["task"],
            "policy_type": data["policy_type"],
            "episodes": n,
            "successes": successes,
            "success_rate": successes / n if n else 0.0,
            "success_ci95": list(wilson_interval(successes, n)),
        }
    except (KeyError, TypeError, ValueError) as exc:
        raise DatasetError(f"{folder / SUMMARY_FILE}: not an evaluation summary ({exc})") from None
    summary.setdefault("complete", not (folder / MANIFEST_FILE).is_file())
    return RunRecord(folder, summary, None)


def _json(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise DatasetError(f"{path}: unreadable ({exc})") from None
    if not isinstance(data, dict):
        raise DatasetError(f"{path}: not an evaluation summary")
    return data


@dataclass
class Report:
    """Cells by (task, policy, version) and a raw-vs-augmented comparison per (task, policy)."""

    cells: dict[tuple[str, str, str], RunRecord]
    comparisons: dict[tuple[str, str], Comparison] = field(default_factory=dict)
    holm_p: dict[tuple[str, str], float] = field(default_factory=dict)

    def rows(self) -> list[tuple[str, str]]:
        return sorted({(task, policy) for task, policy, _ in self.cells})


def build_report(runs: list[RunRecord]) -> Report:
    report = Report({run.key: run for run in runs})
    for task, policy in report.rows():
        raw, aug = report.cells.get((task, policy, "raw")), report.cells.get((task, policy, "augmented"))
        if raw is None or aug is None:
            continue
        report.comparisons[task, policy] = compare(
            raw.outcomes if raw.outcomes is not None else (raw.summary["successes"], raw.summary["episodes"]),
            aug.outcomes if aug.outcomes is not None else (aug.summary["successes"], aug.summary["episodes"]),
        )
    keys = list(report.comparisons)
    report.holm_p = dict(zip(keys, holm([report.comparisons[k].p_value for k in keys]), strict=True))
    return report


def cell_text(summary: dict[str, Any]) -> str:
    """``7/10 (70 %, 40-89)``, with the stage progress of staged tasks and ``*`` when incomplete."""
    low, high = summary["success_ci95"]
    text = f"{summary['successes']}/{summary['episodes']} ({100 * summary['success_rate']:.0f} %, {100 * low:.0f}-{100 * high:.0f})"
    if summary.get("mean_progress") is not None:
        text += f", progress {summary['mean_progress']:.2f}"
    return text + ("" if summary.get("complete", True) else "*")


def comparison_text(c: Comparison, holm_p: float) -> tuple[str, str, str]:
    """Change, test with p-values, and verdict columns."""
    test = "McNemar" if c.test == "mcnemar_exact" else "Fisher"
    pairs = f", {c.only_a} vs {c.only_b} discordant" if c.only_a is not None else ""
    verdict = "yes" if holm_p < ALPHA else ("p < 0.05 alone" if c.significant else "no")
    return f"{100 * c.difference:+.0f} pt", f"{test} p = {c.p_value:.3g} (Holm {holm_p:.3g}){pairs}", verdict


def markdown(report: Report) -> str:
    """One row per (task, policy): each version's cell, the change and its test."""
    lines = [
        "| task | policy | raw (95 % CI) | augmented (95 % CI) | change | test | significant |",
        "| --- | --- | ---: | ---: | ---: | --- | --- |",
    ]
    for task, policy in report.rows():
        cells = [report.cells.get((task, policy, v)) for v in VERSIONS]
        texts = [cell_text(c.summary) if c is not None else "-" for c in cells]
        c = report.comparisons.get((task, policy))
        extra = comparison_text(c, report.holm_p[task, policy]) if c is not None else ("-", "-", "-")
        lines.append(f"| {task} | {policy} | {texts[0]} | {texts[1]} | {' | '.join(extra)} |")
    notes = [
        (
            f"Cells: successes/episodes (rate, 95 % Wilson interval); staged tasks add the mean share of stages "
            f"completed. Significant: two-sided exact test at {ALPHA}, Holm-adjusted over the {len(report.comparisons)} "
            "comparison(s); McNemar pairs the same episodes (seed and instruction), Fisher compares independent samples."
        )
    ]
    others = sorted({v for _, _, v in report.cells} - set(VERSIONS))
    if others:
        notes.append(f"Not tabulated (only raw and augmented are): dataset versions {', '.join(others)}.")
    if any(not c.summary.get("complete", True) for c in report.cells.values()):
        notes.append("* incomplete run: fewer episodes than planned (resume it with the same command).")
    return "\n".join(lines) + "\n\n" + "\n".join(notes) + "\n"


def to_json(report: Report) -> dict[str, Any]:
    return {
        "alpha": ALPHA,
        "runs": [{"folder": str(run.folder), **run.summary} for run in report.cells.values()],
        "comparisons": [
            {
                "task": task,
                "policy": policy,
                **c.as_dict(),
                "p_holm": report.holm_p[task, policy],
                "significant_holm": report.holm_p[task, policy] < ALPHA,
            }
            for (task, policy), c in report.comparisons.items()
        ],
    }


def csv_text(report: Report) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    writer.writerow(
        [
            "task",
            "policy",
            "version",
            "episodes",
            "successes",
            "success_rate",
            "ci95_low",
            "ci95_high",
            "mean_progress",
            "complete",
        ]
    )
    for (task, policy, version), run in sorted(report.cells.items()):
        s = run.summary
        writer.writerow(
            [
                task,
                policy,
                version,
                s["episodes"],
                s["successes"],
                f"{s['success_rate']:.4f}",
                f"{s['success_ci95'][0]:.4f}",
                f"{s['success_ci95'][1]:.4f}",
                "" if s.get("mean_progress") is None else f"{s['mean_progress']:.4f}",
                s.get("complete", True),
            ]
        )
    return buffer.getvalue()


def bar_chart(report: Report, path: Path) -> None:
    """Grouped bars per (task, policy), one per dataset version, with 95 % interval whiskers and
    a star over groups whose difference is significant (Holm)."""
    rows = report.rows()
    bar, gap, height, left, top = 30, 52, 220, 40, 22
    width = left + len(rows) * (len(VERSIONS) * bar + gap) + 20
    image = Image.new("RGB", (max(width, 280), height + top + 124), "white")
    draw = ImageDraw.Draw(image)
    colors = {"raw": (120, 144, 180), "augmented": (230, 140, 60)}

    def y(rate: float) -> float:
        return top + height - height * rate

    draw.line([(left, top), (left, top + height)], fill="black")
    for pct in (0, 50, 100):
        draw.text((4, y(pct / 100) - 6), f"{pct}%", fill="black")
    for i, (task, policy) in enumerate(rows):
        x = left + 8 + i * (len(VERSIONS) * bar + gap)
        for j, version in enumerate(VERSIONS):
            run = report.cells.get((task, policy, version))
            if run is None:
                continue
            s = run.summary
            x0, x1 = x + j * bar, x + (j + 1) * bar - 2
            draw.rectangle([x0, y(s["success_rate"]), x1, top + height], fill=colors[version])
            low, high = s["success_ci95"]
            mid = (x0 + x1) / 2
            draw.line([(mid, y(high)), (mid, y(low))], fill="black", width=1)
            for end in (low, high):
                draw.line([(mid - 5, y(end)), (mid + 5, y(end))], fill="black", width=1)
            draw.text((x0 + 2, max(y(high) - 12, 0)), f"{100 * s['success_rate']:.0f}", fill="black")
        if report.holm_p.get((task, policy), 1.0) < ALPHA:
            draw.text((x + bar - 4, 2), "*", fill="black")
        for k, line in enumerate([*_label_lines(task), policy]):
            draw.text((x, top + height + 6 + 14 * k), line, fill="black")
    for j, version in enumerate(VERSIONS):
        draw.rectangle(
            [left + 8 + 90 * j, top + height + 74, left + 20 + 90 * j, top + height + 86], fill=colors[version]
        )
        draw.text((left + 24 + 90 * j, top + height + 74), version, fill="black")
    draw.text((left + 8, top + height + 94), "whiskers: 95 % CI; *: significant (Holm)", fill="black")
    path.parent.mkdir(parents=True, exist_ok=True)
    image.save(path)


def _label_lines(task: str, width: int = 18) -> list[str]:
    """A task's name without namespace and version, cut between its words into at most 3 lines."""
    lines: list[str] = []
    for word in re.findall(r"[A-Z0-9][a-z0-9]*|[a-z0-9]+", task.split("/")[-1].rsplit("-v", 1)[0]):
        if lines and len(lines[-1]) + len(word) <= width:
            lines[-1] += word
        else:
            lines.append(word)
    return lines[:3]


def write_report(report: Report, stem: Path) -> list[Path]:
    """``STEM.md``, ``STEM.json``, ``STEM.csv`` and ``STEM.png``, written together."""
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_suffix(s) for s in (".md", ".json", ".csv", ".png")]
    paths[0].write_text(markdown(report))
    paths[1].write_text(json.dumps(to_json(report), indent=2) + "\n")
    paths[2].write_text(csv_text(report))
    bar_chart(report, paths[3])
    return paths

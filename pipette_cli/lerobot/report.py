"""``pipette eval report``: the paper's kind of table (task x policy x raw/augmented) from
evaluation summaries, as markdown, CSV and a bar chart PNG."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

from pipette_cli.errors import DatasetError

VERSIONS = ("raw", "augmented")


def load_summaries(dirs: list[Path]) -> list[dict[str, Any]]:
    """Every ``summary.json`` under ``dirs``."""
    rows = []
    for folder in dirs:
        found = sorted(Path(folder).rglob("summary.json")) if Path(folder).is_dir() else []
        if not found:
            raise DatasetError(f"{folder}: no summary.json (write one with `pipette eval TASK ... --out DIR`)")
        for path in found:
            try:
                data = json.loads(path.read_text())
                rows.append({"task": data["task"], "policy": data["policy_type"], "version": data.get("dataset_version", "raw"),
                             "episodes": int(data["episodes"]), "success_rate": float(data["success_rate"])})
            except (OSError, ValueError, KeyError) as exc:
                raise DatasetError(f"{path}: not an evaluation summary ({exc})") from None
    return rows


def table(rows: list[dict[str, Any]]) -> tuple[list[str], list[list[str]]]:
    """Header and rows: one row per (task, policy), one column per dataset version."""
    cells: dict[tuple[str, str], dict[str, str]] = {}
    for r in rows:
        cells.setdefault((r["task"], r["policy"]), {})[r["version"]] = f"{100 * r['success_rate']:.0f}"
    header = ["task", "policy", *VERSIONS]
    body = [[task, policy, *(v.get(version, "-") for version in VERSIONS)] for (task, policy), v in sorted(cells.items())]
    return header, body


def markdown(rows: list[dict[str, Any]]) -> str:
    header, body = table(rows)
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |"]
    lines += ["| " + " | ".join(r) + " |" for r in body]
    return "\n".join(lines) + "\n"


def csv_text(rows: list[dict[str, Any]]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    header, body = table(rows)
    writer.writerow(header)
    writer.writerows(body)
    return buffer.getvalue()


def bar_chart(rows: list[dict[str, Any]], path: Path) -> None:
    """Grouped bars: success rate per (task, policy), one bar per dataset version."""
    from PIL import Image, ImageDraw

    header, body = table(rows)
    bar, gap, height, left = 30, 52, 220, 40  # a group (2 bars + gap) is wide enough for a 14-char label
    width = left + len(body) * (len(VERSIONS) * bar + gap) + 20
    image = Image.new("RGB", (max(width, 240), height + 90), "white")
    draw = ImageDraw.Draw(image)
    colors = {"raw": (120, 144, 180), "augmented": (230, 140, 60)}
    draw.line([(left, 10), (left, 10 + height)], fill="black")
    for pct in (0, 50, 100):
        y = 10 + height - height * pct / 100
        draw.text((4, y - 6), f"{pct}%", fill="black")
    for i, row in enumerate(body):
        x = left + 8 + i * (len(VERSIONS) * bar + gap)
        for j, version in enumerate(VERSIONS):
            value = row[2 + j]
            if value != "-":
                top = 10 + height - height * float(value) / 100
                draw.rectangle([x + j * bar, top, x + (j + 1) * bar - 2, 10 + height], fill=colors[version])
                draw.text((x + j * bar + 4, max(top - 12, 0)), value, fill="black")  # 0 % is visible too
        label = row[0].split("/")[-1].rsplit("-v", 1)[0][:14]
        draw.text((x, height + 16), label, fill="black")
        draw.text((x, height + 30), row[1], fill="black")
    for j, version in enumerate(VERSIONS):
        draw.rectangle([left + 8 + 90 * j, height + 56, left + 20 + 90 * j, height + 68], fill=colors[version])
        draw.text((left + 24 + 90 * j, height + 56), version, fill="black")
    path.parent.mkdir(parents=True, exist_ok=True)
    image.save(path)

"""The yield report: per variant (and per perturbation axis) attempts, kept and failure reasons, and
on protocol tasks the stage at which the rejected variants failed (``failed_at_stage``: stage
number, counting from 1 -> rejected variants)."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any


@dataclass
class YieldRow:
    key: str
    magnitude: str
    attempts: int = 0
    kept: int = 0
    reasons: Counter[str] = field(default_factory=Counter)
    failed_at: Counter[int] = field(default_factory=Counter)

    @property
    def yield_(self) -> float:
        return self.kept / self.attempts if self.attempts else 0.0

    def as_dict(self) -> dict[str, Any]:
        return {
            "magnitude": self.magnitude,
            "attempts": self.attempts,
            "kept": self.kept,
            "yield": round(self.yield_, 4),
            "failures": dict(sorted(self.reasons.items())),
            **({"failed_at_stage": {str(k): v for k, v in sorted(self.failed_at.items())}} if self.failed_at else {}),
        }


def yield_report(demos: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Aggregate the per-demo records of a run (the ledger) into the report's JSON."""
    variants: dict[tuple[str, str], YieldRow] = {}
    axes: dict[tuple[str, str], YieldRow] = {}
    skipped: Counter[str] = Counter()
    for record in demos.values():
        if record["status"] != "ok":
            skipped[record["status"]] += 1
            continue
        for out in record["outcomes"]:
            rows = [variants.setdefault((out["variant"], out["magnitude"]), YieldRow(out["variant"], out["magnitude"]))]
            for part, mag in zip(out["variant"].split("+"), out["magnitude"].split(";"), strict=False):
                rows.append(axes.setdefault((part, mag), YieldRow(part, mag)))
            for row in rows:
                row.attempts += 1
                row.kept += bool(out["kept"])
                if not out["kept"]:
                    row.reasons[out["reason"]] += 1
                    if out.get("stage") is not None:  # ledgers written before protocols have none
                        row.failed_at[int(out["stage"]) + 1] += 1
    attempts = sum(r.attempts for r in variants.values())
    kept = sum(r.kept for r in variants.values())
    return {
        "demos": len(demos),
        "demos_skipped": dict(skipped),
        "attempts": attempts,
        "kept": kept,
        "yield": round(kept / attempts, 4) if attempts else 0.0,
        "variants": [{"variant": r.key, **r.as_dict()} for r in variants.values()],
        "axes": [{"axis": r.key, **r.as_dict()} for r in sorted(axes.values(), key=lambda r: (r.key, r.magnitude))],
    }

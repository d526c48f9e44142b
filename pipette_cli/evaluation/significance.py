"""How sure a success rate is, and whether two differ: Wilson intervals and exact tests (scipy).

* :func:`wilson_interval`: the 95 % Wilson score interval of ``k`` successes in ``n`` episodes
  (sound at 0/n and n/n, where the normal interval collapses to a point).
* :func:`compare`: raw versus augmented on one task. When both were evaluated on the same
  episodes (same seeds and instructions, as a suite guarantees) the outcomes are paired and the
  test is McNemar's exact test: a two-sided binomial test of the discordant pairs (raw succeeded
  and augmented failed, ``b``; the other way round, ``c``) against ``p = 1/2``. Otherwise the two
  rates are independent samples and the test is Fisher's exact test on the 2x2 table.
* :func:`holm`: Holm's step-down adjustment of several p-values (one per task), so that
  "significant on some task" keeps its 5 % error rate across a whole table.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

from scipy import stats

ALPHA = 0.05
"""Significance level of every test reported."""


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a success rate; ``(0, 1)`` when ``n`` is 0."""
    if n == 0:
        return 0.0, 1.0
    ci = stats.binomtest(successes, n).proportion_ci(confidence_level=confidence, method="wilson")
    return float(ci.low), float(ci.high)


def mcnemar_exact(b: int, c: int) -> float:
    """Two-sided exact McNemar p-value from the discordant pair counts ``b`` and ``c``."""
    if b + c == 0:
        return 1.0
    return float(stats.binomtest(b, b + c, 0.5).pvalue)


def smallest_significant(n: int, discordant: int, alpha: float = ALPHA) -> float | None:
    """The smallest difference in success rate (of ``n`` paired episodes) that McNemar's exact
    test would have called significant at ``alpha`` with ``discordant`` discordant pairs, all
    else as observed; None when even all of them on one side would not be (too few)."""
    if n == 0:
        return None
    for lead in range(discordant % 2, discordant + 1, 2):  # b - c, with b + c = discordant
        b = (discordant + lead) // 2
        if mcnemar_exact(b, discordant - b) < alpha:
            return lead / n
    return None


def fisher_exact(successes_a: int, n_a: int, successes_b: int, n_b: int) -> float:
    """Two-sided Fisher exact p-value of two independent success counts."""
    table = [[successes_a, n_a - successes_a], [successes_b, n_b - successes_b]]
    return float(stats.fisher_exact(table).pvalue)


def holm(pvalues: Sequence[float]) -> list[float]:
    """Holm-adjusted p-values, in the input's order."""
    order = sorted(range(len(pvalues)), key=lambda i: pvalues[i])
    adjusted = [0.0] * len(pvalues)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(pvalues) - rank) * pvalues[i]))
        adjusted[i] = running
    return adjusted


@dataclass(frozen=True)
class Comparison:
    """Raw (``a``) versus augmented (``b``) on one task.

    Attributes:
        test: ``mcnemar_exact`` (paired episodes) or ``fisher_exact`` (independent samples).
        n_a, successes_a, n_b, successes_b: The counts compared (paired: the shared episodes).
        only_a, only_b: Paired only: episodes that succeeded under one and failed under the other.
        difference: ``rate_b - rate_a``.
        p_value: Two-sided p-value of the test.
    """

    test: str
    n_a: int
    successes_a: int
    n_b: int
    successes_b: int
    only_a: int | None
    only_b: int | None
    difference: float
    p_value: float

    @property
    def significant(self) -> bool:
        return self.p_value < ALPHA

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "significant": self.significant}


Outcomes = Mapping[Any, bool]
"""Episode key (seed, instruction) -> success."""


def compare(a: Outcomes | tuple[int, int], b: Outcomes | tuple[int, int]) -> Comparison:
    """Compare two evaluations, paired when both are episode outcomes over the same episodes.

    Args:
        a: Episode key -> success, or ``(successes, n)`` when only counts are known.
        b: The same for the other evaluation.
    """
    if isinstance(a, Mapping) and isinstance(b, Mapping) and a and set(a) == set(b):
        only_a = sum(a[k] and not b[k] for k in a)
        only_b = sum(b[k] and not a[k] for k in a)
        k_a, k_b, n = sum(a.values()), sum(b.values()), len(a)
        return Comparison(
            "mcnemar_exact", n, k_a, n, k_b, only_a, only_b, k_b / n - k_a / n, mcnemar_exact(only_a, only_b)
        )
    k_a, n_a = _counts(a)
    k_b, n_b = _counts(b)
    rate_a, rate_b = (k_a / n_a if n_a else 0.0), (k_b / n_b if n_b else 0.0)
    return Comparison("fisher_exact", n_a, k_a, n_b, k_b, None, None, rate_b - rate_a, fisher_exact(k_a, n_a, k_b, n_b))


def _counts(x: Outcomes | tuple[int, int]) -> tuple[int, int]:
    if isinstance(x, Mapping):
        return sum(x.values()), len(x)
    return x

"""Numbers in a request and the options they set: "30 demos", "seed 3", "64x64 images", "15k steps",
"the third episode" (an index counting from 0), a bare count for ``bare_number``; and the counts of the
values of an option written ``NAME*N`` ("lighting and camera jitter, 3 draws each": :func:`counted`)."""

from __future__ import annotations

import re
from collections.abc import Set as AbstractSet
from typing import Any

from pipette_cli.agent.catalog import AgentError, CommandInfo, ParamInfo, is_empty
from pipette_cli.agent.vocabulary import WorkflowVocabularySpec
from pipette_cli.language.phrases import find_phrase, phrase_pattern, phrase_regex
from pipette_cli.registry import Registry
from pipette_cli.specs.task import TimingSpec

_NUMBER = re.compile(r"(?<![\w.])(-?\d+(?:,\d{3})*(?:\.\d+)?)(?!-[a-z])(\s*(?:k|thousand)\b)?(%)?")
"""A number, not one that opens a compound word ("the 96-well plate")."""
_MEASURE = re.compile(r"(?:ml|mm|cm|ul|µl|l|g|mg|kg|m|s|ms|hz|deg|°|well|channel|x)\b", re.IGNORECASE)
"""Units after a number that make it a size ("50 mL tube"), not a count."""
_METRES = {"mm": 0.001, "millimetre": 0.001, "millimetres": 0.001, "millimeter": 0.001, "millimeters": 0.001,
           "cm": 0.01, "centimetre": 0.01, "centimetres": 0.01, "centimeter": 0.01, "centimeters": 0.01,
           "m": 1.0, "metre": 1.0, "metres": 1.0, "meter": 1.0, "meters": 1.0}  # fmt: skip
_LENGTH = re.compile(rf"({'|'.join(sorted(_METRES, key=len, reverse=True))})\b", re.IGNORECASE)
"""A length after a number ("3 cm"): the value of the command's one option measured in metres."""


_SECONDS = {"ms": 0.001, "millisecond": 0.001, "milliseconds": 0.001, "s": 1.0, "sec": 1.0, "secs": 1.0,
            "second": 1.0, "seconds": 1.0, "min": 60.0, "mins": 60.0, "minute": 60.0, "minutes": 60.0}  # fmt: skip
TIME_UNITS = frozenset(_SECONDS)
_TIME = "|".join(sorted(map(re.escape, _SECONDS), key=len, reverse=True))


def in_control_steps(param: ParamInfo) -> bool:
    """Whether the help counts ``param`` in control steps ("Control-step cap per episode", "control
    steps of a moving average"): a duration said in seconds is that many seconds of control steps."""
    return param.kind == "int" and re.search(r"\bcontrol[- ]steps?\b", param.help, re.IGNORECASE) is not None


def control_rate(registry: Registry, info: CommandInfo, args: dict[str, Any]) -> float:
    """The control rate of the task ``args`` name for ``info`` (a registered id), else every task spec's
    default: durations said for an option counted in control steps count that task's steps."""
    task = args.get(param.name) if (param := info.task_param()) is not None else None
    if isinstance(task, str) and task in registry.ids():
        return float(registry.get(task).timing.control_hz)
    return float(TimingSpec().control_hz)


def durations(steps: float, control_hz: float) -> list[tuple[float, str]]:
    """How ``steps`` control steps may have been said as a duration: (amount, unit) pairs ((0.5, "s"),
    (500, "ms"), ... at 30 Hz for 15)."""
    return [(steps / control_hz / factor, unit) for unit, factor in _SECONDS.items()]


def _durations_in_steps(numeric: list[ParamInfo], text: str, control_hz: float) -> str:
    """ "a 0.5-second window" -> "a 15 control steps window" for the command's one option counted in
    control steps, at the task's control rate; a duration no such option takes stays as said."""
    if len([p for p in numeric if in_control_steps(p)]) != 1:
        return text

    def steps(m: re.Match[str]) -> str:
        return f"{round(float(m.group(1)) * _SECONDS[m.group(2).lower()] * control_hz)} control steps"

    pattern = rf"(?<![\w.])(\d+(?:\.\d+)?)[\s-]?({_TIME})(?![\w'-])(?:\s+long\b)?"  # "6 seconds long"
    return re.sub(pattern, steps, text, flags=re.IGNORECASE)


def in_metres(param: ParamInfo) -> bool:
    """Whether the help gives ``param`` in metres ("Object shift range ... (m, uniform ...)")."""
    return param.kind == "float" and re.search(r"\((?:m|metres|meters)[,)]|\bin metres\b", param.help) is not None


def _in_metres_said(params: list[ParamInfo], text: str) -> list[ParamInfo]:
    """The options in metres a length may be for: the only one, or those a word of whose name
    the text says ("object shifts ... 3 cm": ``--object-xy``, not ``--camera-radius``)."""
    metres = [p for p in params if in_metres(p)]
    said = set(re.findall(r"[a-z]+", text.lower()))
    count = {p.name: sum(len(w) > 2 and (w in said or f"{w}s" in said) for w in p.name.split("_")) for p in metres}
    most = max(count.values(), default=0)
    return metres if len(metres) == 1 else [p for p in metres if most and count[p.name] == most]


def length_phrases(value: float) -> list[str]:
    """How a length of ``value`` metres may have been said ("3 cm", "30 mm", "0.03 m")."""
    return [f"{value / factor:g} {unit}" for unit, factor in _METRES.items()]


_LISTED = r"(?:\s*\d+(?:\s*,)?(?:\s+(?:and|&))?)*\s*"
"""Numbers listed before the one read, after an option that takes several ("episodes 3, 5 and")."""


def _typed(param: ParamInfo, number: float) -> int | float:
    return int(number) if param.kind == "int" and number == int(number) else number


def read_numbers(
    vocab: WorkflowVocabularySpec,
    info: CommandInfo,
    words: str,
    args: dict[str, Any],
    bound: AbstractSet[float],
    control_hz: float,
) -> None:
    """Numbers next to an option's words: units after ("30 demos", "60 expert demos"), names
    before ("seed 3", "batch size of 8"); a number with neither counts episodes (``bare_number``).
    A duration is counted in control steps at ``control_hz`` (the task's) for an option that counts them."""
    numeric = [p for p in info.params.values() if p.kind in ("int", "float") and is_empty(args.get(p.name))]
    if not numeric:
        return
    text = re.sub(r"\b(\d+)\s*[x×]\s*\1\b", r"\1 px", words)  # 64x64 images
    text = _positions(vocab, numeric, text)
    for word, value in sorted(vocab.spelled.items(), key=lambda kv: -len(kv[0])):
        text = re.sub(rf"(?<![\w-]){re.escape(word)}(?![\w-])", str(value), text)
    text = _unhyphenated(numeric, _durations_in_steps(numeric, text, control_hz))  # "half a second" is 0.5 s by now
    claims = [  # the words of this command's values said in several ("camera jitter": the cam variants, never
        # light's jitter), as ArgumentReader._values claims them
        m.span()
        for name in info.params
        for found in vocab.values.get(name, {}).values()
        for phrase in found
        if " " in phrase
        for m in phrase_pattern(phrase).finditer(text)
    ]

    def own(name: re.Match[str] | None) -> re.Match[str] | None:
        """A name matched before a number, unless it is a part of a longer value's words."""
        inside = name is not None and any(
            s <= name.start() and e >= name.end() and e - s > name.end() - name.start() for s, e in claims
        )
        return None if inside else name

    taken: set[str] = set()
    bare: list[float] = []
    counts = "|".join(phrase_regex(p) for p in vocab.counts_of)
    for m in _NUMBER.finditer(text):
        number = float(m.group(1).replace(",", "")) * (1000 if m.group(2) else 1) / (100 if m.group(3) else 1)
        after, before = text[m.end() :].lstrip(), text[: m.start()].rstrip()
        if counts and re.match(rf"(?:[x×]\s*)?(?:{counts})(?![\w-])", after):
            continue  # "a 2x augmentation with light", "3 draws each of ...": a count of variants (:func:`counted`)
        best: tuple[int, int, ParamInfo] | None = None  # rank, then the longest words: "2x the task range"
        for param in (p for p in numeric if p.name not in taken):
            names = param.names
            tests = (
                (3, param.units, lambda p, after=after: phrase_pattern(p).match(after)),
                (
                    2,
                    param.units,
                    lambda p, after=after: re.match(rf"(?:[a-z][\w-]*\s+){{1,2}}{phrase_pattern(p).pattern}", after),
                ),
                (
                    1,
                    names,
                    lambda p, before=before, listing=_LISTED if param.multiple else "": own(
                        re.search(rf"{phrase_pattern(p).pattern}(?=(?:\s+(?:of|at|to|=|:|is|from))?{listing}$)", before)
                    ),
                ),
            )
            for rank, phrases, matcher in tests:
                said = max((len(found.group(0)) for p in phrases if (found := matcher(p))), default=None)
                if said is not None and (best is None or (rank, said) > best[:2]):
                    best = (rank, said, param)
        chosen = best[2] if best is not None else None
        if chosen is not None and chosen.multiple:  # "episodes 3, 5 and 7": one value each
            args[chosen.name] = [*args.get(chosen.name, []), _typed(chosen, number)]
        elif chosen is not None:
            length = _LENGTH.match(after) if in_metres(chosen) else None  # "shift up to 3 cm": 0.03
            args[chosen.name] = (
                round(number * _METRES[length.group(1).lower()], 9) if length else _typed(chosen, number)
            )
            taken.add(chosen.name)
        elif (length := _LENGTH.match(after)) and len(metres := _in_metres_said(numeric, text)) == 1:
            args[metres[0].name] = round(number * _METRES[length.group(1).lower()], 9)  # "a 3 cm range": 0.03
            numeric.remove(metres[0])
        elif not m.group(3) and not _MEASURE.match(after) and number not in bound:
            bare.append(number)
    fallback = info.params.get(vocab.bare_number)
    if bare and fallback is not None and fallback.name not in taken and is_empty(args.get(fallback.name)):
        args[fallback.name] = _typed(fallback, bare[0])


def _unhyphenated(numeric: list[ParamInfo], text: str) -> str:
    """ "a 15-step window", "a 2k-step run": a number joined to one of the options' units is read as
    said apart; other compounds stay ("the 96-well plate")."""
    units = "|".join(phrase_regex(u) for p in numeric for u in p.units)
    return re.sub(rf"(?<![\w.])(\d+(?:\.\d+)?k?)-(?=(?:{units})(?![\w'-]))", r"\1 ", text) if units else text


def _positions(vocab: WorkflowVocabularySpec, numeric: list[ParamInfo], text: str) -> str:
    """ "the third episode" / "the 3rd demo" -> "episode 2" for a parameter counting from 0; "the first
    two episodes" -> "episode 0, 1" for one that takes several."""
    ordinals = "|".join(sorted(map(re.escape, vocab.ordinals), key=len, reverse=True))
    spelled = "|".join(sorted(map(re.escape, vocab.spelled), key=len, reverse=True))
    for param in (p for p in numeric if p.name in vocab.from_zero):
        names = "|".join(phrase_pattern(n).pattern for n in param.names)
        if param.multiple:

            def leading(m: re.Match[str], name: str = param.names[0]) -> str:
                said = m.group(1)
                count = int(said) if said.isdigit() else int(vocab.spelled[said])
                return f"{name} {', '.join(map(str, range(count)))}"

            pattern = rf"(?<![\w-])first\s+(\d+|{spelled})\s+(?:{names})(?![\w-])"
            text = re.sub(pattern, leading, text)

        def index(m: re.Match[str], name: str = param.names[0]) -> str:
            said = m.group(1)
            position = int(said[:-2]) if said[0].isdigit() else vocab.ordinals[said]
            return f"{name} {position - 1}"

        text = re.sub(rf"(?<![\w-])(\d+(?:st|nd|rd|th)|{ordinals})\s+(?:{names})(?![\w-])", index, text)
    return text


def counted(
    vocab: WorkflowVocabularySpec, words: str, found: list[tuple[int, int, str]], uncounted: list[str]
) -> list[tuple[int, int, str]]:
    """The values ``found`` (start, -length, value) with the count said for them, for an option whose
    help writes ``NAME*N``. A count just before a value's words is its own ("three object-pose draws"
    -> ``object*3``). A count said after the last value ("..., 3 draws each") or before the first with
    the vocabulary's ``counts_of`` words ("3 draws each of ...") is that of every value without its
    own when it says "each" of them, or when there is one value. Said per input of several values
    ("lighting and camera jitter, 3 per demo"), it is each variant combining them when the request
    says so (vocabulary ``combined``: ``light+cam*3``); otherwise which is meant is asked. Values
    in ``uncounted`` (``original``) take no count.

    Raises:
        AgentError: a count per input for several values, neither "each" nor combined.
    """
    spelled = vocab.spelled
    numbers = "|".join([r"\d+", *(re.escape(w) for w in sorted(spelled, key=len, reverse=True))])

    def count(m: re.Match[str] | None) -> int | None:
        return None if m is None else int(m.group(1)) if m.group(1).isdigit() else int(spelled[m.group(1)])

    own = {at: count(re.search(rf"(?<![\w.-])({numbers})(?:\s*[x×])?\s+$", words[:at])) for at, _, _ in found}
    first, last = min(found), max(found, key=lambda f: f[0] - f[1])  # the value said last ends last
    each = "|".join(phrase_regex(p) for p in vocab.per_each)
    after = re.search(rf"(?<![\w.-])({numbers})\s+(?:[a-z-]+\s+){{0,2}}?(?:{each})(?![\w-])", words[last[0] :])
    if after is not None and last[0] + after.start() < last[0] - last[1]:
        after = None  # inside the last value's own words
    of = "|".join(phrase_regex(p) for p in vocab.counts_of)
    before = (  # "3 draws each of ...", "a 2x augmentation with ..."
        re.search(rf"(?<![\w.-])({numbers})(?:\s*[x×])?\s+(?:{of})\s+(?:\S+\s+){{0,2}}$", words[: first[0]])
        if of
        else None
    )
    said = after or before
    shared = count(said)
    if said is None or shared is None:
        return [(at, n, f"{value}*{own[at]}" if (own[at] or 1) > 1 else value) for at, n, value in found]
    counted = [f for f in found if f[2] not in uncounted]
    mixed = len([f for f in counted if not own[f[0]]]) > 1
    per_input = re.search(rf"\b(?:{'|'.join(vocab.inputs)})\b", said.group(0)) is not None
    if mixed and (per_input or not re.search(r"\beach\b", said.group(0))):
        if find_phrase(vocab.combined, words) is not None and not any(own.values()):
            joined = "+".join(dict.fromkeys(v for _, _, v in sorted(counted)))
            alone = [f for f in found if f[2] in uncounted]
            return [*alone, (first[0], first[1], f"{joined}*{shared}" if shared > 1 else joined)]
        names = [v for at, _, v in sorted(counted) if not own[at]]
        raise AgentError(
            f"{said.group(0).strip()!r} for {' and '.join(names)}: say '{shared} of each' "
            f"({','.join(f'{v}*{shared}' for v in names)}) or '{shared} combining them' ({'+'.join(names)}*{shared})"
        )
    return [
        (at, n, f"{value}*{times}" if (times := own[at] or (1 if value in uncounted else shared)) > 1 else value)
        for at, n, value in found
    ]

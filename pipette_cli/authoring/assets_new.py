"""``pipette assets new``: a description -> a parametric generator and its parameters -> USD.

The backend fills an :class:`AssetDraftSpec` (generator + size); the geometry comes from the
registered generator of the nearest asset of that family, scaled: lengths with the cube root
of the volume ratio (or the diameter ratio), mass with the wall area. The asset is written to
a temporary folder and must pass ``pipette assets validate`` (USD validators, MuJoCo compile,
settle test) before it is copied under the asset root.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import tempfile
import time
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from pydantic import Field, model_validator

from pipette_cli.assets.generators import all_generators
from pipette_cli.assets.library import ASSET_PATH_ENV, load_asset_library
from pipette_cli.assets.usd_writer import write_usda
from pipette_cli.assets.validate import validate_asset
from pipette_cli.errors import AssetError, PipetteError
from pipette_cli.resources import env_paths
from pipette_cli.specs.base import Spec
from pipette_cli.taskgen.plan import PlanError as DraftError

if TYPE_CHECKING:
    from pipette_cli.assets.model import AssetDef
    from pipette_cli.authoring.backends.base import AuthoringBackend

SizeField = Literal["volume_ml", "diameter_mm", "length_mm"]
Generator = Literal[
    "beaker", "erlenmeyer_flask", "volumetric_flask", "media_bottle", "graduated_cylinder", "petri_dish", "test_tube"
]
# generator -> (generator function name, id prefix, size kind, (min, max), alias phrases)
FAMILIES: dict[str, tuple[str, str, str, tuple[float, float], tuple[str, ...]]] = {
    "beaker": ("beaker", "beaker", "volume_ml", (10, 5000), ("beaker",)),
    "erlenmeyer_flask": (
        "erlenmeyer",
        "erlenmeyer_flask",
        "volume_ml",
        (25, 5000),
        ("erlenmeyer flask", "erlenmeyer", "conical flask", "flask"),
    ),
    "volumetric_flask": ("volumetric_flask", "volumetric_flask", "volume_ml", (10, 2000), ("volumetric flask",)),
    "media_bottle": (
        "media_bottle",
        "media_bottle",
        "volume_ml",
        (25, 5000),
        ("media bottle", "reagent bottle", "bottle"),
    ),
    "graduated_cylinder": (
        "graduated_cylinder",
        "graduated_cylinder",
        "volume_ml",
        (10, 2000),
        ("graduated cylinder", "measuring cylinder", "cylinder"),
    ),
    "petri_dish": ("petri_dish", "petri_dish", "diameter_mm", (20, 250), ("petri dish", "culture dish", "dish")),
    "test_tube": ("tube", "test_tube", "diameter_mm", (6, 40), ("test tube", "glass tube", "culture tube")),
}
REQUEST_WORDS = frozenset(
    [
        "make",
        "create",
        "generate",
        "model",
        "add",
        "build",
        "design",
        "draw",
        "need",
        "want",
        "give",
        "new",
        "asset",
        "assets",
        "labware",
        "lab",
        "ware",
        "piece",
        "of",
        "a",
        "an",
        "the",
        "one",
        "please",
        "me",
        "i",
        "we",
        "us",
        "for",
    ]
)
"""Words of an asset request that ask for nothing more than the asset itself."""
UNITS = frozenset(
    [
        "ml",
        "millilitre",
        "millilitres",
        "milliliter",
        "milliliters",
        "l",
        "litre",
        "litres",
        "liter",
        "liters",
        "mm",
        "cm",
        "x",
        "by",
    ]
)
"""Units of the sizes a generator takes (used where a number of the draft is)."""

PROMPT = """You choose a parametric generator for a lab-ware asset described in English.
Reply with one JSON object: {{"generator": one of {generators}, "volume_ml": number or null,
"diameter_mm": number or null, "length_mm": number or null}}.
Volume generators ({volume}) need volume_ml; petri_dish needs diameter_mm; test_tube needs
diameter_mm and length_mm (e.g. "16 x 150 mm" -> 16 and 150). Nothing else."""


class AssetDraftSpec(Spec):
    """Which generator, and its size."""

    generator: Generator
    volume_ml: float | None = Field(None, gt=0, le=5000)
    diameter_mm: float | None = Field(None, gt=0, le=250)
    length_mm: float | None = Field(None, gt=0, le=300)

    @model_validator(mode="after")
    def _sizes(self) -> AssetDraftSpec:
        _, _, kind, (low, high), _ = FAMILIES[self.generator]
        value = getattr(self, kind)
        if value is None:
            raise ValueError(f"{self.generator} needs {kind}")
        if not low <= value <= high:
            raise ValueError(
                f"{self.generator}: {kind} = {value:g} is outside what its generator can make ({low:g}-{high:g})"
            )
        if self.generator == "test_tube" and (
            self.length_mm is None or not 50 <= self.length_mm <= 250 or self.length_mm < 3 * (self.diameter_mm or 0)
        ):
            raise ValueError("test_tube needs length_mm between 50 and 250 and at least 3 diameters")
        return self

    def size(self, field: SizeField) -> float:
        """A size the generator needs (the validator has checked it is set)."""
        value = getattr(self, field)
        if value is None:
            raise DraftError(f"{self.generator} needs {field}")
        return float(value)

    def describe(self) -> str:
        if self.generator == "test_tube":
            return f"{self.diameter_mm:g} x {self.length_mm:g} mm"
        if self.generator == "petri_dish":
            return f"{self.diameter_mm:g} mm"
        return f"{self.volume_ml:g} mL"

    def default_id(self) -> str:
        prefix = FAMILIES[self.generator][1]
        if self.generator == "test_tube":
            return f"{prefix}_{self.diameter_mm:g}x{self.length_mm:g}".replace(".", "_")
        if self.generator == "petri_dish":
            return f"{prefix}_{self.diameter_mm:g}mm".replace(".", "_")
        return f"{prefix}_{self.volume_ml:g}ml".replace(".", "_")


def parse_asset(description: str) -> AssetDraftSpec:
    """Offline: the generator from the family words, the size from "250 mL", "1 L", "90 mm", "16 x 150 mm"."""
    text = description.lower().replace("×", "x").replace("µ", "u")
    text = re.sub(r"(\d),(\d{3})\b", r"\1\2", text)
    found = None
    for phrase, generator in sorted(((p, g) for g, f in FAMILIES.items() for p in f[4]), key=lambda pg: -len(pg[0])):
        if re.search(rf"\b{re.escape(phrase)}\b", text):
            found = generator
            break
    if found is None:
        raise DraftError(
            f"no parametric generator for {description!r}; generators: {', '.join(FAMILIES)} "
            f"(e.g. 'a 300 mL beaker', 'a 120 mm petri dish', 'a 12 x 75 mm test tube'){_library_has(description)}"
        )
    values: dict[str, float] = {}
    if m := re.search(r"(\d+(?:\.\d+)?)\s*(?:x|by)\s*(\d+(?:\.\d+)?)\s*mm\b", text):
        values = {"diameter_mm": float(m[1]), "length_mm": float(m[2])}
    elif m := re.search(r"(\d+(?:\.\d+)?)\s*(?:ml|millilit(?:er|re)s?)\b", text):
        values = {"volume_ml": float(m[1])}
    elif m := re.search(r"(\d+(?:\.\d+)?)\s*(?:l|lit(?:er|re)s?)\b", text):
        values = {"volume_ml": float(m[1]) * 1000}
    elif m := re.search(r"(\d+(?:\.\d+)?)\s*mm\b", text):
        values = {"diameter_mm": float(m[1])}
    elif m := re.search(r"(\d+(?:\.\d+)?)\s*cm\b", text):
        values = {"diameter_mm": float(m[1]) * 10}
    try:
        return AssetDraftSpec(generator=found, **values)
    except ValueError as exc:
        raise DraftError(
            f"cannot make {description!r}: {exc.errors()[0]['msg'].removeprefix('Value error, ') if hasattr(exc, 'errors') else exc}"
        ) from None


def _library_has(description: str) -> str:
    """ "; the library has: well_plate_384, ..." for the kinds the description names, else ""."""
    from pipette_cli.language.assets import load_vocabulary  # deferred: the asset vocabulary

    vocab = load_vocabulary()
    ids = list(dict.fromkeys(a for _, kind in vocab.names_in(description.lower()) for a in vocab.members(kind)))
    if not ids:
        return ""
    sizes = set(re.findall(r"\d+", description))  # "a 384-well plate" -> well_plate_384 first
    ids.sort(key=lambda a: not sizes & set(re.findall(r"\d+", a)))
    more = f" and {len(ids) - 6} more" if len(ids) > 6 else ""
    return f"; the library has: {', '.join(ids[:6])}{more} (`pipette assets show ID`)"


def unused_words(description: str, spec: AssetDraftSpec, made: str = "") -> list[str]:
    """The words of ``description`` that ``spec`` does not explain, in order: every word but the
    family's names, the numbers of its sizes (in mL, L, mm or cm) with their units, the words of
    ``made`` (the made asset's own description: "glass", "blue screw cap") and words that only ask
    for an asset (the same check for the offline parser and an LLM's answer)."""
    from pipette_cli.language.assets import load_vocabulary  # deferred: the asset vocabulary

    words = load_vocabulary().words
    text = description.lower().replace("×", " x ").replace("µ", "u")
    text = re.sub(r"(\d),(\d{3})\b", r"\1\2", text)
    text = re.sub(r"(\d)([a-z])", r"\1 \2", text)  # "500ml" -> "500 ml"
    for phrase in sorted([*words.polite, *FAMILIES[spec.generator][4]], key=len, reverse=True):
        text = re.sub(rf"\b{re.escape(phrase)}\b", " ", text)
    sizes = [v for v in (spec.volume_ml, spec.diameter_mm, spec.length_mm) if v is not None]
    said = {v * f for v in sizes for f in (1.0, 0.001, 0.1)}  # mL or L, mm or cm
    known = REQUEST_WORDS | set(words.articles) | set(words.fillers) | set(re.findall(r"[a-z]+", made.lower()))
    tokens = re.findall(r"\d+(?:\.\d+)?|[a-z][a-z'-]*", text)
    numbers = {t for t in tokens if t[0].isdigit() and any(math.isclose(float(t), v) for v in said)}
    return [t for t in tokens if t not in known and t not in numbers and not (t in UNITS and numbers)]


def _references(function_name: str) -> list[tuple[str, partial[AssetDef]]]:
    out = []
    for asset_id, gen in all_generators().items():
        factory = gen.factory
        if isinstance(factory, partial) and factory.func.__name__ == function_name:
            if function_name == "tube" and not asset_id.startswith("test_tube"):
                continue
            out.append((asset_id, factory))
    if not out:
        raise AssetError(f"no registered generator uses {function_name}()")
    return out


def build_asset(spec: AssetDraftSpec, asset_id: str) -> tuple[AssetDef, str]:
    """The :class:`~pipette_cli.assets.model.AssetDef` of ``spec``, scaled from the nearest reference,
    and the reference's id."""
    function_name = FAMILIES[spec.generator][0]
    refs = _references(function_name)
    func = refs[0][1].func
    if spec.generator == "petri_dish":
        dish = spec.size("diameter_mm") / 1000
        ref_id, ref = min(refs, key=lambda r: abs(math.log(dish / r[1].args[1])))
        _, diameter, height, mass = ref.args
        s = dish / diameter
        return func(asset_id, dish, height, mass * s * s), ref_id
    if spec.generator == "test_tube":
        radius, length = spec.size("diameter_mm") / 2000, spec.size("length_mm") / 1000
        ref_id, ref = min(refs, key=lambda r: abs(math.log(radius / r[1].keywords["radius"])))
        kw = dict(ref.keywords)
        kw["mass"] = kw["mass"] * (radius * length) / (ref.keywords["radius"] * ref.keywords["length"])
        inner = radius - kw.get("wall", 0.0008)
        kw["volume_ml"] = round(math.pi * inner * inner * length * 0.9e6, 1)
        kw.update(radius=radius, length=length)
        kw.pop("description", None)
        description = f"Borosilicate glass test tube, {spec.diameter_mm:g} mm x {spec.length_mm:g} mm."
        return func(asset_id, description, **kw), ref_id
    volume = spec.size("volume_ml")
    ref_id, ref = min(refs, key=lambda r: abs(math.log(volume / r[1].args[1])))
    args = list(ref.args)
    s = (volume / args[1]) ** (1 / 3)
    mass_index = {"beaker": 4, "erlenmeyer": 6, "volumetric_flask": 5, "media_bottle": 6, "graduated_cylinder": 5}[
        function_name
    ]
    for i in range(2, mass_index):
        args[i] = args[i] * s
    args[mass_index] = args[mass_index] * s * s
    args[0], args[1] = asset_id, volume
    return func(*args), ref_id


@dataclass
class DraftedAsset:
    """A generated, validated asset held in memory until written."""

    spec: AssetDraftSpec
    asset_id: str
    category: str
    text: str
    reference: str
    existing: str | None
    dimensions: list[float]
    mass: float
    description: str = ""
    """The asset's own description (its material, cap, ...)."""
    not_understood: list[str] = field(default_factory=list)
    """Words of the description the draft does not use (see :func:`unused_words`)."""

    def summary(self) -> dict[str, Any]:
        return {
            "id": self.asset_id,
            "category": self.category,
            "generator": self.spec.generator,
            "size": self.spec.describe(),
            "scaled_from": self.reference,
            "dimensions_m": self.dimensions,
            "mass_kg": round(self.mass, 4),
            "not_understood": self.not_understood,
        }


def make_asset(spec: AssetDraftSpec, asset_id: str | None = None) -> DraftedAsset:
    """Build and validate the asset in a temporary folder.

    Raises:
        AssetError: the asset fails validation (every problem listed).
    """
    name = asset_id or spec.default_id()
    if not re.fullmatch(r"[a-z][a-z0-9_]*", name):
        raise PipetteError(f"asset id {name!r} must be lower_snake_case (letters, digits, _)")
    library = load_asset_library()
    existing = spec.default_id() if spec.default_id() in library else None
    if asset_id and asset_id in library:
        raise PipetteError(
            f"asset id {asset_id!r} is already in the library ({library.get(asset_id).path}); choose another --id"
        )
    asset, reference = build_asset(spec, name)
    with tempfile.TemporaryDirectory(prefix="pipette_asset_") as tmp:
        path = Path(tmp) / asset.category / f"{name}.usda"
        write_usda(asset, path)
        report = validate_asset(path, asset.category)
        if not report.ok:
            raise AssetError([f"generated asset {name} fails validation: {p}" for p in report.problems])
        text = path.read_text(encoding="utf-8")
    lo, hi = asset.bounds()
    return DraftedAsset(
        spec,
        name,
        asset.category,
        text,
        reference,
        existing,
        [round(float(v), 4) for v in (hi - lo)],
        asset.total_mass(),
        asset.description,
    )


def draft_asset(description: str, backend: AuthoringBackend, *, asset_id: str | None = None) -> DraftedAsset:
    """Description -> validated asset, with the offline parser or an LLM backend; the words of the
    description it does not use are listed in ``not_understood``."""
    if backend.name == "offline":
        drafted = make_asset(parse_asset(description), asset_id)
    else:
        system = PROMPT.format(
            generators=", ".join(FAMILIES), volume=", ".join(g for g, f in FAMILIES.items() if f[2] == "volume_ml")
        )
        drafted = backend.complete(
            system=system,
            user=f"Asset description: {description}",
            schema=AssetDraftSpec,
            accept=lambda spec: make_asset(spec, asset_id),
        )
    return replace(drafted, not_understood=unused_words(description, drafted.spec, drafted.description))


def default_asset_root() -> Path:
    """First ``PIPETTE_ASSET_PATH`` folder, else ``./pipette_assets``."""
    paths = env_paths(ASSET_PATH_ENV)
    return paths[0] if paths else Path(os.getcwd()) / "pipette_assets"


@dataclass
class WrittenAsset:
    path: Path
    seconds: float

    def as_dict(self) -> dict[str, Any]:
        return {"path": str(self.path), "ok": True}


def write_asset(drafted: DraftedAsset, root: Path, *, force: bool = False) -> WrittenAsset:
    """Write the validated asset to ``root/<category>/<id>.usda``."""
    start = time.perf_counter()
    path = root / drafted.category / f"{drafted.asset_id}.usda"
    if path.exists() and not force:
        raise PipetteError(f"{path} exists; pass --force to overwrite")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".usda.tmp")
    tmp.write_text(drafted.text, encoding="utf-8")
    shutil.move(tmp, path)
    return WrittenAsset(path, time.perf_counter() - start)

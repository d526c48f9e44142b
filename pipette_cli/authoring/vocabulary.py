"""The words a description may use for each asset: kinds, synonyms, sizes, modifiers.

Each asset belongs to one or more *kinds* (``conical tube``, ``tube rack``, ``balance``...).
A kind has the phrases people use for it ("falcon tube", "eppendorf", "scale") and a
default member for when the description gives no size. Sizes ("15 mL", "90 mm", "96-well",
"P200", "T75", "8-channel", "16 x 150 mm") become *size tags* compared with tags derived
from each asset's id and semantics (``volume_ml``, ``volume_ul``, ``channels``, rows x cols).
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field
from functools import cache

from pipette_cli.assets.library import load_asset_library


@dataclass(frozen=True)
class Kind:
    """A family of assets and the phrases that name it."""

    name: str
    aliases: tuple[str, ...]
    pattern: str  # regex over asset ids
    default: str | None = None


KINDS: tuple[Kind, ...] = (
    # consumables -------------------------------------------------------------------------
    Kind("beaker", ("beaker", "glass beaker"), r"^beaker_", "beaker_250ml"),
    Kind("erlenmeyer flask", ("erlenmeyer flask", "erlenmeyer", "conical flask", "shake flask"), r"^erlenmeyer_flask_", "erlenmeyer_flask_250ml"),
    Kind("volumetric flask", ("volumetric flask",), r"^volumetric_flask_", "volumetric_flask_250ml"),
    Kind("cell culture flask", ("cell culture flask", "culture flask", "tissue culture flask", "t-flask", "t flask"), r"^cell_culture_flask_", "cell_culture_flask_t75"),
    Kind("flask", ("flask",), r"^(erlenmeyer_flask_|volumetric_flask_|cell_culture_flask_)", "erlenmeyer_flask_250ml"),
    Kind("media bottle", ("media bottle", "medium bottle", "reagent bottle", "duran bottle", "schott bottle", "glass bottle", "bottle"), r"^media_bottle_", "media_bottle_500ml"),
    Kind("wash bottle", ("wash bottle", "squeeze bottle", "squirt bottle"), r"^wash_bottle_", "wash_bottle_500ml"),
    Kind("graduated cylinder", ("graduated cylinder", "measuring cylinder", "cylinder"), r"^graduated_cylinder_", "graduated_cylinder_100ml"),
    Kind("conical tube", ("conical tube", "falcon tube", "falcon", "centrifuge tube", "conical centrifuge tube"), r"^conical_tube_\d+ml", "conical_tube_15ml"),
    Kind("microtube", ("microcentrifuge tube", "microtube", "micro tube", "eppendorf tube", "eppendorf", "snap cap tube", "microfuge tube"), r"^microtube_\d", "microtube_1_5ml"),
    Kind("test tube", ("test tube", "glass tube", "culture tube"), r"^test_tube_\d", "test_tube_16x150"),
    Kind("cryovial", ("cryovial", "cryo vial", "cryotube", "cryo tube", "cryogenic vial", "vial"), r"^cryovial_", "cryovial_2ml"),
    Kind("pcr tube", ("pcr tube",), r"^pcr_tube_", "pcr_tube_0_2ml"),
    Kind("pcr strip", ("pcr strip", "strip tubes", "tube strip", "8 strip"), r"^pcr_strip_", "pcr_strip_8"),
    Kind("tube", ("tube",), r"^(conical_tube_\d+ml|microtube_\d|test_tube_\d|cryovial_|pcr_tube_)", "test_tube_16x150"),
    Kind("petri dish", ("petri dish", "petri plate", "agar plate", "culture dish", "petri", "dish"), r"^petri_dish_\d", "petri_dish_90mm"),
    Kind("deep well plate", ("deep well plate", "deepwell plate", "deep well block"), r"^deep_well_plate_", "deep_well_plate_96"),
    Kind("pcr plate", ("pcr plate",), r"^pcr_plate_", "pcr_plate_96"),
    Kind("well plate", ("well plate", "microplate", "multiwell plate", "microtiter plate", "culture plate", "plate"), r"^(well_plate_|deep_well_plate_|pcr_plate_)", "well_plate_96"),
    Kind("reservoir", ("reagent reservoir", "reservoir", "trough"), r"^(reagent_reservoir_|reservoir_)", "reagent_reservoir_25ml"),
    Kind("cuvette", ("cuvette",), r"^cuvette_", "cuvette_standard"),
    Kind("microscope slide", ("microscope slide", "glass slide", "slide"), r"^microscope_slide$", "microscope_slide"),
    Kind("coverslip", ("coverslip", "cover slip", "cover glass"), r"^coverslip_", "coverslip_22mm"),
    Kind("pipette tip", ("pipette tip", "tip"), r"^pipette_tip_", "pipette_tip_200ul"),
    Kind("syringe", ("syringe",), r"^syringe_", "syringe_10ml"),
    Kind("weighing boat", ("weighing boat", "weigh boat", "weighing dish"), r"^weighing_boat_", "weighing_boat_medium"),
    Kind("tape", ("tape roll", "lab tape", "labelling tape", "labeling tape", "tape"), r"^lab_tape_roll$", "lab_tape_roll"),
    Kind("wipes", ("wipes box", "box of wipes", "kimwipes", "task wipes", "wipes"), r"^wipes_box$", "wipes_box"),
    Kind("gloves", ("glove box", "box of gloves", "gloves"), r"^glove_box_", "glove_box_nitrile"),
    # tools ---------------------------------------------------------------------------------
    Kind("multichannel pipette", ("multichannel pipette", "multi channel pipette", "multichannel"), r"^pipette_multichannel_", "pipette_multichannel_8"),
    Kind("serological pipette", ("serological pipette", "serological", "stripette"), r"^serological_pipette_", "serological_pipette_10ml"),
    Kind("pipette controller", ("pipette controller", "pipet aid", "pipette aid", "pipet controller", "pipette gun", "pipetboy"), r"^pipette_controller$", "pipette_controller"),
    Kind("pipette", ("single channel pipette", "micropipette", "pipettor", "pipette", "pipet"), r"^pipette_(single_channel|multichannel_)", "pipette_single_channel"),
    Kind("cell scraper", ("cell scraper", "scraper"), r"^cell_scraper$", "cell_scraper"),
    Kind("stirring rod", ("stirring rod", "stir rod", "glass rod", "rod"), r"^glass_stirring_rod$", "glass_stirring_rod"),
    Kind("inoculation loop", ("inoculation loop", "inoculating loop", "loop"), r"^inoculation_loop$", "inoculation_loop"),
    Kind("marker", ("marker pen", "marker", "sharpie", "pen"), r"^marker_pen$", "marker_pen"),
    Kind("spatula", ("spatula",), r"^spatula$", "spatula"),
    Kind("tweezers", ("tweezers", "forceps"), r"^tweezers$", "tweezers"),
    # equipment -------------------------------------------------------------------------------
    Kind("conical tube rack", ("conical tube rack", "falcon tube rack", "falcon rack", "conical rack"), r"^conical_tube_rack_", "conical_tube_rack_15ml"),
    Kind("microtube rack", ("microtube rack", "microcentrifuge tube rack", "eppendorf rack", "eppendorf tube rack"), r"^microtube_rack_", "microtube_rack_24"),
    Kind("pcr rack", ("pcr rack", "pcr tube rack"), r"^pcr_rack_", "pcr_rack_96"),
    Kind("test tube rack", ("test tube rack",), r"^test_tube_rack_", "test_tube_rack_16mm"),
    Kind("floating rack", ("floating tube rack", "floating rack", "float rack"), r"^floating_tube_rack$", "floating_tube_rack"),
    Kind("cryo box", ("cryo box", "cryobox", "freezer box", "cryogenic box", "cryovial box", "storage box"), r"^cryo_box_", "cryo_box_81"),
    Kind("tube rack", ("tube rack", "rack"), r"^(conical_tube_rack_|microtube_rack_|pcr_rack_|test_tube_rack_|floating_tube_rack|cryo_box_)", "conical_tube_rack_15ml"),
    Kind("petri dish rack", ("petri dish rack", "dish rack", "petri rack", "dish carrier"), r"^petri_dish_rack$", "petri_dish_rack"),
    Kind("drying rack", ("drying rack", "glassware rack"), r"^drying_rack$", "drying_rack"),
    Kind("pipette stand", ("pipette stand", "pipette rack", "pipette holder", "pipette carousel", "stand"), r"^pipette_stand_", "pipette_stand_linear"),
    Kind("tip box", ("tip box", "tip rack", "box of tips"), r"^tip_box_", "tip_box_200ul"),
    Kind("tip waste box", ("tip waste box", "tip waste", "tip disposal box", "tip bin"), r"^tip_waste_box$", "tip_waste_box"),
    Kind("ice bucket", ("ice bucket", "ice box", "ice"), r"^ice_bucket$", "ice_bucket"),
    Kind("tray", ("lab tray", "tray"), r"^lab_tray_", "lab_tray_small"),
    Kind("bench mat", ("bench mat", "silicone mat", "mat"), r"^bench_mat$", "bench_mat"),
    Kind("biohazard bin", ("biohazard bin", "biohazard waste bin", "waste bin", "biohazard bag", "bin", "trash"), r"^biohazard_bin$", "biohazard_bin"),
    Kind("sharps container", ("sharps container", "sharps bin", "sharps"), r"^sharps_container$", "sharps_container"),
    Kind("slide box", ("slide box", "slide storage box"), r"^slide_box$", "slide_box"),
    Kind("reagent shelf", ("reagent shelf", "reagent rack", "bottle shelf"), r"^reagent_shelf$", "reagent_shelf"),
    Kind("ring stand", ("ring stand", "retort stand", "support ring"), r"^ring_stand$", "ring_stand"),
    Kind("biosafety cabinet", ("biosafety cabinet", "safety cabinet", "tissue culture hood", "laminar flow hood", "flow hood", "hood", "sash"), r"^biosafety_cabinet", "biosafety_cabinet_sash"),
    Kind("weighing table", ("weighing table", "balance table", "anti vibration table"), r"^balance_table$", "balance_table"),
    # instruments -------------------------------------------------------------------------------
    Kind("microcentrifuge", ("microcentrifuge", "micro centrifuge", "mini centrifuge", "minicentrifuge", "microfuge"), r"^microcentrifuge$", "microcentrifuge"),
    Kind("centrifuge", ("benchtop centrifuge", "centrifuge"), r"^centrifuge_benchtop$", "centrifuge_benchtop"),
    Kind("balance", ("electronic balance", "analytical balance", "precision balance", "weighing scale", "balance", "scale"), r"^electronic_balance$", "electronic_balance"),
    Kind("hot plate", ("hot plate stirrer", "hot plate", "hotplate", "magnetic stirrer", "stir plate", "stirrer"), r"^hot_plate_stirrer$", "hot_plate_stirrer"),
    Kind("incubator", ("co2 incubator", "incubator"), r"^incubator_benchtop$", "incubator_benchtop"),
    Kind("plate reader", ("microplate reader", "plate reader", "reader"), r"^microplate_reader$", "microplate_reader"),
    Kind("shaker", ("orbital shaker", "platform shaker", "shaker"), r"^orbital_shaker$", "orbital_shaker"),
    Kind("spectrophotometer", ("spectrophotometer", "uv vis spectrophotometer", "uv vis", "photometer", "spectro"), r"^spectrophotometer$", "spectrophotometer"),
    Kind("thermal cycler", ("thermal cycler", "thermocycler", "pcr machine", "pcr cycler", "cycler"), r"^thermal_cycler$", "thermal_cycler"),
    Kind("vortex mixer", ("vortex mixer", "vortexer", "vortex"), r"^vortex_mixer$", "vortex_mixer"),
    Kind("water bath lid", ("water bath lid", "bath lid"), r"^water_bath_lid$", "water_bath_lid"),
    Kind("water bath", ("water bath", "bath"), r"^water_bath$", "water_bath"),
)

BENCH_WORDS = ("lab bench", "bench", "table", "benchtop", "counter", "workbench")
"""Phrases naming the bench itself: a location, never a scene object."""

SIZE_CLASSES = ("ml", "ul", "mm", "well", "channel", "p", "t", "x")


def size_class(tag: str) -> str:
    if re.fullmatch(r"\d+(\.\d+)?x\d+", tag):
        return "x"
    for cls in ("channel", "well", "ml", "ul", "mm"):
        if tag.endswith(cls):
            return cls
    return tag[0]


def _num(text: str) -> str:
    return f"{float(text.replace(',', '.').replace('_', '.')):g}"


def asset_size_tags(asset_id: str, semantics: dict) -> frozenset[str]:
    """Size tags of an asset from its id and semantics (``15ml``, ``90mm``, ``96well``, ``p200``...)."""
    tags: set[str] = set()
    for number, unit in re.findall(r"(\d+(?:_\d+)?)(ml|ul|mm)(?![a-z])", asset_id):
        tags.add(_num(number) + unit)
    m = re.search(r"_(\d+)x(\d+)$", asset_id)
    if m:
        tags.add(f"{m.group(1)}x{m.group(2)}")
        tags.add(f"{m.group(1)}mm")
    m = re.search(r"_t(\d+)$", asset_id)
    if m:
        tags.add(f"t{m.group(1)}")
    if semantics.get("volume_ml") is not None:
        tags.add(f"{float(semantics['volume_ml']):g}ml")
    if semantics.get("volume_ul") is not None:
        ul = float(semantics["volume_ul"])
        tags.add(f"{ul:g}ul")
        if ul >= 1000:
            tags.add(f"{ul / 1000:g}ml")
    if semantics.get("rows") and semantics.get("cols"):
        tags.add(f"{int(semantics['rows'] * semantics['cols'])}well")
    if semantics.get("channels") and asset_id.startswith(("pipette", "reservoir")):
        tags.add(f"{int(semantics['channels'])}channel")
    if asset_id.startswith("pipette_single_channel") and semantics.get("volume_ul"):
        tags.add(f"p{int(semantics['volume_ul'])}")
    if asset_id.startswith("tip_box_") or asset_id.startswith("pipette_tip_"):
        tags.update(t for t in list(tags) if t.endswith("ul"))
    return frozenset(tags)


def _words(text: str) -> set[str]:
    return set(re.findall(r"[a-z0-9]+", text.lower()))


@dataclass(frozen=True)
class AssetInfo:
    """What the parser knows about one asset without compiling it."""

    asset_id: str
    category: str
    semantics: dict
    kinds: tuple[str, ...]
    size_tags: frozenset[str]
    words: frozenset[str]

    @property
    def graspable(self) -> bool:
        return bool(self.semantics.get("graspable")) and not self.semantics.get("static", False)

    @property
    def static(self) -> bool:
        return bool(self.semantics.get("static"))

    @property
    def description(self) -> str:
        return str(self.semantics.get("description", ""))

    def human_name(self) -> str:
        """``15 mL conical tube`` for ``conical_tube_15ml``: the words a person would use."""
        name = self.kinds[0] if self.kinds else self.asset_id.replace("_", " ")
        digits = set(re.findall(r"\d+", self.asset_id.replace("1_5", "1.5").replace("0_2", "0.2")))
        named = [t for t in self.size_tags if (re.match(r"[\d.]+|[pt](\d+)", t) or [None])[0].lstrip("pt") in digits
                 or t.replace("1.5", "1.5") in self.asset_id.replace("_", ".")]
        order = ("well", "channel", "ml", "ul", "mm", "p", "t", "x")
        named.sort(key=lambda t: order.index(size_class(t)))
        if not named:
            return name
        tag = named[0]
        if size_class(tag) == "well" and name.endswith("well plate"):
            return f"{tag[:-4]}-{name}"
        return f"{_pretty_size(tag)} {name}"


def _pretty_size(tag: str) -> str:
    for unit, shown in (("ml", "mL"), ("ul", "uL"), ("mm", "mm")):
        if tag.endswith(unit):
            return tag[: -len(unit)] + " " + shown
    if tag.endswith("well"):
        return tag[:-4] + "-well"
    if tag.endswith("channel"):
        return tag[:-7] + "-channel"
    if tag.startswith(("p", "t")):
        return tag.upper()
    return tag


@dataclass
class Vocabulary:
    """Every asset with its kinds, size tags and words; alias phrases to kinds."""

    assets: dict[str, AssetInfo]
    kinds: dict[str, Kind]
    alias_to_kind: dict[str, str] = field(default_factory=dict)

    def members(self, kind: str) -> list[str]:
        return [a for a, info in self.assets.items() if kind in info.kinds]

    def aliases(self) -> list[str]:
        """Alias phrases, longest first (for greedy matching)."""
        return sorted(self.alias_to_kind, key=lambda a: (-len(a.split()), -len(a), a))

    def closest(self, words: str, n: int = 3) -> list[str]:
        """Asset ids closest to an unknown phrase (alias spelling, then id, then description words)."""
        phrase = words.lower().strip()
        scored: dict[str, float] = {}
        for alias in difflib.get_close_matches(phrase, list(self.alias_to_kind), n=5, cutoff=0.6):
            kind = self.kinds[self.alias_to_kind[alias]]
            ratio = difflib.SequenceMatcher(None, phrase, alias).ratio()
            for asset in ([kind.default] if kind.default else self.members(kind.name)):
                scored[asset] = max(scored.get(asset, 0.0), ratio + 1.0)
        for asset_id in difflib.get_close_matches(phrase.replace(" ", "_"), list(self.assets), n=n, cutoff=0.5):
            scored[asset_id] = max(scored.get(asset_id, 0.0), 1.0 + difflib.SequenceMatcher(None, phrase, asset_id).ratio() / 2)
        query = _words(phrase)
        for asset_id, info in self.assets.items():
            overlap = len(query & info.words)
            if overlap:
                scored[asset_id] = max(scored.get(asset_id, 0.0), 0.3 * overlap)
        return [a for a, _ in sorted(scored.items(), key=lambda kv: (-kv[1], kv[0]))[:n]]


@cache
def load_vocabulary() -> Vocabulary:
    """The vocabulary of the current asset library (reads every asset's semantics once)."""
    library = load_asset_library()
    kinds = {k.name: k for k in KINDS}
    assets: dict[str, AssetInfo] = {}
    for entry in library.entries.values():
        semantics = entry.semantics()
        member_of = tuple(k.name for k in KINDS if re.search(k.pattern, entry.asset_id))
        words = _words(entry.asset_id.replace("_", " ") + " " + str(semantics.get("description", "")))
        assets[entry.asset_id] = AssetInfo(entry.asset_id, entry.category, semantics, member_of,
                                           asset_size_tags(entry.asset_id, semantics), frozenset(words))
    alias_to_kind: dict[str, str] = {}
    for kind in KINDS:
        if kind.default is not None and kind.default not in assets:
            kind = Kind(kind.name, kind.aliases, kind.pattern, None)
            kinds[kind.name] = kind
        for alias in kind.aliases:
            alias_to_kind.setdefault(alias, kind.name)
    # assets no kind covers (user assets on PIPETTE_ASSET_PATH) are reachable by their id words
    for asset_id, info in assets.items():
        if not info.kinds and asset_id != "lab_bench":
            name = asset_id.replace("_", " ")
            kinds[name] = Kind(name, (name,), rf"^{re.escape(asset_id)}$", asset_id)
            alias_to_kind.setdefault(name, name)
            assets[asset_id] = AssetInfo(asset_id, info.category, info.semantics, (name,), info.size_tags, info.words)
    return Vocabulary(assets, kinds, alias_to_kind)

"""The one registry type: duplicates name both definitions, unknown names get did-you-mean."""

from __future__ import annotations

import pytest

from pipette_cli.errors import EvaluatorError
from pipette_cli.plugins import Plugins


def first() -> None: ...


def second() -> None: ...


def test_a_name_defined_twice_names_both_places() -> None:
    things: Plugins = Plugins("widget", EvaluatorError)
    things.register("spin")(first)
    things.register("spin")(first)  # the same definition again (a module imported twice) is fine
    with pytest.raises(EvaluatorError) as err:
        things.register("spin")(second)
    assert "widget 'spin' is defined twice" in str(err.value)
    assert str(err.value).count("test_plugins.py:") == 2


def test_an_unknown_name_suggests_the_closest() -> None:
    things: Plugins = Plugins("widget")
    things.register("region_hold", "lift_and_hold")(first)
    with pytest.raises(Exception, match="unknown widget 'region_hod'; did you mean 'region_hold'"):
        things.get("region_hod")
    assert things.find("nope") is None and things.names() == ["lift_and_hold", "region_hold"]


def test_every_registry_of_the_package_is_one() -> None:
    from pipette_cli.assets.generators import GENERATORS, all_generators
    from pipette_cli.skills.derive import DERIVERS
    from pipette_cli.skills.library import skill_runtime
    from pipette_cli.skills.runtime import SKILL_RUNTIMES
    from pipette_cli.specs.expert import PickSpec

    skill_runtime(PickSpec)
    assert all(isinstance(r, Plugins) for r in (GENERATORS, DERIVERS, SKILL_RUNTIMES))
    assert len(all_generators()) > 100 and "place_on" in SKILL_RUNTIMES and "region_hold" in DERIVERS

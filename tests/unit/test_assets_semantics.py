"""Semantics read straight from the USD files, without compiling."""

from __future__ import annotations

import pytest

from pipette_cli.assets.library import load_asset_library

SITES = {
    "test_tube_16x150": {"grasp"},
    "pipette_single_channel": {"tip", "grasp"},
    "petri_dish_90mm": {"center"},
    "incubator_benchtop": {"shelf_0_center", "shelf_1_center", "door_handle"},
    "centrifuge_benchtop": {"button", "lid_handle"},
    "water_bath_lid": {"lid_handle"},
    "spectrophotometer": {"lid_handle", "cuvette_slot"},
    "electronic_balance": {"pan_center"},
    "pipette_stand_linear": {"slot_0", "slot_1", "slot_2", "slot_3"},
    "orbital_shaker": {"platform_center"},
}


def semantics(asset_id: str) -> dict:
    return load_asset_library().get(asset_id).semantics()


@pytest.mark.parametrize("asset_id", sorted(SITES))
def test_benchmark_sites_are_declared(asset_id: str) -> None:
    assert SITES[asset_id] <= set(semantics(asset_id)["sites"])


def test_bench_dimensions() -> None:
    s = semantics("lab_bench")
    assert s["top_height"] == pytest.approx(0.55)
    assert s["dimensions"][:2] == pytest.approx([1.6, 1.0])
    assert s["dimensions"][2] == pytest.approx(0.55)
    assert s["static"] is True and s["graspable"] is False


def test_pipette_mass_and_length() -> None:
    s = semantics("pipette_single_channel")
    assert 0.08 <= s["mass"] <= 0.10
    assert 0.22 <= s["dimensions"][2] <= 0.28
    assert s["upright"] is False and len(s["rest_quat"]) == 4


def test_balance_pan() -> None:
    s = semantics("electronic_balance")
    assert 0.08 <= s["pan_height"] <= 0.10
    assert s["pan_size"] == pytest.approx([0.13, 0.13])
    assert "pan" in s["bodies"]


def test_hinges_and_drives_are_listed() -> None:
    assert semantics("centrifuge_benchtop")["joints"] == ["lid_hinge"]
    assert semantics("centrifuge_benchtop")["actuators"] == ["lid_drive"]
    assert semantics("incubator_benchtop")["joints"] == ["door_hinge"]
    assert semantics("balance_table")["top_height"] == pytest.approx(0.12)


def test_every_asset_has_description_and_real_mass() -> None:
    for entry in load_asset_library().entries.values():
        s = entry.semantics()
        assert s["category"] == entry.category
        assert len(s["description"]) > 10, entry.asset_id
        assert 1e-4 <= s["mass"] <= 200, entry.asset_id

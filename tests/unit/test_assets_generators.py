"""Generators, geometry and the asset library on disk (no MuJoCo compile)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from pipette_cli.assets import geometry as g
from pipette_cli.assets.generators import all_generators, register
from pipette_cli.assets.library import CATEGORIES, load_asset_library
from pipette_cli.assets.model import Body, Collider
from pipette_cli.errors import AssetError

MINIMUM = {"tools": 12, "equipment": 26, "consumables": 55, "instruments": 9}
BENCHMARK = {
    "lab_bench": "equipment",
    "test_tube_16x150": "consumables",
    "pipette_single_channel": "tools",
    "petri_dish_90mm": "consumables",
    "incubator_benchtop": "instruments",
    "centrifuge_benchtop": "instruments",
    "water_bath": "instruments",
    "water_bath_lid": "instruments",
    "spectrophotometer": "instruments",
    "conical_tube_50ml_skirted": "consumables",
    "electronic_balance": "instruments",
    "balance_table": "equipment",
    "pipette_stand_linear": "equipment",
    "erlenmeyer_flask_250ml": "consumables",
    "orbital_shaker": "instruments",
}


def signed_volume(mesh: g.Mesh) -> float:
    """Volume by the divergence theorem: positive iff faces point outward."""
    total, start = 0.0, 0
    for count in mesh.counts:
        face = mesh.points[mesh.indices[start : start + count]]
        for k in range(1, count - 1):
            total += np.dot(face[0], np.cross(face[k], face[k + 1])) / 6
        start += count
    return total


def test_revolved_cylinder_is_closed_and_outward() -> None:
    mesh = g.revolve([(0, 0), (0.01, 0), (0.01, 0.1), (0, 0.1)], 64)
    assert signed_volume(mesh) == pytest.approx(np.pi * 0.01**2 * 0.1, rel=0.01)


def test_hollow_vessel_volume_is_the_wall_only() -> None:
    from pipette_cli.assets.parts import vessel_profile

    mesh = g.revolve(vessel_profile([(0.03, 0.0), (0.03, 0.1)], 0.002, 0.002), 96)
    solid = np.pi * 0.03**2 * 0.1
    wall = solid - np.pi * 0.028**2 * 0.098
    assert signed_volume(mesh) == pytest.approx(wall, rel=0.03)


def test_extruded_box_volume() -> None:
    assert signed_volume(g.box((0.1, 0.2, 0.3), (1, 2, 3), radius=0.0)) == pytest.approx(0.006)


def test_box_body_inertia_matches_formula() -> None:
    body = Body("b", 2.0, colliders=[Collider("c", "box", (0.05, 0.1, 0.15), (0.0, 0.0, 0.15))])
    com, moments, axes = body.mass_properties()
    assert com == pytest.approx([0, 0, 0.15])
    a, b, c = 0.1, 0.2, 0.3
    assert moments == pytest.approx([2 / 12 * (b * b + c * c), 2 / 12 * (a * a + c * c), 2 / 12 * (a * a + b * b)])
    assert axes == (1.0, 0.0, 0.0, 0.0)


def test_rotated_box_gets_principal_axes() -> None:
    quat = (np.cos(np.pi / 8), 0.0, 0.0, np.sin(np.pi / 8))  # 45 deg about z
    body = Body("b", 1.0, colliders=[Collider("c", "box", (0.2, 0.01, 0.01), (0, 0, 0), quat)])
    _, moments, axes = body.mass_properties()
    assert sorted(moments) == pytest.approx(
        sorted([1 / 12 * 0.0008, 1 / 12 * (0.16 + 0.0004), 1 / 12 * (0.16 + 0.0004)]), rel=1e-6
    )
    assert axes != (1.0, 0.0, 0.0, 0.0)


def test_duplicate_generator_id_is_rejected() -> None:
    all_generators()
    with pytest.raises(AssetError, match="defined twice"):
        register("beaker_250ml", "consumables", lambda: None)  # type: ignore[arg-type,return-value]


def test_library_has_the_paper_counts() -> None:
    counts = Counter(e.category for e in load_asset_library().entries.values())
    for category, minimum in MINIMUM.items():
        assert counts[category] >= minimum, category
    assert sum(counts.values()) >= 102
    assert set(counts) <= set(CATEGORIES)


@pytest.mark.parametrize("asset_id", sorted(BENCHMARK))
def test_benchmark_assets_exist_in_their_category(asset_id: str) -> None:
    assert load_asset_library().get(asset_id).category == BENCHMARK[asset_id]


def test_every_generator_has_a_file_and_ids_are_snake_case() -> None:
    library = load_asset_library()
    for asset_id, gen in all_generators().items():
        assert asset_id in library, asset_id
        assert library.get(asset_id).category == gen.category
        assert asset_id == asset_id.lower() and " " not in asset_id


def test_committed_files_match_the_generators(tmp_path: Path) -> None:
    """Drift check: regenerating gives byte-identical files (run `pipette assets generate`)."""
    from pipette_cli.assets.build import generate_assets

    library = load_asset_library()
    stale = [p.stem for p in generate_assets(tmp_path) if p.read_bytes() != library.get(p.stem).path.read_bytes()]
    assert not stale, f"regenerate these assets: {stale}"

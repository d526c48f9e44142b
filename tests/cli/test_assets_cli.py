"""``pipette assets ...`` end to end (CliRunner on the command group, one real subprocess)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pipette_cli.cli.assets import app
from pipette_cli.errors import AssetError

FIXTURES = Path(__file__).parent.parent / "fixtures" / "assets"
runner = CliRunner()


def test_list_json_counts_categories() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "pipette_cli.cli.main", "assets", "list", "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    rows = json.loads(result.stdout)
    assert len(rows) >= 102
    assert {r["category"] for r in rows} == {"tools", "equipment", "consumables", "instruments"}


def test_list_one_category() -> None:
    result = runner.invoke(app, ["list", "--category", "instruments", "--json"])
    assert result.exit_code == 0
    assert {r["category"] for r in json.loads(result.stdout)} == {"instruments"}


def test_show_json() -> None:
    result = runner.invoke(app, ["show", "centrifuge_benchtop", "--json"])
    assert result.exit_code == 0
    info = json.loads(result.stdout)
    assert info["joints"] == ["lid_hinge"] and "button" in info["sites"]
    assert {"pipette/CloseCentrifugeLid-v1", "pipette/OpenCentrifugeLid-v1"} <= set(info["used_by"])  # its tasks


def test_show_unknown_suggests() -> None:
    result = runner.invoke(app, ["show", "centrifuge"])
    assert isinstance(result.exception, AssetError)
    assert "did you mean" in str(result.exception)


def test_validate_good_assets_exits_0() -> None:
    result = runner.invoke(app, ["validate", "centrifuge_benchtop", "test_tube_16x150", "--json"])
    assert result.exit_code == 0, result.stdout
    assert json.loads(result.stdout)["failed"] == 0


def test_validate_reports_every_bad_asset_and_exits_1() -> None:
    before = {p: p.read_bytes() for p in FIXTURES.glob("*.usda")}
    result = runner.invoke(app, ["validate", str(FIXTURES), "beaker_250ml", "--json"])
    assert result.exit_code == 1
    report = json.loads(result.stdout)
    failed = {a["id"] for a in report["assets"] if not a["ok"]}
    assert failed == {"broken_syntax", "missing_reference", "exploding_dish"}
    assert {p: p.read_bytes() for p in FIXTURES.glob("*.usda")} == before


# ----------------------------------------------------------------------------- repair-paths


def _layer(path: Path, body: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("#usda 1.0\n" + body)


@pytest.fixture()
def scene_folder(tmp_path: Path) -> Path:
    """A scene with absolute and relative sublayer/reference/payload/attribute paths and a usdz package."""
    from pxr import Sdf, UsdUtils

    root = tmp_path / "project"
    _layer(
        root / "scene" / "props" / "cup.usda",
        '(\n defaultPrim = "cup"\n)\ndef Xform "cup" {\n def Cube "shape" {}\n}\n',
    )
    _layer(root / "scene" / "lights.usda", 'def Xform "lights" {}\n')
    _layer(root / "textures" / "wood_src" / "wood.usda", 'def Xform "w" {}\n')
    (root / "textures" / "wood_src" / "wood.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    pkg_layer = Sdf.Layer.FindOrOpen(str(root / "textures" / "wood_src" / "wood.usda"))
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(pkg_layer.identifier), str(root / "textures" / "wood.usdz"))
    old = "/old/workstation/assets"
    _layer(
        root / "scene" / "main.usda",
        f"""(
    subLayers = [@{root}/scene/lights.usda@]
)
def Xform "table" (
    prepend references = @./props/cup.usda@
)
{{
}}
def Xform "cup2" (
    prepend payload = @{old}/props/cup.usda@
)
{{
}}
def Shader "wood_tex"
{{
    asset inputs:file = @{old}/textures/wood.usdz[wood.png]@
    asset inputs:fallback = @./props/cup.usda@
}}
""",
    )
    return root


def test_repair_paths_reports_without_changing(scene_folder: Path, tmp_path: Path) -> None:
    main = scene_folder / "scene" / "main.usda"
    before = main.read_bytes()
    report_path = tmp_path / "report.json"
    result = runner.invoke(app, ["repair-paths", str(scene_folder), "--report", str(report_path)])
    assert result.exit_code == 0, result.output
    report = json.loads(report_path.read_text())
    refs = {(r["kind"], r["path"]): r for f in report["files"] for r in f["references"]}
    kinds = {k for k, _ in refs}
    assert kinds == {"sublayer", "reference", "payload", "attribute"}
    assert report["summary"]["absolute"] == 3 and report["summary"]["relative"] == 2
    package = next(r for (k, p), r in refs.items() if p.endswith("wood.usdz[wood.png]"))
    assert package["absolute"] and package["fixed_to"] == "../textures/wood.usdz[wood.png]"
    assert main.read_bytes() == before


def test_repair_paths_fix_rewrites_relative_and_is_idempotent(scene_folder: Path, tmp_path: Path) -> None:
    from pxr import Usd

    main = scene_folder / "scene" / "main.usda"
    result = runner.invoke(app, ["repair-paths", str(scene_folder), "--report", str(tmp_path / "r.json"), "--fix"])
    assert result.exit_code == 0, result.output
    text = main.read_text()
    assert "/old/workstation" not in text and str(scene_folder) not in text
    assert "@../textures/wood.usdz[wood.png]@" in text and "@./props/cup.usda@" in text
    assert (scene_folder / "scene" / "main.usda.bak").read_text().count("/old/workstation") == 2
    stage = Usd.Stage.Open(str(main))
    assert stage.GetPrimAtPath("/cup2").IsValid() and stage.GetPrimAtPath("/lights").IsValid()
    fixed = main.read_bytes()
    again = runner.invoke(app, ["repair-paths", str(scene_folder), "--report", str(tmp_path / "r2.json"), "--fix"])
    assert again.exit_code == 0
    assert main.read_bytes() == fixed
    assert json.loads((tmp_path / "r2.json").read_text())["summary"]["absolute"] == 0


def test_repair_paths_never_writes_unparseable_files(scene_folder: Path, tmp_path: Path) -> None:
    bad = scene_folder / "scene" / "broken.usda"
    bad.write_text('#usda 1.0\ndef Xform "x" ( prepend references = @/abs/cup.usda@ \n')
    before = bad.read_bytes()
    result = runner.invoke(app, ["repair-paths", str(scene_folder), "--report", str(tmp_path / "r.json"), "--fix"])
    assert result.exit_code == 1
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["summary"]["unparseable"] == 1
    assert bad.read_bytes() == before and not bad.with_name("broken.usda.bak").exists()

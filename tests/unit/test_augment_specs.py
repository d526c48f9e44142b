"""Perturbation specs: defaults of the paper, impossible parameters refused, the variant grid."""

from __future__ import annotations

import pytest

from pipette_cli.augment.report import yield_report
from pipette_cli.augment.specs import AugmentSpec, VariantSpec, default_atoms, make_variants
from pipette_cli.errors import SpecError
from pipette_cli.specs.perturbations import PERTURBATIONS, CameraPoseSpec, LightingSpec, SpeedSpec


def test_paper_defaults() -> None:
    atoms = default_atoms()
    assert atoms["light"].scale == 0.8
    assert (atoms["speed"].factor, atoms["speed"].rho, atoms["speed"].window) == (1.2, 0.10, 11)
    assert atoms["speed"].interpolation == "catmull_rom"
    assert (atoms["noise"].sigma, atoms["noise"].bound) == (0.005, 0.02)
    assert (atoms["cam"].radius, atoms["cam"].wrist_radius) == (0.2, 0.002)
    assert set(PERTURBATIONS.names()) >= {"lighting", "speed", "joint_noise", "camera_pose", "object_pose"}


@pytest.mark.parametrize(
    ("atom", "field", "value", "needle"),
    [
        ("speed", "factor", 0.0, "factor"),
        ("speed", "factor", -1.0, "factor"),
        ("cam", "radius", -0.1, "radius"),
        ("cam", "wrist_radius", -1e-3, "wrist_radius"),
        ("light", "scale", 0.0, "scale"),
        ("noise", "sigma", -1, "sigma"),
        ("speed", "interpolation", "cubic", "interpolation"),
    ],
)
def test_impossible_parameters_are_refused(atom: str, field: str, value: object, needle: str) -> None:
    with pytest.raises(SpecError) as info:
        default_atoms(**{atom: {field: value}})
    assert needle in str(info.value)


def test_variant_grid_and_physics_flags() -> None:
    variants = make_variants(["paper", "original"], default_atoms())
    assert [v.name for v in variants] == [
        "light",
        "speed",
        "light+speed",
        "light+cam",
        "speed+cam",
        "light+speed+cam",
        "original",
    ]
    assert [v.physics for v in variants] == [False, True, True, False, True, True, False]
    with pytest.raises(SpecError, match="unknown perturbation 'spede'"):
        make_variants(["spede"], default_atoms())


def test_specs_dispatch_on_type_and_scale_down() -> None:
    v = VariantSpec.model_validate(
        {"name": "x", "perturbations": [{"type": "speed", "factor": 2.0}, {"type": "lighting"}]}
    )
    assert isinstance(v.perturbations[0], SpeedSpec) and isinstance(v.perturbations[1], LightingSpec)
    half = v.scaled(0.5)
    assert half.perturbations[0].factor == 1.5 and half.perturbations[1].scale == pytest.approx(0.9)
    assert CameraPoseSpec().scaled(0.5).radius == 0.1
    with pytest.raises(ValueError):
        AugmentSpec(variants=[VariantSpec(name="a"), VariantSpec(name="a")])


def test_yield_report_counts_attempts_kept_and_reasons() -> None:
    outcome = lambda v, m, kept, reason="": {"variant": v, "magnitude": m, "kept": kept, "reason": reason}
    demos = {
        "a": {
            "status": "ok",
            "outcomes": [outcome("light", "s_I=0.8", True), outcome("light+speed", "s_I=0.8;s_v=3", False, "dropped")],
        },
        "b": {
            "status": "ok",
            "outcomes": [outcome("light", "s_I=0.8", True), outcome("light+speed", "s_I=0.8;s_v=3", True)],
        },
        "c": {"status": "replay_failed", "outcomes": []},
    }
    report = yield_report(demos)
    assert (report["attempts"], report["kept"], report["demos_skipped"]) == (4, 3, {"replay_failed": 1})
    rows = {r["variant"]: r for r in report["variants"]}
    assert rows["light+speed"]["failures"] == {"dropped": 1} and rows["light+speed"]["yield"] == 0.5
    axes = {(r["axis"], r["magnitude"]): r for r in report["axes"]}
    assert axes[("light", "s_I=0.8")]["attempts"] == 4 and axes[("speed", "s_v=3")]["kept"] == 1


def test_yield_report_says_at_which_stage_rejected_variants_of_a_protocol_failed() -> None:
    outcome = lambda kept, stage, reason="": {
        "variant": "object",
        "magnitude": "xy=0.02",
        "kept": kept,
        "reason": reason,
        "stage": stage,
    }
    demos = {
        "a": {"status": "ok", "outcomes": [outcome(False, 0, "rotor_loaded.tube_unmet"), outcome(True, 4)]},
        "b": {"status": "ok", "outcomes": [outcome(False, 2, "run_time_s_unmet"), outcome(False, 0, "undecided")]},
        "old": {
            "status": "ok",
            "outcomes": [{"variant": "object", "magnitude": "xy=0.02", "kept": False, "reason": "dropped"}],
        },
    }
    row = yield_report(demos)["variants"][0]
    assert (row["attempts"], row["kept"]) == (5, 1)
    assert row["failed_at_stage"] == {"1": 2, "3": 1}  # stage numbers from 1; a ledger without stages counts none

"""Stages that open or close an instrument: a hinge or slide by hand, a latched lid by its release,
a motorised lid or drawer by its button, a lift-off lid by its handle (table in :mod:`.stages`);
and an instrument's run: its start button, as the protocols do (``protocols/SpinMicrotube-v1``)."""

from __future__ import annotations

from pipette_cli.specs import evaluators as ev
from pipette_cli.specs import expert as sk
from pipette_cli.specs.base import BoundSpec
from pipette_cli.specs.mechanisms import ClosureSpec, InstrumentSpec, RunSpec, ScaleSpec
from pipette_cli.taskgen.measure import AssetGeometry, JointInfo, measure_asset, r
from pipette_cli.taskgen.motors import SHUT_TOLERANCE, motor_button, motorised, shut_bound
from pipette_cli.taskgen.plan import PlanError, PlanStepSpec
from pipette_cli.taskgen.scene import HANDLES, PART_JOINTS, hatch_joint
from pipette_cli.taskgen.stage_base import Stage, StageBase
from pipette_cli.taskgen.validate import lid_depth, lid_travel, separate_lid

RUN_SECONDS = 10.0
"""Length of a drafted instrument's run (its start button's)."""
RAN_S = 2.0
"""Seconds a run must have gone on for its stage to count (protocols/SpinMicrotube-v1)."""


class HatchStages(StageBase):
    """The open and close stages of :class:`~pipette_cli.taskgen.stages.StageBuilder`."""

    def _open(self, step: PlanStepSpec) -> Stage:
        return self._hatch(step, opening=True)

    def _close(self, step: PlanStepSpec) -> Stage:
        return self._hatch(step, opening=False)

    def _hatch(self, step: PlanStepSpec, opening: bool) -> Stage:
        name = step.object
        geom = measure_asset(self.placed[name].asset)
        if not geom.joints and separate_lid(geom):
            return self._lift_off_lid(step, geom, opening)
        joint = hatch_joint(geom, step.part, self.human(name))
        limit = joint.open_limit
        sign = 1.0 if limit > 0 else -1.0
        ref = f"{name}/{joint.name}"
        hold = self.hold(0.5)
        if opening:
            goal = r(0.75 * limit)
            bound = BoundSpec(min=goal) if sign > 0 else BoundSpec(max=goal)
            note = f"VERIFY: open past 75 % of the {limit:g} {joint.unit} limit"
        else:
            bound = shut_bound(joint)
            note = f"VERIFY: within {SHUT_TOLERANCE[joint.kind]:g} {joint.unit} of shut (0)"
        release = self.scene.release(name, geom, joint)
        criterion = ev.JointThresholdSpec(
            joint=ref,
            bound=bound,
            unit="m" if joint.kind == "slide" else "deg",
            hold_s=hold,
            timeout_s=self.timeout(20 if opening and joint.kind != "slide" and release is None else 10),  # by hand
        )
        handle = next((f"{name}/{h}" for h in HANDLES if h in geom.sites and h.split("_")[0] in joint.name), None)
        if release is not None and opening:  # a latched lid (a centrifuge's): its release pops it open
            goal = r(0.75 * release)  # it creeps back a few degrees on its friction once let go
            criterion = criterion.model_copy(update={"bound": BoundSpec(min=goal) if sign > 0 else BoundSpec(max=goal)})
            comments = {
                "bound": f"VERIFY: open past 75 % of the {release:g} deg its release opens it to",
                "": "the lid is latched: its release button opens it",
            }
            return _by_button(step, criterion, motorised(name, joint, "button", release), "button", comments, hold)
        button = motor_button(geom, joint)
        if button is not None:  # a motorised lid or drawer (a thermal cycler's, a plate reader's): its button
            comments = {
                "bound": note,
                "": f"the {joint.name.split('_')[0]} is motorised: its {button} drives it (a toggle)",
            }
            return _by_button(step, criterion, motorised(name, joint, button), button, comments, hold)
        if joint.kind == "slide":
            skill: sk.StepSpec = sk.SlideSpec(
                joint=ref, to="open" if opening else "closed", handle=handle, hold_s=hold + 0.3
            )
        elif opening:
            skill = sk.OpenHingeSpec(
                joint=ref, to_deg=r(0.75 * limit + 3.0 * sign, 1), handle=handle, hold_s=hold + 0.3
            )
        else:
            skill = sk.CloseHingeSpec(joint=ref, hold_s=hold + 0.3)
        return Stage(step, criterion, [skill], {"bound": note}, [name])

    def _press_open(self, step: PlanStepSpec, geom: AssetGeometry, joint: JointInfo) -> Stage | None:
        """A release button pressed before its lid is closed or its instrument run: the instrument's
        state machine pops the lid open (to where its friction holds it: the asset's release angle,
        else near its limit, as ``protocols/SpinMicrotube-v1`` does), and a later stage may close it.
        None when the lid holds open nowhere (a ``button_release`` press, never closed again)."""
        name = step.object
        angle = self.scene.release(name, geom, joint)
        if angle is None:
            return None
        goal = r(0.75 * angle)
        criterion = ev.JointThresholdSpec(
            joint=f"{name}/{joint.name}",
            bound=BoundSpec(min=goal) if angle > 0 else BoundSpec(max=goal),
            hold_s=self.hold(0.3),
            timeout_s=self.timeout(10),
        )
        comments = {"bound": f"VERIFY: open past 75 % of the {angle:g} deg its release opens it to"}
        return _by_button(step, criterion, motorised(name, joint, "button", angle), "button", comments, self.hold(0.3))

    def _run(self, step: PlanStepSpec) -> Stage:
        """Press the start button of a closed instrument; it must run ``RAN_S`` with its lid, door
        or drawer shut (an open one refuses the run, and opening it aborts one)."""
        name = step.object
        geom = measure_asset(self.placed[name].asset)
        if "start_button" not in geom.sites:
            raise PlanError(f"the {self.human(name)} has no start button: running it is not simulated")
        joint = next((geom.joints[j] for js in PART_JOINTS.values() for j in js if j in geom.joints), None)
        values = {"run_time_s": BoundSpec(min=RAN_S)}
        closure = None
        if joint is not None:
            closure = ClosureSpec(joint=f"{name}/{joint.name}", closed=shut_bound(joint))
            values["closed"] = BoundSpec(min=1.0)
        instrument = InstrumentSpec(
            name=name, closure=closure, run=RunSpec(button=f"{name}/start_button", seconds=RUN_SECONDS)
        )
        criterion = ev.InstrumentStateSpec(mechanism=name, values=values, timeout_s=self.timeout(10))
        comments = {
            "values": f"ran at least {RAN_S:g} s with its {joint.name.split('_')[0] if joint else 'parts'} shut"
        }
        program: list[sk.StepSpec] = [sk.PressSpec(button=f"{name}/start_button"), sk.WaitSpec(seconds=RAN_S + 1.0)]
        return Stage(step, criterion, program, comments, [name], instruments=[instrument])

    def _tare(self, step: PlanStepSpec) -> Stage:
        """Press the tare button of a balance: its reading is zero after (an empty pan, or a container on it)."""
        name = step.object
        geom = measure_asset(self.placed[name].asset)
        if "tare_button" not in geom.sites:
            raise PlanError(f"the {self.human(name)} has no tare button")
        instrument = InstrumentSpec(name=name, scale=ScaleSpec(pan=f"{name}/pan", tare_button=f"{name}/tare_button"))
        values = {"tared": BoundSpec(min=1.0), "mass_g": BoundSpec(min=-0.5, max=0.5)}
        criterion = ev.InstrumentStateSpec(mechanism=name, values=values, timeout_s=self.timeout(10))
        comments = {"values": "tared at least once, reading within 0.5 g of zero"}
        program: list[sk.StepSpec] = [sk.PressSpec(button=f"{name}/tare_button"), sk.WaitSpec(seconds=1.0)]
        return Stage(step, criterion, program, comments, [name], instruments=[instrument])

    def _lift_off_lid(self, step: PlanStepSpec, geom: AssetGeometry, opening: bool) -> Stage:
        name = step.object
        lid = self.scene.out.lids.get(name)
        if lid is None:
            raise PlanError(f"the {self.human(name)}'s lid must be opened or closed once per task")
        lid_geom = self.geom(lid)
        handle = f"{lid}/lid_handle" if "lid_handle" in lid_geom.sites else None
        seat = geom.sites["lid_seat"]
        if opening:
            depth = lid_depth(lid_geom)
            criterion: ev.EvaluatorSpec = ev.DisplacementSpec(
                object=lid,
                delta=ev.AxisDeltaSpec(x=BoundSpec(max=-depth), z=BoundSpec(min=0.10)),
                hold_s=self.hold(0.3),
                timeout_s=self.timeout(15),
            )
            comments = {
                "delta": f"lifted 10 cm (paper A.8) and drawn toward the robot by its own depth ({depth * 1000:.0f} mm)"
            }
            program: list[sk.StepSpec] = [
                sk.PickSpec(object=lid, at=handle, lift=0.14),
                sk.MoveSpec(by=(-lid_travel(lid_geom), 0.0, 0.0), hold_s=1.0),
            ]
        else:
            z = self.placed[name].pos[2] + seat[2]
            criterion = ev.RegionHoldSpec(
                object=lid,
                within=ev.CircleSpec(center=f"{name}/lid_seat", radius=0.015),
                z=BoundSpec(min=r(z - 0.015), max=r(z + 0.015)),
                max_tilt_deg=5.0,
                hold_s=self.hold(0.5),
                timeout_s=self.timeout(20),
                released=True,
            )
            comments = {"z": "VERIFY: seated on the rim (lid_seat site height)"}
            program = [sk.PickSpec(object=lid, at=handle), sk.PlaceOnSpec(object=lid, target=f"{name}/lid_seat")]
        return Stage(step, criterion, program, comments, [lid, name])


def _by_button(
    step: PlanStepSpec,
    criterion: ev.EvaluatorSpec,
    motor: InstrumentSpec,
    button: str,
    comments: dict[str, str],
    hold: float,
) -> Stage:
    """Press the instrument's ``button`` and wait for its motor to move the part (and the hold)."""
    ramp = motor.motor.ramp_s if motor.motor is not None else 1.5
    program: list[sk.StepSpec] = [
        sk.PressSpec(button=f"{step.object}/{button}"),
        sk.WaitSpec(seconds=r(ramp + hold + 0.5, 1)),
    ]
    return Stage(step, criterion, program, comments, [step.object], instruments=[motor])


__all__ = ["HatchStages"]

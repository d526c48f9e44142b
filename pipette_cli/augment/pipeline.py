"""One demo through every variant: check the original, simulate, judge, render the kept ones, write.

:class:`DemoAugmenter` owns one :class:`~pipette_cli.sim.world.World` (and, once something must
be rendered, one :class:`~pipette_cli.sim.render.CameraRig`); an executor gives each worker
one. For each demo:

1. the original is replayed without rendering; a demo that does not reproduce its recorded
   states bit for bit, or does not succeed, is reported and skipped;
2. each variant is planned (:func:`~.perturb.plan_variant`); physics variants (speed, joint
   noise, object pose) are simulated without rendering and judged by the task's evaluator;
   light/camera-only variants reuse the original's verified physics as is;
3. only passing variants are rendered, from their recorded states, and written with the
   recorder's schema; failures are counted with their reasons (and optionally written too).
"""

from __future__ import annotations

import json
import logging
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pipette_cli.augment.batch import can_batch, screen
from pipette_cli.augment.clutter import Clutter, clutter_of, transfer_state
from pipette_cli.augment.objectcentric import adapt_actions, hands_over
from pipette_cli.augment.perturb import VariantPlan, placed_object, plan_variant
from pipette_cli.augment.render import fresh_steps, render_rollout, view_key
from pipette_cli.augment.simulate import Placement, Rollout, placement, replay_check, restore, settle_steps, simulate
from pipette_cli.augment.specs import AugmentSpec
from pipette_cli.demos.experts.base import expert_program
from pipette_cli.demos.provenance import replay_reason
from pipette_cli.demos.recorder import DatasetInfo, EpisodeWriter, compress_frame
from pipette_cli.demos.store import EpisodeRef, read_episode
from pipette_cli.errors import PipetteError
from pipette_cli.evaluators.base import Verdict
from pipette_cli.sim.distractors import ATTR as DISTRACTORS_ATTR
from pipette_cli.sim.distractors import with_distractors
from pipette_cli.sim.env import Observation
from pipette_cli.sim.render import CameraRig, Profile, find_profile
from pipette_cli.sim.world import World
from pipette_cli.specs.expert import StepSpec
from pipette_cli.specs.perturbations import DistractorSpec
from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)

REPLAY_FAILED = "replay_failed"
NOT_SUCCESSFUL = "source_failed"


@dataclass(frozen=True)
class DemoJob:
    """One source demo to augment."""

    position: int
    ref: EpisodeRef
    kept_dir: Path | None
    """Where kept variants are written; None writes nothing (calibration)."""
    rejected_dir: Path | None = None


@dataclass
class VariantOutcome:
    variant: str
    magnitude: str
    kept: bool
    reason: str
    steps: int
    simulated: bool
    params: dict[str, Any] = field(default_factory=dict)
    stage: int | None = None
    """On a protocol task (a ``sequence`` criterion): the stages the variant completed, so a rejected
    variant failed at stage ``stage + 1``. None for one-step tasks."""


@dataclass
class DemoResult:
    """What a worker did with one demo; ``kept``/``rejected`` are closed, uncommitted part files."""

    position: int
    uid: str
    seed: int
    status: str
    """``ok``, ``replay_failed`` or ``source_failed``."""
    detail: str = ""
    outcomes: list[VariantOutcome] = field(default_factory=list)
    kept: list[Path] = field(default_factory=list)
    rejected: list[Path] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=lambda: {"physics": 0.0, "render": 0.0, "write": 0.0})


def write_rollout(
    path: Path,
    info: DatasetInfo,
    rollout: Rollout,
    frames: list[dict[str, np.ndarray]],
    *,
    index: int,
    seed: int,
    vision_every: int,
    attrs: dict[str, Any],
    chunks: dict[int, dict[str, bytes]] | None = None,
) -> Path:
    """Write a rendered rollout with :class:`EpisodeWriter`; returns the closed ``.tmp`` file.
    ``chunks[t]``: row ``t``'s frames already compressed (:func:`compress_frame`)."""
    fresh = fresh_steps(rollout.num_steps, vision_every)
    last = 0
    writer = EpisodeWriter(path, info, index=index, seed=seed, source="augmented", attrs=attrs)
    with writer:
        for t in range(rollout.num_steps):
            last = t if fresh[t] else last
            obs = Observation(
                images=frames[t] if frames else {},
                state=rollout.obs_state[t],
                fresh=bool(fresh[t]),
                frame_age=t - last,
                sim_time=float(rollout.sim_time[t]),
                wall_time=float(rollout.wall_time[t]),
                step=t + 1,
                instruction=rollout.instruction[t],
                stage=int(rollout.stage[t]),
                instrument=rollout.instrument[t],
            )
            executed = None if rollout.executed is None else rollout.executed[t]
            writer.add(obs, rollout.actions[t], rollout.states[t], (chunks or {}).get(t), executed)
        writer.close(rollout.verdict, rollout.final_state, rollout.final_sim_state)
    return writer.tmp


def _stage(verdict: Verdict) -> int | None:
    """Stages completed by the end of an episode of a ``sequence`` criterion (its ``stage`` metric)."""
    stage = verdict.metrics.get("stage")
    return None if stage is None else int(stage)


def _program(task: TaskSpec) -> list[StepSpec]:
    """The task's skill program, whose steps say which object's frame each part of a demo is in
    (``[]`` for a task without one: a teleoperation-only task stays one object-centric segment)."""
    try:
        return expert_program(task)[0]
    except PipetteError as exc:
        log.debug("%s: no skill program; object variants stay one segment: %s", task.id, exc)
        return []


def _compress_views(views: dict[str, np.ndarray]) -> dict[str, bytes]:
    return {camera: compress_frame(frame) for camera, frame in views.items()}


class DemoAugmenter:
    """Augments demos of one task with one spec (one per worker process)."""

    def __init__(
        self,
        task: TaskSpec,
        spec: AugmentSpec,
        info: DatasetInfo,
        *,
        render: bool = True,
        attrs: dict[str, Any] | None = None,
        profile: Profile = "fast",
    ) -> None:
        self.task, self.spec, self.info = task, spec, info
        self.program = _program(task)
        self.profile = profile
        self.world = World(task, meshes=find_profile(profile).meshes if render else "full")
        self.render = render
        self.rig: CameraRig | None = None
        self.compressor = ThreadPoolExecutor(1, thread_name_prefix="compress")  # zlib runs without the GIL
        self.attrs = dict(attrs or {})
        self.settle = settle_steps(self.world, spec.settle_s)

    def _rig(self) -> CameraRig:
        if self.rig is None:
            self.rig = CameraRig(self.world.model, self.info.image_width, self.info.image_height, self.profile)
        return self.rig

    def close(self) -> None:
        self.compressor.shutdown()
        if self.rig is not None:
            self.rig.close()
            self.rig = None

    def run(self, job: DemoJob) -> DemoResult:
        record = read_episode(job.ref)
        s = record.summary
        result = DemoResult(job.position, s.uid, s.seed, "ok")
        original = Rollout.from_record(record)
        t0 = time.perf_counter()
        if not s.success:
            result.status, result.detail = NOT_SUCCESSFUL, f"the demo failed when recorded ({s.reason})"
            return result
        why = replay_check(self.world, s.seed, original)
        result.seconds["physics"] += time.perf_counter() - t0
        if why is not None:
            result.status, result.detail = REPLAY_FAILED, replay_reason(why, record.attrs)
            return result
        target = self.task.targets[0] if self.task.targets else None
        t0 = time.perf_counter()
        plans = []
        starts: dict[str, Placement] = {}
        rooms: dict[float, Clutter] = {}
        for variant in self.spec.variants:
            name = placed_object(variant, target)
            if name is not None and name not in starts:
                restore(self.world, s.seed, original.states[0])
                starts[name] = placement(self.world, name)
            extra = variant.get(DistractorSpec)
            if isinstance(extra, DistractorSpec) and extra.path_height not in rooms:
                rooms[extra.path_height] = clutter_of(self.world, original.states, extra.path_height)
            plan = plan_variant(
                variant,
                original.actions,
                seed=self.spec.seed,
                demo_seed=s.seed,
                default_object=target,
                placement=starts.get(name) if name is not None else None,
                clutter=rooms.get(extra.path_height) if isinstance(extra, DistractorSpec) else None,
            )
            plans.append(plan)
        screened = self._screen(s.seed, original.states[0], plans)
        seen: dict[tuple[str, Any], list[np.ndarray]] = {}  # frames of the original physics, by camera and view
        result.seconds["physics"] += time.perf_counter() - t0
        for v, plan in enumerate(plans):
            t0 = time.perf_counter()
            early = screened.get(v)
            if early is not None and not early.success and job.rejected_dir is None:
                # rejected by the batch rollout and nobody keeps rejects: no step-by-step re-run
                result.seconds["physics"] += time.perf_counter() - t0
                result.outcomes.append(
                    VariantOutcome(
                        plan.variant,
                        plan.magnitude,
                        False,
                        early.reason or "undecided",
                        0,
                        True,
                        plan.params,
                        _stage(early),
                    )
                )
                continue
            world, state0 = self._scene(plan, s.seed, original.states[0])
            if plan.offset is not None and plan.actions is not None:
                hand_off = hands_over(self.program, plan.offset.name)
                plan.actions = adapt_actions(
                    world, s.seed, state0, plan.actions, plan.offset, plan.object_ramp, hand_off=hand_off
                )
            if plan.physics:
                executed = plan.executed()
                assert plan.actions is not None and executed is not None
                rollout = simulate(world, s.seed, state0, executed, settle_steps=self.settle, offset=plan.offset)
                if plan.noise is not None:  # corrective: record the demonstrated targets, keep what ran
                    rollout = rollout.relabelled(plan.actions)
            else:
                rollout = original  # lights and cameras do not change the physics: verified above
            result.seconds["physics"] += time.perf_counter() - t0
            kept = bool(rollout.verdict.success)
            reason = "" if kept else (rollout.verdict.reason or "undecided")
            result.outcomes.append(
                VariantOutcome(
                    plan.variant,
                    plan.magnitude,
                    kept,
                    reason,
                    rollout.num_steps,
                    plan.physics,
                    plan.params,
                    _stage(rollout.verdict),
                )
            )
            folder = job.kept_dir if kept else job.rejected_dir
            if folder is None:
                continue
            path = folder / f"aug_{s.uid}_{v:03d}.h5"
            tmp = self._write(
                path, rollout, plan, s.seed, job, record.attrs, result, None if plan.physics else seen, world
            )
            (result.kept if kept else result.rejected).append(tmp)
        return result

    def _scene(self, plan: VariantPlan, seed: int, state0: np.ndarray) -> tuple[World, np.ndarray]:
        """The world a variant runs in and its start state: the task's own, or the task with the
        plan's distractors (built for it; the recorded start carried over by name)."""
        if not plan.distractors:
            return self.world, state0
        world = World(with_distractors(self.task, plan.distractors), meshes=self.world.meshes)
        return world, transfer_state(self.world, state0, world, seed)

    def _screen(self, seed: int, state0: np.ndarray, plans: list[VariantPlan]) -> dict[int, Verdict]:
        """Verdicts from one multithreaded ``mujoco.rollout`` for the physics variants without an
        object offset, when the task has no scripted mechanism (:mod:`.batch`)."""
        if not self.spec.batch or not can_batch(self.world):
            return {}
        chosen = [
            (v, actions)
            for v, p in enumerate(plans)
            if p.offset is None and not p.distractors and (actions := p.executed()) is not None
        ]
        if len(chosen) < 2:
            return {}
        index = [v for v, _ in chosen]
        verdicts = screen(self.world, seed, state0, [actions for _, actions in chosen], settle_steps=self.settle)
        return dict(zip(index, verdicts, strict=True))

    def _write(
        self,
        path: Path,
        rollout: Rollout,
        plan: VariantPlan,
        seed: int,
        job: DemoJob,
        source: dict[str, object],
        result: DemoResult,
        seen: dict[tuple[str, Any], list[np.ndarray]] | None,
        world: World | None = None,
    ) -> Path:
        """Render (reusing in ``seen`` the views of the same physics, lights and camera pose), write.
        ``world``: the scene the rollout ran in (default: the task's own)."""
        t0 = time.perf_counter()
        pending: dict[int, Future[dict[str, bytes]]] = {}
        frames: list[dict[str, np.ndarray]] = []
        world = world or self.world
        own_rig = world is not self.world and self.render
        if self.render:
            rig = (
                self._rig()
                if not own_rig
                else CameraRig(world.model, self.info.image_width, self.info.image_height, self.profile)
            )
            keys = {camera: (camera, view_key(plan, camera)) for camera in rig.ids}
            known = {camera: seen[key] for camera, key in keys.items() if seen is not None and key in seen}
            try:
                frames = render_rollout(
                    world,
                    rig,
                    seed,
                    rollout,
                    plan,
                    vision_every=self.task.timing.vision_every,
                    known=known,
                    on_capture=lambda t, views: pending.__setitem__(t, self.compressor.submit(_compress_views, views)),
                )
            finally:
                if own_rig:  # a cluttered scene's own renderer (its GL context) goes even when rendering fails
                    rig.close()
            if seen is not None:
                fresh = fresh_steps(rollout.num_steps, self.task.timing.vision_every)
                for camera, key in keys.items():
                    seen.setdefault(key, [frames[t][camera] for t in np.flatnonzero(fresh)])
        t1 = time.perf_counter()
        attrs = {
            **self.attrs,
            "augment_variant": plan.variant,
            "augment_magnitude": plan.magnitude,
            "augment_params": json.dumps(plan.params, sort_keys=True),
            "augment_seed": self.spec.seed,
            "augment_simulated": plan.physics,
            "augment_actions": "executed" if rollout.executed is None else "corrective",
            "augment_source_file": str(job.ref.file),
            "augment_source_index": job.ref.index,
            "augment_source_uid": str(source.get("uid", "")),
            "augment_source_expert": str(source.get("expert", "")),
            "augment_source_kind": str(source.get("source", "")),
            "augment_object_offset": json.dumps(plan.offset.as_dict() if plan.offset else {}),
            DISTRACTORS_ATTR: json.dumps([d.as_dict() for d in plan.distractors]),
        }
        if "expert" in source:
            attrs["expert"] = str(source["expert"])
        tmp = write_rollout(
            path,
            self.info,
            rollout,
            frames,
            index=job.position,
            seed=seed,
            vision_every=self.task.timing.vision_every,
            attrs=attrs,
            chunks={t: f.result() for t, f in pending.items()},
        )
        result.seconds["render"] += t1 - t0
        result.seconds["write"] += time.perf_counter() - t1
        return tmp

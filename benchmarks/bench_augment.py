"""Kept verified episodes per hour at 3 x 400 x 400: ours, the paper-faithful baseline, a reference
tree, the physical floor, and scaling over local workers and Ray.

On the same demos, variants and seeds (one process, measurements interleaved per repeat so
that ratios hold on a shared machine):

- ``baseline`` (paper A.7 as written): every variant is replayed with rendering on (three views
  at the 10 Hz vision schedule while simulating), then judged; passing ones are written.
- ``ours`` (``pipette augment``, one worker): verify the original once, simulate only variants
  that change the physics, without rendering; render only kept variants from their recorded
  states, compressing each frame while the next renders.
- ``reference`` (``--reference TREE``): ``pipette augment`` of another source tree (e.g. an
  export of main before this work) in a subprocess, one worker, its own defaults.
- ``floor``: what any verified pipeline must spend: physics of every variant (the original's
  replay check plus each physics variant simulated once) plus rendering the kept variants' fresh
  frames (the ``render_all`` calls alone, no writing). ``ours / floor`` is our overhead.
- scaling (``--workers 1,2``, ``--ray``): ``ours`` with N local worker processes and with the
  Ray executor (N actors on a local Ray cluster started before timing, or ``--ray-address``).
  Efficiency = rate with N / (N x rate with 1).

The JSON records the git commit, the machine, and the load average before each measurement.

    python benchmarks/bench_augment.py --demos 4 --reference /tmp/main_tree --ray --out bench_augment.json
    python benchmarks/bench_augment.py --input raw.h5 --image-size 128 --variants paper --repeats 1
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")
ROOT = Path(__file__).resolve().parents[1]
if "MENAGERIE_ROOT" not in os.environ and (ROOT.parent / "shared" / "menagerie").is_dir():
    os.environ["MENAGERIE_ROOT"] = str(ROOT.parent / "shared" / "menagerie")

import numpy as np  # noqa: E402

from pipette_cli.augment.perturb import plan_variant  # noqa: E402
from pipette_cli.augment.pipeline import DemoAugmenter, write_rollout  # noqa: E402
from pipette_cli.augment.render import render_rollout, visual_perturbation  # noqa: E402
from pipette_cli.augment.run import augment  # noqa: E402
from pipette_cli.augment.simulate import Rollout, replay_check, settle_steps, simulate  # noqa: E402
from pipette_cli.augment.specs import AugmentSpec, default_atoms, make_variants  # noqa: E402
from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.demos.recorder import DatasetInfo, sim_state  # noqa: E402
from pipette_cli.demos.store import part_path, read_episode, scan  # noqa: E402
from pipette_cli.evaluators.base import Verdict  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402
from pipette_cli.sim.env import PipetteEnv  # noqa: E402

REFERENCE_SCRIPT = """
import json, sys, tempfile, time
from pathlib import Path
from pipette_cli.augment.run import augment
from pipette_cli.augment.specs import AugmentSpec, default_atoms, make_variants
from pipette_cli.registry import load_registry
task_id, raw, variants, size = sys.argv[1], Path(sys.argv[2]), sys.argv[3].split(","), int(sys.argv[4])
spec = AugmentSpec(variants=make_variants(variants, default_atoms()), image_size=size)
out = Path(tempfile.mkdtemp(prefix="bench_reference_")) / "out.h5"
started = time.perf_counter()
result = augment(load_registry([]).get(task_id), raw, out, spec, workers=1)
import pipette_cli
print(json.dumps({"kept": result.report["kept"], "attempts": result.report["attempts"],
                  "seconds": time.perf_counter() - started, "package": pipette_cli.__file__}))
"""


def rate(kept: int, seconds: float) -> float:
    return kept / seconds * 3600 if seconds > 0 else 0.0


def machine() -> dict[str, Any]:
    model = (
        next(
            (
                line.split(":", 1)[1].strip()
                for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")
            ),
            platform.processor(),
        )
        if Path("/proc/cpuinfo").exists()
        else ""
    )
    return {
        "cpu": model,
        "cpus": len(os.sched_getaffinity(0)),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "mujoco_gl": os.environ.get("MUJOCO_GL", ""),
    }


def baseline(task, raw: Path, out: Path, spec: AugmentSpec) -> dict[str, Any]:
    info: DatasetInfo = scan(raw).info  # type: ignore[assignment]
    started = time.perf_counter()
    env = PipetteEnv(task, image_size=spec.image_size or info.image_height)
    world = env.world
    settle = settle_steps(world, spec.settle_s)
    kept = attempts = 0
    for ref in scan(raw).episodes:
        original = Rollout.from_record(read_episode(ref))
        for variant in spec.variants:
            plan = plan_variant(
                variant, original.actions, seed=spec.seed, demo_seed=ref.summary.seed, default_object=task.targets[0]
            )
            actions = plan.actions if plan.actions is not None else original.actions
            attempts += 1
            with visual_perturbation(world.model, plan, env.rig.ids):  # type: ignore[union-attr]
                obs = env.reset(ref.summary.seed)
                rows, verdict = [], Verdict()
                for k in range(len(actions) + settle):
                    action = np.asarray(actions[min(k, len(actions) - 1)])
                    rows.append((action, sim_state(world.model, world.data), obs))
                    obs, verdict = env.step(action)
                    if verdict.done:
                        break
            if not verdict.success:
                continue
            rollout = Rollout(
                actions=np.stack([r[0] for r in rows]),
                states=np.stack([r[1] for r in rows]),
                obs_state=np.stack([r[2].state for r in rows]),
                sim_time=np.array([r[2].sim_time for r in rows]),
                wall_time=np.array([r[2].wall_time for r in rows]),
                final_state=world.state(),
                final_sim_state=sim_state(world.model, world.data),
                verdict=verdict,
                instruction=[r[2].instruction for r in rows],
                stage=np.array([r[2].stage for r in rows], dtype=np.int32),
                instrument=np.stack([r[2].instrument for r in rows]),
            )
            out_info = dataclasses.replace(info, image_height=env.rig.height, image_width=env.rig.width)  # type: ignore[union-attr]
            tmp = write_rollout(
                part_path(out, kept),
                out_info,
                rollout,
                [r[2].images for r in rows],
                index=kept,
                seed=ref.summary.seed,
                vision_every=task.timing.vision_every,
                attrs={"augment_variant": plan.variant},
            )
            tmp.replace(part_path(out, kept))
            kept += 1
    env.close()
    seconds = time.perf_counter() - started
    return {"attempts": attempts, "kept": kept, "seconds": seconds, "kept_per_hour": rate(kept, seconds)}


def ours(
    task,
    raw: Path,
    out: Path,
    spec: AugmentSpec,
    *,
    workers: int = 1,
    executor: str = "local",
    address: str | None = None,
) -> dict[str, Any]:
    started = time.perf_counter()
    result = augment(task, raw, out, spec, workers=workers, executor=executor, address=address)  # type: ignore[arg-type]
    seconds = time.perf_counter() - started
    return {
        "attempts": result.report["attempts"],
        "kept": result.report["kept"],
        "seconds": seconds,
        "kept_per_hour": rate(result.report["kept"], seconds),
        "timings": result.timings,
    }


def reference(tree: Path, task, raw: Path, variants: str, size: int) -> dict[str, Any]:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    done = subprocess.run(
        [sys.executable, "-c", REFERENCE_SCRIPT, task.id, str(raw), variants, str(size)],
        capture_output=True,
        text=True,
        env=env,
        check=False,
        cwd=tree,
    )  # `-c` imports from cwd first
    if done.returncode != 0:
        raise SystemExit(f"reference run in {tree} failed:\n{done.stderr[-2000:]}")
    row = json.loads(done.stdout.strip().splitlines()[-1])
    return {**row, "kept_per_hour": rate(row["kept"], row["seconds"]), "tree": str(tree)}


def floor(task, raw: Path, spec: AugmentSpec) -> dict[str, Any]:
    """Physics of every variant + rendering of the kept ones' fresh frames (see the module doc)."""
    info: DatasetInfo = scan(raw).info  # type: ignore[assignment]
    size = spec.image_size or info.image_height
    sized = dataclasses.replace(info, image_height=size, image_width=size)
    worker = DemoAugmenter(task, spec, sized)
    world, rig = worker.world, worker._rig()
    rig.render_all(world.data)  # the GL context is made and warm, as in a running worker
    physics = render = 0.0
    kept = 0
    render_view = rig.render

    def timed_render(data, camera):
        nonlocal render
        t0 = time.perf_counter()
        image = render_view(data, camera)
        render += time.perf_counter() - t0
        return image

    rig.render = timed_render  # type: ignore[method-assign]
    for ref in scan(raw).episodes:
        seed = ref.summary.seed
        original = Rollout.from_record(read_episode(ref))
        t0 = time.perf_counter()
        assert replay_check(world, seed, original) is None
        physics += time.perf_counter() - t0
        for variant in spec.variants:
            plan = plan_variant(
                variant, original.actions, seed=spec.seed, demo_seed=seed, default_object=task.targets[0]
            )
            rollout = original
            if plan.physics:
                t0 = time.perf_counter()
                rollout = simulate(
                    world, seed, original.states[0], plan.actions, settle_steps=worker.settle, offset=plan.offset
                )
                physics += time.perf_counter() - t0
            if rollout.verdict.success:
                kept += 1
                render_rollout(world, rig, seed, rollout, plan, vision_every=task.timing.vision_every)
    worker.close()
    return {"kept": kept, "physics_s": physics, "render_s": render, "seconds": physics + render}


def make_input(task, demos: int, folder: Path) -> Path:
    from pipette_cli.demos.collect import collect

    raw = folder / "raw.h5"
    result = collect(task, raw, episodes=demos, seed=0, image_size=64)
    if not all(e.success for e in result.added):
        raise SystemExit("a scripted demo failed; pass --input with successful demos")
    return raw


def measure(name: str, fn, *args, **kwargs) -> dict[str, Any]:
    load = os.getloadavg()
    row = fn(*args, **kwargs)
    row["loadavg_before"] = [round(x, 2) for x in load]
    print(f"  {name:<22} {row.get('kept', '')!s:>4} kept in {row['seconds']:7.1f} s  (load {load[0]:.2f})", flush=True)
    return row


def median_rate(rows: list[dict[str, Any]]) -> float:
    return statistics.median(r["kept_per_hour"] for r in rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--task", default="PickUpTestTube")
    parser.add_argument("--input", type=Path, help="Raw demos (default: --demos scripted demos at 64 px).")
    parser.add_argument("--demos", type=int, default=4)
    parser.add_argument("--variants", default="paper")
    parser.add_argument("--image-size", type=int, default=400, help="Square side of the rendered views.")
    parser.add_argument("--repeats", type=int, default=2, help="Interleaved rounds of baseline/ours/reference/floor.")
    parser.add_argument("--reference", type=Path, help="Another source tree whose `pipette augment` to time.")
    parser.add_argument("--workers", default="1,2", help="Local worker counts for the scaling rows.")
    parser.add_argument("--ray", action="store_true", help="Also time the Ray executor with the largest worker count.")
    parser.add_argument("--ray-address", help="An existing Ray cluster (default: start a local one).")
    parser.add_argument("--out", "--json", dest="out", type=Path, default=Path("bench_augment.json"))
    args = parser.parse_args()
    task = load_registry([]).get(args.task)
    spec = AugmentSpec(variants=make_variants(args.variants.split(","), default_atoms()), image_size=args.image_size)
    work = Path(tempfile.mkdtemp(prefix="bench_augment_"))
    runs: dict[str, list[dict[str, Any]]] = {"baseline": [], "ours": [], "reference": [], "floor": []}
    scaling: list[dict[str, Any]] = []
    try:
        raw = args.input or make_input(task, args.demos, work)
        demos = len(scan(raw).episodes)
        print(
            f"{task.id}: {demos} demos x {len(spec.variants)} variants, 3 x {args.image_size} px, {args.repeats} rounds"
        )
        for r in range(args.repeats):
            runs["baseline"].append(measure("baseline", baseline, task, raw, work / f"baseline{r}.h5", spec))
            runs["ours"].append(measure("ours", ours, task, raw, work / f"ours{r}.h5", spec))
            if args.reference:
                runs["reference"].append(
                    measure("reference", reference, args.reference, task, raw, args.variants, args.image_size)
                )
            runs["floor"].append(measure("floor", floor, task, raw, spec))
        counts = [int(n) for n in args.workers.split(",")]
        for n in counts:
            rows = (
                runs["ours"]
                if n == 1
                else [measure(f"ours, {n} workers", ours, task, raw, work / f"local{n}.h5", spec, workers=n)]
            )
            scaling.append({"executor": "local", "workers": n, "kept_per_hour": median_rate(rows), "runs": rows})
        if args.ray:
            import ray

            t0 = time.perf_counter()
            if args.ray_address:
                ray.init(address=args.ray_address, include_dashboard=False, log_to_driver=False)
            else:
                ray.init(
                    num_cpus=max(counts), include_dashboard=False, log_to_driver=False, _node_ip_address="127.0.0.1"
                )
            start_s = time.perf_counter() - t0
            n = max(counts)
            row = measure(
                f"ours, Ray x {n}",
                ours,
                task,
                raw,
                work / "ray.h5",
                spec,
                workers=n,
                executor="ray",
                address=args.ray_address,
            )
            scaling.append(
                {
                    "executor": "ray",
                    "workers": n,
                    "kept_per_hour": row["kept_per_hour"],
                    "runs": [row],
                    "cluster_start_s": start_s,
                    "address": args.ray_address or "local",
                }
            )
            ray.shutdown()
    finally:
        shutil.rmtree(work, ignore_errors=True)
    one = median_rate(runs["ours"])
    for row in scaling:
        row["efficiency"] = row["kept_per_hour"] / (row["workers"] * one) if one else 0.0
    summary = {
        "ours_kept_per_hour": one,
        "baseline_kept_per_hour": median_rate(runs["baseline"]),
        "ours_over_baseline": statistics.median(
            o["kept_per_hour"] / b["kept_per_hour"] for o, b in zip(runs["ours"], runs["baseline"])
        ),
        "ours_over_floor": statistics.median(o["seconds"] / f["seconds"] for o, f in zip(runs["ours"], runs["floor"])),
    }
    if runs["reference"]:
        summary["reference_kept_per_hour"] = median_rate(runs["reference"])
        summary["ours_over_reference"] = statistics.median(
            o["kept_per_hour"] / r["kept_per_hour"] for o, r in zip(runs["ours"], runs["reference"])
        )
    print(f"\n{'pipeline':<12}{'kept/hour':>11}   (median of {args.repeats} interleaved rounds)")
    for name in ("baseline", "ours", "reference"):
        if runs[name]:
            print(f"{name:<12}{median_rate(runs[name]):>11.0f}")
    print(
        f"ours / baseline: {summary['ours_over_baseline']:.2f}x; ours wall / floor: {summary['ours_over_floor']:.2f}x"
        + (f"; ours / reference: {summary['ours_over_reference']:.2f}x" if runs["reference"] else "")
    )
    print(f"\n{'executor':<10}{'workers':>8}{'kept/hour':>11}{'efficiency':>12}")
    for row in scaling:
        print(f"{row['executor']:<10}{row['workers']:>8}{row['kept_per_hour']:>11.0f}{row['efficiency']:>12.2f}")
    commit, dirty = git_state()
    args.out.write_text(
        json.dumps(
            {
                "git_sha": commit,
                "git_dirty": dirty,
                "machine": machine(),
                "task": task.id,
                "demos": demos,
                "variants": args.variants,
                "image_size": args.image_size,
                "repeats": args.repeats,
                "summary": summary,
                "runs": runs,
                "scaling": scaling,
                "loadavg_after": [round(x, 2) for x in os.getloadavg()],
            },
            indent=2,
            default=str,
        )
        + "\n"
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()

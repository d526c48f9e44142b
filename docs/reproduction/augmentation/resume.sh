#!/usr/bin/env bash
# Resume the augmentation experiment of docs/reproduction/plan.md on this machine, in the plan's order:
# the registered cells, amendment 8's training-seed replicates on the first two tasks, then (amendment 9) two
# lanes at once: amendment 6 (as many passes) on PickUpTestTube and CloseCentrifugeLid; amendment 5 (segmented
# retargeting, PlaceTubeOnBalance only) and amendment 6 on PlaceTubeOnBalance and RemoveTubeFromBalance; then
# amendment 8 on the last two tasks. Each stage resumes where its work stopped
# (finished cells are reused; the kept episode logs are restored on a new machine), so this script can
# be started again after any interruption. It stops before anything when the CPU lacks AVX-512 (plan,
# "Machines": such a restart is written into the plan first).
#
#   bash docs/reproduction/augmentation/resume.sh            # start (in the background: setsid ... &)
#   DRY=1 bash docs/reproduction/augmentation/resume.sh      # print what it would run
#
# The code is the run's: 8739549 with the driver patches of this folder, in worktrees under $WT
# (exp2: exp-run.patch; seg: exp-run.patch + exp-seg.patch); the Python environment is main's.
set -euo pipefail

MAIN=${MAIN:-$(git -C "$(dirname "$0")" rev-parse --show-toplevel)}
WT=${WT:-/work/wt}
RUN=${RUN:-/work/runs/augmentation}
MENAGERIE_ROOT=${MENAGERIE_ROOT:-$MAIN/../shared/menagerie}
RUN_CODE=8739549
HERE=$MAIN/docs/reproduction/augmentation

say() { if [ -n "${DRY:-}" ]; then echo "# $*"; else echo "[$(date -u +%H:%M:%S)] resume.sh: $*" | tee -a "$RUN/logs/run.log"; fi; }
do_() { if [ -n "${DRY:-}" ]; then echo "+ $*"; else "$@"; fi; }

if [ "$(grep -c avx512f /proc/cpuinfo || true)" = "0" ]; then
    echo "this CPU has no AVX-512: write the restart into plan.md (amendment 8, 'Machines') before going on" >&2
    exit 3
fi
do_ mkdir -p "$RUN/docs" "$RUN/logs"
[ -f "$RUN/docs/pilot.json" ] || do_ cp "$HERE/pilot.json" "$RUN/docs/"

worktree() {  # worktree NAME PATCH...: the run's code with these patches, made once
    local dir=$WT/$1
    shift
    if [ ! -d "$dir" ]; then
        do_ git -C "$MAIN" worktree add --detach "$dir" "$RUN_CODE"
        for patch in "$@"; do do_ git -C "$dir" am "$HERE/$patch"; done
    fi
}

stage() {  # stage WORKTREE [--settings ...]: one `run` of the driver from that worktree
    local dir=$WT/$1
    shift
    local cmd=(env PYTHONPATH="$dir" MUJOCO_GL=egl MENAGERIE_ROOT="$MENAGERIE_ROOT" PATH="$MAIN/.venv/bin:$PATH"
        nice -n 15 "$MAIN/.venv/bin/python" benchmarks/augmentation_experiment.py run --work "$RUN"
        --docs "$RUN/docs" --keep "$HERE/episodes" --workers 1 --jobs 2 "$@")
    if [ -n "${DRY:-}" ]; then
        echo "+ (cd $dir && ${cmd[*]})"
        return
    fi
    say "run from $dir $*"
    # a stage that fails (its log says why) does not stop the others; a restart runs it again
    (cd "$dir" && "${cmd[@]}" >> "$RUN/logs/run.log" 2>&1) || say "stage $* exited with $?; going on"
}

# exp2: the run's code with all three driver commits (the registered settings' commands are the
# first commit's; the other two only add opt-in settings). On the machine of stops 47-49, exp holds
# the first commit only and exp2 all three.
worktree exp2 exp-run.patch
stage exp2                                                                 # registered cells
A8=raw_seed1001,aug_all_seed1001,raw_seed1002,aug_all_seed1002
PICK=pipette/PickUpTestTube-v1 PLACE=pipette/PlaceTubeOnBalance-v1
REMOVE=pipette/RemoveTubeFromBalance-v1 CLOSE=pipette/CloseCentrifugeLid-v1
stage exp2 --settings $A8 --tasks $PICK,$PLACE                              # amendment 8, first two tasks
worktree seg exp-run.patch exp-seg.patch
# amendment 9's order: two lanes at once, each one cell at a time; then amendment 8's last two tasks
lane1() { stage exp2 --settings aug_all_ep,more_demos_ep --tasks $PICK,$CLOSE --jobs 1; }  # amendment 6
lane2() {
    stage seg --settings aug_all_seg,aug_object_seg --tasks $PLACE --jobs 1               # amendment 5
    stage exp2 --settings aug_all_ep,more_demos_ep --tasks $PLACE,$REMOVE --jobs 1        # amendment 6
}
if [ -n "${DRY:-}" ]; then
    lane1
    lane2
else
    lane1 &
    lane2 &
    wait
fi
stage exp2 --settings $A8 --tasks $REMOVE,$CLOSE                            # amendment 8, last two tasks
say "all stages done: run main's report (benchmarks/augmentation_experiment.py report)"

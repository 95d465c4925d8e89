#!/bin/bash
# Proves the render-farm recipe of scripts/farm/ on a real Slurm cluster of
# one node (this machine), as a farm user would run it:
#
#   1. installs Slurm and munge from Debian's packages (apt-get) if missing;
#   2. writes a single-node slurm.conf for this host (SelectType
#      select/cons_tres, TaskPlugin task/affinity, ProctrackType
#      proctrack/pgid, no accounting, jobcomp/filetxt for exit codes) and
#      starts munged, slurmctld and slurmd directly (no systemd here);
#   3. renders examples/cornell.tsl as a 16-task tile array plus the
#      dependent merge job, and checks the merged EXR is byte-identical to
#      a single-process render;
#   4. renders 6 frames of examples/orbit.tsl as an array (one frame per
#      task) plus the check job, each frame byte-identical to the frame of
#      a single-process `--frames 1..6` render;
#   5. makes one tile task fail on purpose (its output path is a
#      directory), checks that Slurm records it as failed, that the merge
#      job is cancelled, that `tslc merge` names the missing tile, and that
#      resubmitting just that tile gives the same image;
#   6. stops the daemons it started, by PID.
#
# Usage (as root; a few minutes; not run in CI):
#
#   scripts/farm/test-slurm.sh            # builds target/release/tslc first
#   TSLC=/path/to/tslc scripts/farm/test-slurm.sh
#
# Everything it writes goes under $WORK (default: a new /tmp/tsl-slurm.*),
# except the packages and munge's key (/etc/munge/munge.key, created by
# the package when missing). It prints a summary; the exit status is 0 when
# every check passed.
set -euo pipefail

repo=$(cd "$(dirname "$0")/../.." && pwd)
farm="$repo/scripts/farm"
work=${WORK:-$(mktemp -d /tmp/tsl-slurm.XXXXXX)}
mkdir -p "$work"/{etc,state,spool,log,run}
chmod 755 "$work"
started=()        # PIDs of the daemons this script started
results=()        # summary lines
failures=0
t_start=$(date +%s)

log() { printf '[%4ds] %s\n' $(( $(date +%s) - t_start )) "$*"; }
pass() { results+=("PASS  $*"); log "PASS $*"; }
fail() { results+=("FAIL  $*"); log "FAIL $*"; failures=$((failures + 1)); }

stop_daemons() {
    local pid
    for pid in "${started[@]}"; do
        kill "$pid" 2> /dev/null || true
    done
    for pid in "${started[@]}"; do
        for _ in $(seq 50); do
            kill -0 "$pid" 2> /dev/null || break
            sleep 0.2
        done
        kill -0 "$pid" 2> /dev/null && kill -9 "$pid" 2> /dev/null || true
    done
    [ ${#started[@]} -eq 0 ] || log "stopped the daemons (PIDs ${started[*]})"
    started=()
}
trap stop_daemons EXIT

if [ "$(id -u)" -ne 0 ]; then
    echo "error: run as root: it installs packages and starts munged, slurmctld and slurmd" >&2
    exit 2
fi

# ------------------------------------------------------------- 1. packages
if ! command -v slurmctld > /dev/null || ! command -v slurmd > /dev/null || ! command -v munged > /dev/null; then
    log "installing slurm-wlm and munge from Debian's packages"
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends slurm-wlm munge > "$work/log/apt.log" 2>&1 \
        || { apt-get update > /dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends slurm-wlm munge > "$work/log/apt.log" 2>&1; }
fi
slurm_version=$(slurmd -V)
log "$slurm_version, $(munged --version 2>&1 | head -1)"

# ------------------------------------------------------------- 2. daemons
# munge: the key the package made (or a new one), its run and log
# directories, and munged as the munge user.
if [ ! -s /etc/munge/munge.key ]; then
    mungekey --create --keyfile=/etc/munge/munge.key
fi
chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
install -d -o munge -g munge -m 0755 /run/munge
install -d -o munge -g munge -m 0700 /var/log/munge /var/lib/munge
if munge -n < /dev/null 2> /dev/null | unmunge > /dev/null 2>&1; then
    log "munged is already running: using it"
else
    install -d -o munge -g munge -m 0755 "$work/munge"
    runuser -u munge -- munged --pid-file="$work/munge/munged.pid" --log-file="$work/munge/munged.log"
    for _ in $(seq 25); do [ -s "$work/munge/munged.pid" ] && break; sleep 0.2; done
    started+=("$(cat "$work/munge/munged.pid")")
    munge -n < /dev/null | unmunge > /dev/null || { echo "error: munge does not work; see $work/munge/munged.log" >&2; exit 1; }
fi

host=$(hostname -s)
# This machine as slurmd sees it: CPUs, sockets, cores, threads, memory.
node=$(slurmd -C | head -1 | sed "s/^NodeName=[^ ]*/NodeName=$host/")
export SLURM_CONF="$work/etc/slurm.conf"
cat > "$SLURM_CONF" << EOF
# A single-node cluster for scripts/farm/test-slurm.sh.
ClusterName=tsltest
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/run/slurmctld.pid
SlurmdPidFile=$work/run/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
TaskPlugin=task/affinity
ProctrackType=proctrack/pgid
MpiDefault=none
SchedulerType=sched/backfill
ReturnToService=2
# No accounting (no slurmdbd); job states and exit codes go to a text file.
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/filetxt
JobCompLoc=$work/log/jobcomp.txt
$node State=UNKNOWN
PartitionName=farm Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
log "slurm.conf: $node"
slurmctld -f "$SLURM_CONF"
for _ in $(seq 50); do [ -s "$work/run/slurmctld.pid" ] && break; sleep 0.2; done
started+=("$(cat "$work/run/slurmctld.pid")")
slurmd -f "$SLURM_CONF" -N "$host"
for _ in $(seq 50); do [ -s "$work/run/slurmd.pid" ] && break; sleep 0.2; done
started+=("$(cat "$work/run/slurmd.pid")")
for _ in $(seq 60); do
    state=$(sinfo -h -o %T 2> /dev/null || true)
    [ "$state" = idle ] && break
    sleep 1
done
if [ "$state" != idle ]; then
    echo "error: the node is '$state', not idle; see $work/log/slurmctld.log and slurmd.log" >&2
    exit 1
fi
log "slurmctld and slurmd up (PIDs ${started[*]}), node $host idle"

# ------------------------------------------------------------- helpers
if [ -z "${TSLC:-}" ]; then
    log "building tslc (release)"
    (cd "$repo" && cargo build --release --quiet)
    TSLC="$repo/target/release/tslc"
fi
export TSLC
cd "$work/run"

# Waits until none of the jobs is queued or running any more.
wait_jobs() {
    local jobs=$1
    for _ in $(seq 1800); do
        [ -z "$(squeue -h -j "$jobs" 2> /dev/null)" ] && return 0
        sleep 1
    done
    echo "error: jobs $jobs still queued after 30 minutes" >&2
    return 1
}

# The job ids `submit-*.sh` printed: "...: job N ..., ...: job M ...".
job_ids() { grep -o 'job [0-9]*' | awk '{print $2}' | paste -sd, -; }

# The final state of a job (or array task, `J_I`), from jobcomp/filetxt.
job_state() {
    local id=$1
    if [[ $id == *_* ]]; then
        grep -E "JobId=[0-9]+ .*ArrayJobId=${id%_*} ArrayTaskId=${id#*_} " "$work/log/jobcomp.txt" | tail -1
    else
        grep -E "JobId=$id " "$work/log/jobcomp.txt" | tail -1
    fi | grep -o 'JobState=[A-Z_]* .*ExitCode=[0-9:]*' | sed 's/ .* / /' || echo "JobState=none"
}

# ------------------------------------------------------------- 3. tiles
scene="$repo/examples/cornell.tsl"
opts=(--res 96x72 --spp 16)
log "tiles: 16 tasks of examples/cornell.tsl at ${opts[*]}, then the merge job"
t0=$(date +%s)
out=$(OUT=out "$farm/submit-tiles.sh" "$scene" 16 "${opts[@]}") && log "$out"
ids=$(job_ids <<< "$out")
wait_jobs "$ids"
t_tiles=$(( $(date +%s) - t0 ))
tiles_jid=${ids%%,*}
merge_jid=${ids##*,}
"$TSLC" render "$scene" -o full.exr "${opts[@]}" --quiet
completed=$(grep -c "ArrayJobId=$tiles_jid .*JobState=COMPLETED\|JobState=COMPLETED.*ArrayJobId=$tiles_jid " "$work/log/jobcomp.txt" || true)
if [ "$completed" -eq 16 ] && job_state "$merge_jid" | grep -q COMPLETED && cmp -s out/cornell.exr full.exr; then
    pass "16 tile tasks completed, merge job $merge_jid completed after them, out/cornell.exr is byte-identical to a single-process render ($t_tiles s)"
else
    fail "tiles: $completed of 16 tasks completed, merge: $(job_state "$merge_jid"); cmp: $(cmp out/cornell.exr full.exr 2>&1 || true)"
fi
threads=$(grep -ho 'on [0-9]* threads\?' logs/tsl-tiles-"$tiles_jid"_*.log | sort | uniq -c | tr -s ' ' | paste -sd, -)
log "tile tasks ran${threads} (--cpus-per-task=1)"

# ------------------------------------------------------------- 4. frames
orbit="$repo/examples/orbit.tsl"
fopts=(--res 64x36 --spp 4)
log "frames: frames 1-6 of examples/orbit.tsl, one per task, then the check job"
t0=$(date +%s)
out=$(OUT=out "$farm/submit-frames.sh" "$orbit" 1 6 "${fopts[@]}") && log "$out"
ids=$(job_ids <<< "$out")
wait_jobs "$ids"
t_frames=$(( $(date +%s) - t0 ))
frames_jid=${ids%%,*}
check_jid=${ids##*,}
mkdir -p seq
"$TSLC" render "$orbit" -o seq/orbit.####.exr --frames 1..6 "${fopts[@]}" --quiet
same=0
for f in 1 2 3 4 5 6; do
    cmp -s "out/frames/orbit.000$f.exr" "seq/orbit.000$f.exr" && same=$((same + 1))
done
if [ "$same" -eq 6 ] && job_state "$check_jid" | grep -q COMPLETED; then
    pass "6 frame tasks, each frame byte-identical to frame N of one 'tslc render --frames 1..6'; check job completed ($t_frames s)"
else
    fail "frames: $same of 6 identical, check job: $(job_state "$check_jid")"
fi

# ------------------------------------------------------------- 5. a failure
log "a failed task: tile 5's output path is a directory"
mkdir -p bad/tiles/cornell.tile-5.exr
out=$(OUT=bad "$farm/submit-tiles.sh" "$scene" 16 "${opts[@]}") && log "$out"
ids=$(job_ids <<< "$out")
wait_jobs "$ids"
bad_jid=${ids%%,*}
bad_merge=${ids##*,}
task5=$(job_state "${bad_jid}_5")
merge_state=$(job_state "$bad_merge")
task_log=$(cat logs/tsl-tiles-"${bad_jid}"_5.log)
log "task ${bad_jid}_5: $task5; merge job $bad_merge: $merge_state"
log "its log: $(grep error <<< "$task_log" || true)"
if [[ $task5 == *FAILED*ExitCode=1:0* ]] && [[ $merge_state != *COMPLETED* ]] && [[ $task_log == *"is a directory"* ]]; then
    pass "the failed task is recorded (${bad_jid}_5 $task5), its log says why, the merge job did not run ($merge_state)"
else
    fail "failed task: '$task5', merge: '$merge_state'"
fi
# The farm user clears the debris and merges what is there.
rmdir bad/tiles/cornell.tile-5.exr
message=$("$TSLC" merge bad/tiles/cornell.tile-*.exr -o bad/cornell.exr 2>&1 || true)
log "tslc merge: $message"
if [[ $message == *"missing tile 5 of 16: rerun with --array=5"* ]]; then
    pass "tslc merge names the missing tile: \"$message\""
else
    fail "merge said: $message"
fi
jid=$(OUT=bad TILES=16 SCENE="$scene" TSLC_ARGS="${opts[*]}" sbatch --parsable --array=5 "$farm/tiles.sbatch")
mid=$(OUT=bad SCENE="$scene" sbatch --parsable --dependency=afterok:"${jid%%;*}" "$farm/merge.sbatch")
wait_jobs "${jid%%;*},${mid%%;*}"
if job_state "${mid%%;*}" | grep -q COMPLETED && cmp -s bad/cornell.exr full.exr; then
    pass "resubmitting --array=5 (TILES=16) and merging gives the single-process render's bytes"
else
    fail "resubmission: merge $(job_state "${mid%%;*}"), cmp: $(cmp bad/cornell.exr full.exr 2>&1 || true)"
fi

# ------------------------------------------------------------- 6. summary
stop_daemons
echo
echo "Summary: $slurm_version, one node ($node)"
printf '  %s\n' "${results[@]}"
echo "  total $(( $(date +%s) - t_start )) s; files in $work"
exit $(( failures > 0 ))

#!/usr/bin/env bash
# Issue 17, end to end on a real Slurm: a dataset rendered as a 4-task job
# array, one task killed (SIGKILL) in the middle of its shard and requeued,
# gives exactly the bytes of one `mucosa dataset run` over all frames.
#
#   slurm_e2e.sh MUCOSA SLURM_SINGLE_NODE
#
# MUCOSA is the mucosa binary, SLURM_SINGLE_NODE is scripts/slurm-single-node,
# which starts slurmctld, slurmd and munged under this test's temporary folder
# (root, Debian's slurm-wlm and munge; docs/slurm.md). The test fails, never
# skips, when that cluster cannot be started. Set MUCOSA_KEEP_TMP=1 to keep the
# temporary folder (logs, frames) for a look afterwards.
set -euo pipefail

[ $# -eq 2 ] || {
  echo "usage: $0 MUCOSA SLURM_SINGLE_NODE" >&2
  exit 2
}
mucosa="$1"
cluster="$2"

# The dataset: 32 frames, 4 segments of 8 (auto-exposure warms up before
# each), 4 shards of 8 frames. A shard renders for a second or two when the
# four share 2 cores, so the kill below lands while the victim has frames
# both done and to do; the test checks that it did.
readonly FRAMES=32 SEGMENT=8 SHARDS=4 VICTIM=1
readonly SIZE=160x120 OUTPUTS=rgb,depth
# Bounded waits (seconds), together well inside CTest's 900 s, so the test
# fails itself (and stops its cluster) before CTest would kill it.
readonly WAIT_VICTIM=180 WAIT_KILLED=60 WAIT_ARRAY=420

tmp="$(mktemp -d "${TMPDIR:-/tmp}/mucosa-slurm-e2e.XXXXXX")"
# The Slurm run's dataset, in a folder whose name the batch script must quote
# (a space, a quote) and escape (% starts a Slurm file name pattern).
a="$tmp/set a'1 %j"
b="$tmp/b"
job=""

cleanup() {
  local rc=$?
  "$cluster" stop "$tmp/slurm" >/dev/null 2>&1 || echo "warning: stopping the cluster in $tmp/slurm failed" >&2
  if [ "${MUCOSA_KEEP_TMP:-0}" = 1 ]; then
    echo "kept $tmp" >&2
  else
    rm -rf -- "$tmp"
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

log() { echo "slurm_e2e: $*" >&2; }

# What Slurm and the tasks said, for a failure's diagnosis.
diagnostics() {
  local f
  echo "---- squeue" >&2
  squeue -a 2>&1 | tail -n 20 >&2 || true
  if [ -n "$job" ]; then
    echo "---- scontrol show job $job" >&2
    scontrol show job "$job" 2>&1 | grep -E 'JobId=|JobState=|Restarts=' >&2 || true
  fi
  for f in "$a"/slurm/*.out "$tmp/slurm/log/slurmctld.log" "$tmp/slurm/log/slurmd.log"; do
    [ -f "$f" ] || continue
    echo "---- last lines of $f" >&2
    tail -n 12 "$f" >&2
  done
}
fail() {
  echo "FAIL: $*" >&2
  diagnostics
  exit 1
}

# A refusal: CMD... exits non-zero with one line on stderr, "error: ...",
# that contains WHAT.
refuses() {
  local what="$1" err rc=0
  shift
  err="$("$@" 2>&1 >/dev/null)" || rc=$?
  [ "$rc" -ne 0 ] || fail "'$*' succeeded; it should refuse ($what)"
  if [ "$(printf '%s\n' "$err" | grep -vc '^warning: ')" != 1 ] || [[ "$err" != *"error: "*"$what"* ]]; then
    fail "'$*' should say one line 'error: ...$what...'; it said: $err"
  fi
}

# Frames of shard I: the whole segments floor(I*S/K) .. floor((I+1)*S/K)-1
# (dataset_plan.hpp; mucosa dataset run prints the same range).
segments=$(((FRAMES + SEGMENT - 1) / SEGMENT))
victim_first=$(((VICTIM * segments / SHARDS) * SEGMENT))
victim_end=$((((VICTIM + 1) * segments / SHARDS) * SEGMENT))
[ "$victim_end" -le "$FRAMES" ] || victim_end=$FRAMES
victim_frames=$((victim_end - victim_first))

# The frame number in a file name (the first digits), whatever its padding.
frame_number() {
  [[ "${1##*/}" =~ ([0-9]+) ]] || return 1
  echo $((10#${BASH_REMATCH[1]}))
}
in_victim_shard() { [ "$1" -ge "$victim_first" ] && [ "$1" -lt "$victim_end" ]; }

# Frames of the victim's shard that are done: their .sha256 exists (written last).
victim_done() {
  local n=0 f i
  for f in "$a"/frames/*.sha256; do
    [ -e "$f" ] || continue
    i="$(frame_number "$f")" || continue
    if in_victim_shard "$i"; then n=$((n + 1)); fi
  done
  echo "$n"
}

# Temporaries of the victim's frames (an atomic write's .NAME.tmp-XXXXXX): a
# write the kill cut short. The other tasks' are theirs, still writing.
victim_temporaries() {
  local f i
  for f in "$a"/frames/.*.tmp-*; do
    [ -e "$f" ] || continue
    i="$(frame_number "$f")" || continue
    if in_victim_shard "$i"; then printf '%s ' "${f##*/}"; fi
  done
}

task_state() { scontrol show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -n 1; }

# The victim's process on this node (the batch script execs `mucosa dataset
# run DIR --shard I/K`), found through /proc with builtins only: no procps,
# and no fork per process, so a scan takes milliseconds.
victim_pids() {
  local d args
  for d in /proc/[0-9]*; do
    mapfile -d '' args <"$d/cmdline" 2>/dev/null || continue
    if [[ " ${args[*]} " == *" dataset run "*" --shard $VICTIM/$SHARDS "* ]]; then echo "${d#/proc/}"; fi
  done
}

# ---- refusals, before any cluster ---------------------------------------------

"$mucosa" dataset plan --frames "$FRAMES" --size "$SIZE" --outputs "$OUTPUTS" --segment-frames "$SEGMENT" \
  -o "$a" || fail "mucosa dataset plan failed"
mkdir "$tmp/empty"
refuses "plan.json: no such file" "$mucosa" dataset slurm "$tmp/empty" --shards 4
refuses "--shards" "$mucosa" dataset slurm "$a" --shards 0
refuses "--partition" "$mucosa" dataset slurm "$a" --shards 4 --partition "two words"
refuses "sbatch: not found" env PATH=/nonexistent "$mucosa" dataset slurm "$a" --shards 4 --submit
[ ! -e "$tmp/empty/slurm" ] || fail "a refused mucosa dataset slurm wrote $tmp/empty/slurm"

# ---- the cluster -------------------------------------------------------------

line="$("$cluster" start "$tmp/slurm")" || fail "could not start a single-node Slurm with $cluster (see its error above)"
[ "$line" = "export SLURM_CONF=$tmp/slurm/slurm.conf" ] || fail "$cluster start printed '$line'"
export SLURM_CONF="$tmp/slurm/slurm.conf"
log "single-node Slurm up: $(sinfo -h -o '%P %a %D %T %c CPUs')"

# sbatch refusing: its own message, on one line.
refuses "Invalid partition" "$mucosa" dataset slurm "$a" --shards 4 --partition nosuch --submit

# ---- write the array, submit -------------------------------------------------

job="$("$mucosa" -q dataset slurm "$a" --shards "$SHARDS" --submit)" || fail "mucosa dataset slurm --submit failed"
[[ "$job" =~ ^[0-9]+$ ]] || fail "mucosa -q dataset slurm --submit printed '$job', not a job id"
script="$a/slurm/run.sbatch"
grep -qx "#SBATCH --array=0-$((SHARDS - 1))" "$script" || fail "$script has no --array=0-$((SHARDS - 1))"
grep -qx "#SBATCH --requeue" "$script" || fail "$script has no --requeue"
grep -q "^exec .* dataset run .* --shard \"\${SLURM_ARRAY_TASK_ID.*/$SHARDS\"\$" "$script" ||
  fail "$script does not exec dataset run --shard"
log "submitted job $job; shard $VICTIM is frames $victim_first..$((victim_end - 1))"

# ---- kill the victim in the middle of its shard ------------------------------

# The moment a frame of its shard is done, the victim is stopped (SIGSTOP,
# straight to its process), counted, then killed through Slurm. A shard takes
# a few seconds on a fast machine, less than Slurm's own signalling or a loop
# of scontrol calls can be trusted to land within; a stopped process makes
# no progress, so the count is what the kill finds. The polling below runs
# builtins only (scontrol once a second), every 10 ms.
deadline=$((SECONDS + WAIT_VICTIM))
pids=""
polls=0
while [ -z "$pids" ]; do
  pids="$(victim_pids)"
  if [ -z "$pids" ] && [ $((polls % 20)) = 0 ]; then
    state="$(task_state "${job}_$VICTIM")"
    [ -z "$state" ] || [ "$state" = RUNNING ] || [ "$state" = PENDING ] || [ "$state" = CONFIGURING ] ||
      fail "task ${job}_$VICTIM is $state before its process could be found"
  fi
  [ "$SECONDS" -lt "$deadline" ] || fail "no process of task ${job}_$VICTIM ('dataset run ... --shard $VICTIM/$SHARDS') within ${WAIT_VICTIM}s"
  polls=$((polls + 1))
  sleep 0.05
done
while [ "$(victim_done)" -lt 1 ]; do
  kill -0 $pids 2>/dev/null || fail "task ${job}_$VICTIM's process ($pids) ended before a frame of its shard was done"
  [ "$SECONDS" -lt "$deadline" ] || fail "task ${job}_$VICTIM did not finish a frame within ${WAIT_VICTIM}s"
  sleep 0.01
done
kill -STOP $pids 2>/dev/null || fail "task ${job}_$VICTIM's process ($pids) ended before it could be stopped"
state="$(task_state "${job}_$VICTIM")"
[ "$state" = RUNNING ] || fail "task ${job}_$VICTIM is ${state:-gone} when a frame of its shard is done"
done_now="$(victim_done)"
[ "$done_now" -lt "$victim_frames" ] ||
  fail "task ${job}_$VICTIM finished its $victim_frames frames before it could be stopped; frames must take longer"
scancel --signal=KILL "${job}_$VICTIM" || fail "scancel --signal=KILL ${job}_$VICTIM failed"
deadline=$((SECONDS + WAIT_KILLED))
while :; do
  state="$(task_state "${job}_$VICTIM")"
  case "$state" in RUNNING | COMPLETING | CONFIGURING) ;; *) break ;; esac
  [ "$SECONDS" -lt "$deadline" ] || fail "task ${job}_$VICTIM still $state ${WAIT_KILLED}s after SIGKILL"
  sleep 0.1
done
[ "$state" != COMPLETED ] || fail "task ${job}_$VICTIM completed although it was killed"
killed_done="$(victim_done)"
if [ "$killed_done" -lt 1 ] || [ "$killed_done" -ge "$victim_frames" ]; then
  fail "task ${job}_$VICTIM was not killed mid-shard: $killed_done of $victim_frames frames done after the kill"
fi
log "killed task ${job}_$VICTIM ($state) with $killed_done of $victim_frames frames of its shard done"
cut="$(victim_temporaries)"
[ -z "$cut" ] || log "the kill cut a write short, leaving: $cut"

# ---- requeue it, wait for the array -------------------------------------------

scontrol requeue "${job}_$VICTIM" || fail "scontrol requeue ${job}_$VICTIM failed"
deadline=$((SECONDS + WAIT_ARRAY))
while [ -n "$(squeue -h -j "$job" -o %i 2>/dev/null)" ]; do
  [ "$SECONDS" -lt "$deadline" ] || fail "job array $job did not finish within ${WAIT_ARRAY}s"
  sleep 1
done
for ((i = 0; i < SHARDS; i++)); do
  state="$(task_state "${job}_$i")"
  [ "$state" = COMPLETED ] || fail "task ${job}_$i ended $state, not COMPLETED"
  [ -s "$a/slurm/${job}_$i.out" ] || fail "task ${job}_$i left no log at $a/slurm/${job}_$i.out"
done
restarts="$(scontrol show job "${job}_$VICTIM" | sed -n 's/.*Restarts=\([0-9]*\).*/\1/p')"
[ "$restarts" = 1 ] || fail "task ${job}_$VICTIM was restarted ${restarts:-?} times, not once"
grep -q "attempt 2" "$a/slurm/${job}_$VICTIM.out" || fail "the log of task ${job}_$VICTIM shows no second attempt"
log "array $job completed; task ${job}_$VICTIM ran twice"

"$mucosa" dataset verify "$a" || fail "mucosa dataset verify of the Slurm run failed"

# ---- the same plan in one run: the same bytes ---------------------------------

mkdir "$b"
cp "$a/plan.json" "$b/plan.json"
"$mucosa" dataset run "$b" 2>"$tmp/b-run.log" || {
  cat "$tmp/b-run.log" >&2
  fail "mucosa dataset run over all frames failed"
}
"$mucosa" dataset verify "$b" || fail "mucosa dataset verify of the single run failed"

# A write cut short by SIGKILL leaves its temporary (.NAME.tmp-XXXXXX, the
# atomic write's): the rerun must not leave it in the dataset.
leftovers="$(cd "$a/frames" && find . -type f -name '.*.tmp-*' | LC_ALL=C sort | tr '\n' ' ')"
[ -z "$leftovers" ] ||
  fail "the killed task's unfinished writes are still in frames/ after the rerun: $leftovers"

list() { (cd "$1" && find . -type f | LC_ALL=C sort); }
list "$a/frames" >"$tmp/a.list"
list "$b/frames" >"$tmp/b.list"
if ! cmp -s "$tmp/a.list" "$tmp/b.list"; then
  diff "$tmp/a.list" "$tmp/b.list" | head -n 20 >&2 || true
  fail "the Slurm run and the single run wrote different files under frames/ (diff above, < Slurm, > single)"
fi
files=0
while IFS= read -r f; do
  cmp "$a/frames/$f" "$b/frames/$f" >&2 || fail "frames/$f differs between the Slurm run and the single run"
  files=$((files + 1))
done <"$tmp/a.list"
[ "$files" -ge "$FRAMES" ] || fail "only $files files under frames/"
cmp "$a/SHA256SUMS" "$b/SHA256SUMS" || fail "SHA256SUMS differ between the Slurm run and the single run"
log "PASS: $files files under frames/ are byte-identical between the Slurm array (one task killed and requeued) and one run"

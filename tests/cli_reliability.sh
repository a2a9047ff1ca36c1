#!/usr/bin/env bash
# The command line against issue 13's and issue 43's reproducers, run exactly as a user would:
#   cli_reliability.sh PLUMAGE SOURCE_DIR CASE
# Each case prints what it saw and exits non-zero on the first broken promise (77: skipped,
# saying why).
set -u
plumage=$1; source=$2; case=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
fail() { echo "FAIL ($case): $*"; exit 1; }

# The owner record (studies/staged_directory.h) of process $1 on this host and boot, in PID
# namespace $2 (default: ours).
owner_record() {
  printf 'host=%s\nboot_id=%s\npid_namespace=%s\npid=%s\nstart_time=1\n' "$(hostname)" \
    "$(cat /proc/sys/kernel/random/boot_id)" "${2:-$(stat -L -c %i /proc/self/ns/pid)}" "$1"
}

# A measure study `name` ($1) of plate.obj (copied here) with $2 BRDF passes of 2048 quanta.
measure_study() {
  cp -n "$source/studies/measure/plate.obj" plate.obj
  cat <<TOML
study = "measure"
name = "$1"
seed = 5
[spectrum]
first_nm = 400
last_nm = 700
step_nm = 100
[sample]
file = "plate.obj"
require_closed = false
material = "melanin"
[sample.film]
material = "keratin"
thickness_um = 0.59
[brdf]
direction_set = "mirror"
mirror_angles_deg = [15, 45, 75]
detector_half_angle_deg = 2.5
beam_radius_um = 20
quanta_per_pass = 2048
passes = $2
TOML
}

# Runs study $1 into results/ and sends SIGINT once its BRDF checkpoint has a pass; the run
# must stop with exit 130 and keep the checkpoint.
interrupt_after_first_pass() {
  "$plumage" run "$1" --out results --no-plots >interrupted.log 2>&1 & local pid=$!
  local name; name=$(sed -n 's/^name = "\(.*\)"/\1/p' "$1")
  for _ in $(seq 600); do
    [[ -f results/.checkpoints/$name/brdf.checkpoint ]] && break
    sleep 0.05
  done
  kill -INT $pid; wait $pid; local code=$?
  [[ $code -eq 130 ]] || fail "the run to interrupt exited $code: $(cat interrupted.log)"
  [[ -f results/.checkpoints/$name/brdf.checkpoint ]] || fail "no checkpoint kept: $(cat interrupted.log)"
}

# The records of results/$1 equal those of a fresh run of study $2 (its name $1) in fresh/.
same_as_fresh_run() {
  "$plumage" run "$2" --out fresh --no-plots >fresh.log 2>&1 || fail "fresh run: $(cat fresh.log)"
  /usr/bin/python3 "$source/scripts/compare_records.py" "results/$1" "fresh/$1" \
    || fail "the rerun's records differ from a fresh run's"
}

case $case in
absolute_name)
  # Reproducer 1: an absolute study name used to replace (and delete) the folder it named.
  mkdir victim && echo precious > victim/keep.txt
  sed "s|^name = .*|name = \"$PWD/victim\"|" "$source/studies/ablation_quick.toml" > abs.toml
  message=$("$plumage" run abs.toml --out results --threads 2 2>&1); code=$?
  [[ $code -eq 2 ]] || fail "exit $code, expected 2: $message"
  grep -q "abs.toml:5:8: name = \"$PWD/victim\"" <<<"$message" || fail "message names no file:line:col: $message"
  [[ "$(cat victim/keep.txt)" == precious ]] || fail "victim/keep.txt is gone"
  [[ ! -e results ]] || fail "results were written: $(ls -A results)"
  ;;
foreign_folder)
  # A folder the user owns, of the study's name, is refused before any work and kept.
  mkdir -p results/masking_quick && echo mine > results/masking_quick/notes.txt
  message=$("$plumage" run "$source/studies/masking_quick.toml" --out results 2>&1); code=$?
  [[ $code -eq 2 ]] || fail "exit $code, expected 2: $message"
  grep -q "was not written by plumage" <<<"$message" || fail "$message"
  [[ "$(cat results/masking_quick/notes.txt)" == mine ]] || fail "the user's file is gone"
  ;;
orphan)
  # Reproducer 4: a staging folder left by a killed run (on this host and boot, its process
  # gone) is removed by the next run.
  sleep 0 & gone=$!; wait $gone
  mkdir -p "results/masking_quick.partial-$gone" && touch "results/masking_quick.partial-$gone/.plumage-results"
  owner_record $gone > "results/masking_quick.partial-$gone/.plumage-owner"
  message=$("$plumage" run "$source/studies/masking_quick.toml" --out results --no-plots 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "exit $code: $message"
  [[ ! -e "results/masking_quick.partial-$gone" ]] || fail "the orphan survived"
  grep -q "removed .*masking_quick.partial-$gone, left by process $gone which is gone" <<<"$message" || fail "not said: $message"
  ;;
tiny_step)
  # Reproducer 2: step_nm = 1e-320 used to allocate until out of memory.
  sed "s|^step_nm = .*|step_nm = 1e-320|" "$source/studies/rock_dove_quick.toml" > tiny.toml
  message=$("$plumage" run tiny.toml --out results 2>&1); code=$?
  [[ $code -eq 2 ]] || fail "exit $code, expected 2: $message"
  grep -q "tiny.toml:17:11: spectrum.step_nm = .*expected at most 4701" <<<"$message" || fail "$message"
  ;;
plot_failure)
  # Reproducer 5: a plot that fails no longer loses the study.
  message=$(PLUMAGE_PYTHON=/nonexistent/python3 "$plumage" run "$source/studies/masking_quick.toml" --out results 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "exit $code: $message"
  [[ -f results/masking_quick/masking.h5 && -f results/masking_quick/report.md ]] || fail "records or report missing"
  grep -q "warning: masking.png not drawn: cannot run the interpreter /nonexistent/python3" <<<"$message" || fail "$message"
  ;;
options_after_subcommand)
  # --out, --threads and --no-plots after the subcommand (geometry used to exit 109).
  message=$("$plumage" geometry "$source/studies/geometry/rock_dove_row.toml" --out R --threads 2 --no-plots 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "exit $code: $message"
  [[ -f R/rock_dove_row/report.md ]] || fail "no R/rock_dove_row/report.md"
  help=$("$plumage" run --help 2>&1)
  for option in --out --threads --time-budget --target-error --no-plots; do
    grep -q -- "$option" <<<"$help" || fail "run --help does not list $option"
  done
  ;;
messages)
  # Short, named messages for misspellings and wrong values.
  message=$("$plumage" --threads two 2>&1); code=$?
  [[ $code -ne 0 && ${#message} -lt 300 ]] || fail "exit $code, ${#message} characters: $message"
  grep -q "expected a whole number of threads" <<<"$message" || fail "$message"
  message=$("$plumage" runn x.toml 2>&1)
  grep -q "did you mean 'run'" <<<"$message" || fail "$message"
  message=$("$plumage" run x.toml --treads 2 2>&1)
  grep -q "did you mean '--threads'" <<<"$message" || fail "$message"
  message=$("$plumage" run "$source/studies/geometry/rock_dove_row.toml" 2>&1); code=$?
  [[ $code -eq 2 ]] && grep -q "plumage geometry" <<<"$message" || fail "exit $code: $message"
  message=$("$plumage" geometry "$source/studies/masking_quick.toml" 2>&1); code=$?
  [[ $code -eq 2 ]] && grep -q "plumage run" <<<"$message" || fail "exit $code: $message"
  message=$("$plumage" run "$source/studies/masking_quick.toml" --time-budget 5 2>&1); code=$?
  [[ $code -eq 2 ]] && grep -q "do not apply to the masking study" <<<"$message" || fail "exit $code: $message"
  ;;
changed_mesh)
  # Issue 43, case 2: a BRDF checkpoint of a mesh that changed since used to be resumed (exit 0,
  # a record mixing both meshes). Now the run starts afresh, says why, and its records equal a
  # fresh run's of the new mesh (here the plate moved out of the beam: a fresh run reads 0).
  measure_study m 100 > m.toml
  interrupt_after_first_pass m.toml
  sed -i 's/^v -100 /v 900 /; s/^v 100 /v 1100 /' plate.obj
  message=$("$plumage" run m.toml --out results --no-plots 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "exit $code: $message"
  grep -q "not resuming .*brdf.checkpoint: the content of the sample file 'plate.obj' changed" <<<"$message" \
    || fail "not said why: $message"
  [[ $(grep -c "not resuming" <<<"$message") -eq 1 ]] || fail "said more than once: $message"
  same_as_fresh_run m m.toml
  [[ ! -e results/.checkpoints ]] || fail "checkpoints left: $(ls -R results/.checkpoints)"
  ;;
stale_checkpoint)
  # Issue 43, case 2: a failed run's checkpoint used to block a changed study of the same name
  # ("belongs to a different measurement ... remove it"); a damaged one ended the run. Neither
  # blocks now: the run starts afresh, says why, and equals a fresh run.
  measure_study m 100 > m.toml
  interrupt_after_first_pass m.toml
  measure_study m 20 | sed 's/^seed = 5/seed = 6/' > changed.toml
  message=$("$plumage" run changed.toml --out results --no-plots 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "changed study: exit $code: $message"
  grep -q "not resuming .*brdf.checkpoint: the study file changed; the measurement's configuration changed" <<<"$message" \
    || fail "changed study: not said why: $message"
  same_as_fresh_run m changed.toml
  rm -rf fresh
  interrupt_after_first_pass m.toml
  head -c 3000 /dev/urandom > results/.checkpoints/m/brdf.checkpoint
  message=$("$plumage" run m.toml --out results --no-plots 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "damaged checkpoint: exit $code: $message"
  grep -q "not resuming .*brdf.checkpoint: it cannot be read" <<<"$message" || fail "damaged: $message"
  same_as_fresh_run m m.toml
  ;;
pid_namespaces)
  # Issue 43, case 3: a run in another PID namespace sharing --out took a running study's
  # staging folder for an orphan (its pid is not alive there) and deleted it; that study failed.
  # Run A as pid 2 of a new namespace; once its staging folder exists, start B (another study,
  # pid 3 of its own namespace, where pid 2 is nobody) and C (the same study, pid 2 of a third).
  unshare --pid --fork --mount-proc true 2>/dev/null || { echo "skipped: unshare --pid needs root"; exit 77; }
  measure_study a 200 > a.toml; measure_study b 5 > b.toml
  unshare --pid --fork --mount-proc sh -c '"$0" run a.toml --out results --no-plots; exit $?' "$plumage" >a.log 2>&1 & a=$!
  for _ in $(seq 600); do compgen -G "results/a.partial-*" >/dev/null && break; sleep 0.05; done
  compgen -G "results/a.partial-*" >/dev/null || fail "A never staged: $(cat a.log)"
  unshare --pid --fork --mount-proc sh -c '/bin/true; "$0" run b.toml --out results --no-plots; exit $?' "$plumage" >b.log 2>&1 & b=$!
  unshare --pid --fork --mount-proc sh -c '"$0" run a.toml --out results --no-plots; exit $?' "$plumage" >c.log 2>&1 & c=$!
  wait $b; code_b=$?
  kill -0 $a 2>/dev/null || fail "A ended before B did: nothing overlapped (raise A's passes)"
  wait $c; code_c=$?; wait $a; code_a=$?
  [[ $code_a -eq 0 ]] || fail "A exited $code_a: $(cat a.log)"
  [[ $code_b -eq 0 ]] || fail "B exited $code_b: $(cat b.log)"
  [[ $code_c -eq 0 ]] || fail "C exited $code_c: $(cat c.log)"
  [[ -f results/a/report.md && -f results/b/report.md ]] || fail "results missing: $(ls -A results)"
  ! grep -q "removed" a.log b.log c.log || fail "a run removed something: $(cat a.log b.log c.log)"
  left=$(ls -A results | grep -e '\.partial-' -e '\.previous-'); [[ -z $left ]] || fail "left: $left"
  ;;
foreign_owner)
  # A staging folder whose owner ran on another boot (another host, or before a reboot), or
  # whose record is missing, cannot be proven abandoned: it is left alone, and said so once.
  sleep 0 & gone=$!; wait $gone
  for dir in x.partial-$gone-1 y.previous-$gone-2 z.partial-$gone; do
    mkdir -p results/$dir && touch results/$dir/.plumage-results results/$dir/keep.txt
  done
  owner_record $gone | sed 's/^boot_id=.*/boot_id=another-boot/' > results/x.partial-$gone-1/.plumage-owner
  owner_record $gone 4026531999 | sed 's/^host=.*/host=another-host/' > results/y.previous-$gone-2/.plumage-owner
  message=$("$plumage" run "$source/studies/masking_quick.toml" --out results --no-plots 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "exit $code: $message"
  for dir in x.partial-$gone-1 y.previous-$gone-2 z.partial-$gone; do
    [[ -f results/$dir/keep.txt ]] || fail "$dir was removed: $message"
    [[ $(grep -c "left results/$dir alone" <<<"$message") -eq 1 ]] || fail "$dir not said once: $message"
  done
  [[ ! -e results/y ]] || fail "y.previous- was restored"
  ;;
reserved_names)
  # Issue 43, case 3: names the staging scheme uses were accepted as study names, and the next
  # run deleted (x.partial-999999) or renamed (y.previous-999998) such results. Refused now at
  # read time with file:line:column; folders of such names already there are left untouched.
  for name in x.partial-999999 y.previous-999998 .checkpoints .plumage-owner; do
    sed "s|^name = .*|name = \"$name\"|" "$source/studies/masking_quick.toml" > reserved.toml
    message=$("$plumage" run reserved.toml --out results 2>&1); code=$?
    [[ $code -eq 2 ]] || fail "$name: exit $code, expected 2: $message"
    grep -q "reserved.toml:[0-9]*:[0-9]*: name = \"$name\" .*reserved" <<<"$message" || fail "$name: $message"
  done
  [[ ! -e results ]] || fail "results were written: $(ls -A results)"
  for name in x.partial-999999 y.previous-999998; do
    mkdir -p results/$name && touch results/$name/.plumage-results && echo mine > results/$name/report.md
  done
  message=$("$plumage" run "$source/studies/masking_quick.toml" --out results --no-plots 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "exit $code: $message"
  for name in x.partial-999999 y.previous-999998; do
    [[ "$(cat results/$name/report.md)" == mine ]] || fail "$name was touched: $message"
  done
  [[ ! -e results/y ]] || fail "y.previous-999998 was renamed to y"
  ;;
*) fail "unknown case" ;;
esac
echo "ok: $case"

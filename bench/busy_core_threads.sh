#!/usr/bin/env bash
# Issue 41: is `--threads 2` no slower than `--threads 1` when another process holds one of the
# cores? Times quick studies at 1 and 2 threads, with and without a busy loop beside them, in both
# orders (1 then 2, 2 then 1), under two wait policies of the idle OpenMP threads:
#   passive  what plumage does unless told (common/omp_wait_policy.h: idle threads sleep)
#   spin     GOMP_SPINCOUNT=300000, libgomp's own default, i.e. what plumage did before
# Each pair is timed back to back, so the 2-thread/1-thread ratio of a pair shares the machine's
# load of the moment (other users' jobs on a shared machine move single times by tens of %).
# Also checks that the records of 1 and 2 threads are the same to the bit
# (scripts/compare_records.py), once per study.
#
#   bench/busy_core_threads.sh PLUMAGE [REPEATS [STUDY...]]
#     PLUMAGE  the plumage executable (e.g. build/studies/plumage)
#     REPEATS  times the whole matrix runs (default 1)
#     STUDY    studies/*.toml stems (default: species_quick rock_dove_quick)
#   LOADS="busy idle" POLICIES="passive spin" choose the rows (defaults: both of each).
#
# Prints one CSV line per run (study, load, policy, order, threads, wall s, CPU s) and, at the
# end, per study, load and policy the median and range of the pairs' wall and CPU ratios
# (2 threads / 1 thread). The busy loop is a shell `while :` started here and killed on any exit.
set -u
plumage=$(realpath "$1")
repeats=${2:-1}
shift $(($# >= 2 ? 2 : 1))
studies=("$@")
[[ ${#studies[@]} -eq 0 ]] && studies=(species_quick rock_dove_quick)
loads=${LOADS:-busy idle}
policies=${POLICIES:-passive spin}
source=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
busy_pid=""
stop_busy() {
  if [[ -n $busy_pid ]]; then
    kill "$busy_pid" 2>/dev/null
    wait "$busy_pid" 2>/dev/null
  fi
  busy_pid=""
}
trap 'stop_busy; rm -rf "$work"' EXIT
trap 'exit 130' INT TERM

# run STUDY POLICY THREADS OUT: appends "wall cpu" of one run to stdout.
run() {
  local study=$1 policy=$2 threads=$3 out=$4
  local -a env_vars=()
  [[ $policy == spin ]] && env_vars=(GOMP_SPINCOUNT=300000)
  rm -rf "$out"
  if ! env "${env_vars[@]}" /usr/bin/time -f "%e %U %S" -o "$work/time" "$plumage" \
       --threads "$threads" --no-plots --out "$out" run "$source/studies/$study.toml" \
       >"$work/log" 2>&1; then
    echo "FAIL: $study, $policy, $threads threads:" >&2
    cat "$work/log" >&2
    exit 1
  fi
  awk '{ printf "%.2f,%.2f\n", $1, $2 + $3 }' "$work/time"
}

echo "study,load,policy,order,threads,wall_s,cpu_s" | tee "$work/runs.csv"
declare -A compared=()
for ((r = 1; r <= repeats; r++)); do
  for study in "${studies[@]}"; do
    for load in $loads; do
      if [[ $load == busy ]]; then
        bash -c 'while :; do :; done' &
        busy_pid=$!
      fi
      for policy in $policies; do
        for order in "1 2" "2 1"; do
          for threads in $order; do
            times=$(run "$study" "$policy" "$threads" "$work/t$threads") || exit 1
            echo "$study,$load,$policy,${order/ />},$threads,$times" | tee -a "$work/runs.csv"
          done
          if [[ $policy == passive && -z ${compared[$study]:-} ]]; then
            if ! /usr/bin/python3 "$source/scripts/compare_records.py" "$work/t1" "$work/t2" \
                 >"$work/compare" 2>&1; then
              echo "FAIL: $study: the records of 1 and 2 threads differ:" >&2
              cat "$work/compare" >&2
              exit 1
            fi
            echo "# $study: records of 1 and 2 threads identical (scripts/compare_records.py)"
            compared[$study]=1
          fi
        done
      done
      stop_busy
    done
  done
done

# Pairs: consecutive lines of one (study, load, policy, order) block, in the order run.
echo
echo "study,load,policy,pairs,wall ratio median [min-max],cpu ratio median [min-max]"
awk -F, 'NR > 1 {
    key = $1 "," $2 "," $3; wall[key, $4, $5] = $6; cpu[key, $4, $5] = $7
    if ($5 == 2 && $4 == "1>2" || $5 == 1 && $4 == "2>1") {
      n[key]++; w[key, n[key]] = wall[key, $4, 2] / wall[key, $4, 1]
      c[key, n[key]] = cpu[key, $4, 2] / cpu[key, $4, 1]
      if (!(key in seen)) { seen[key] = 1; keys[++k] = key }
    }
  }
  function summary(a, key, m,   i, j, t, v) {
    for (i = 1; i <= m; i++) v[i] = a[key, i]
    for (i = 1; i <= m; i++) for (j = i + 1; j <= m; j++) if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
    return sprintf("%.2f [%.2f-%.2f]", m % 2 ? v[(m + 1) / 2] : (v[m / 2] + v[m / 2 + 1]) / 2, v[1], v[m])
  }
  END { for (i = 1; i <= k; i++) print keys[i] "," n[keys[i]] "," summary(w, keys[i], n[keys[i]]) "," summary(c, keys[i], n[keys[i]]) }' \
  "$work/runs.csv"

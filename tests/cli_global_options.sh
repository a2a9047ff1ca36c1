#!/usr/bin/env bash
# Issue 41: the global options (--out, --threads, --time-budget, --target-error, --no-plots) work
# with every subcommand, before or after it, or are refused by name (exit 2, nothing written).
#   cli_global_options.sh PLUMAGE SOURCE_DIR CASE
# CASE is a subcommand (run, default, geometry, thin-film, fit, export-bsdf): each writes under
# --out given after the subcommand and given before it, and nothing lands in the working folder.
# export-bsdf ignored --out before the fix (it wrote beside its source, here the working folder).
set -u
plumage=$1; source=$2; case=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
fail() { echo "FAIL ($case): $*"; exit 1; }
# ok FILE ARGS...: plumage ARGS exits 0 and writes FILE; nothing else appears beside the
# inputs in the working folder (made before the call: in/).
ok() {
  local file=$1; shift
  message=$("$plumage" "$@" 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "$*: exit $code: $message"
  [[ -f $file ]] || fail "$*: no $file; wrote: $(find . -newer in -type f | head)"
  stray=$(ls -A | grep -v -x -e in -e out -e out2)
  [[ -z $stray ]] || fail "$*: wrote outside --out: $stray"
}
# refused PATTERN ARGS...: exit 2, PATTERN (the option's name) in the message, nothing written.
refused() {
  local pattern=$1; shift
  message=$("$plumage" "$@" 2>&1); code=$?
  [[ $code -eq 2 ]] || fail "$*: exit $code, expected 2: $message"
  grep -q -- "$pattern" <<<"$message" || fail "$*: no '$pattern' in: $message"
  [[ ! -e out3 ]] || fail "$*: out3 was written: $(find out3)"
}
mkdir in
case $case in
run)
  study=$source/studies/calibration.toml
  ok out/calibration/report.md run "$study" --out out --threads 2 --no-plots
  ok out2/calibration/report.md --out out2 --threads 1 --no-plots run "$study"
  ;;
default)
  # The default study takes a minute or more: its staging folder must appear under --out, then
  # SIGTERM stops it (exit 143) and nothing is left there.
  "$plumage" --out out --no-plots --threads 1 > log 2>&1 &
  pid=$!
  for _ in $(seq 1 300); do
    compgen -G "out/rock_dove.partial-*" >/dev/null && break
    kill -0 $pid 2>/dev/null || break
    sleep 0.1
  done
  compgen -G "out/rock_dove.partial-*" >/dev/null || { kill $pid 2>/dev/null; fail "no out/rock_dove.partial-*: $(cat log)"; }
  kill -TERM $pid
  wait $pid; code=$?
  [[ $code -eq 143 ]] || fail "exit $code after SIGTERM, expected 143: $(cat log)"
  left=$(ls -A out | grep -v -x -e .checkpoints)
  [[ -z $left ]] || fail "left in out: $left"
  ;;
geometry)
  study=$source/studies/geometry/rock_dove_row.toml
  ok out/rock_dove_row/report.md geometry "$study" --out out --threads 2 --no-plots
  ok out2/rock_dove_row/report.md --out out2 geometry "$study"
  refused "--time-budget" geometry "$study" --out out3 --time-budget 5
  ;;
thin-film)
  coarse=(--thickness-step-nm 20 --angle-step-deg 10 --max-thickness-nm 1000)
  ok out/thin_film/report.md thin-film "${coarse[@]}" --out out --threads 2 --no-plots
  ok out2/thin_film/report.md --out out2 --no-plots thin-film "${coarse[@]}"
  refused "--target-error" thin-film "${coarse[@]}" --out out3 --target-error 0.1
  ;;
fit)
  # A small BRDF table in the documented layout (docs/user_data.md).
  {
    echo "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,wavelength_nm,value_per_sr,sigma_per_sr"
    for ti in 15 30 45 60; do for to in 0 15 30 45 60 75; do for po in 0 90 180 270; do
      for l in 450 550 650; do
        echo "$ti,90,$to,$po,$l,$(awk -v a="$ti" -v b="$to" -v c="$po" \
          'BEGIN { printf "%.4f", 0.1 + 0.02 * cos(c * 3.14159 / 180) + 0.001 * a + 0.0005 * b }'),0.01"
      done
    done; done; done
  } > in/brdf.csv
  ok out/fit_filip2024_brdf/parameters.json fit --model filip2024 in/brdf.csv --out out --threads 2 --no-plots
  ok out2/fit_filip2024_brdf/parameters.json --out out2 --no-plots fit --model filip2024 in/brdf.csv
  refused "--time-budget" fit --model filip2024 in/brdf.csv --out out3 --time-budget 5
  ;;
export-bsdf)
  small=(--theta-nodes 2 --phi-nodes 1 --resolution 4 --step-nm 150)
  ok out/filip2024_parrot.bsdf export-bsdf filip2024:parrot "${small[@]}" --out out --threads 2 --no-plots
  ok out2/sub/huang2022.bsdf --out out2/sub export-bsdf huang2022 "${small[@]}"
  # A relative -o is inside --out; an absolute one is refused naming both.
  ok out/named.bsdf export-bsdf filip2024:rooster "${small[@]}" -o named.bsdf --out out
  refused "--out out3 with -o /" export-bsdf filip2024:parrot --out out3 -o "$work/in/x.bsdf"
  refused "--time-budget" export-bsdf filip2024:parrot "${small[@]}" --out out3 --time-budget 5
  refused "--target-error" --target-error 0.1 --out out3 export-bsdf filip2024:parrot
  ;;
*)
  fail "unknown case"
  ;;
esac
echo "ok ($case)"

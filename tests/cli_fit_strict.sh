#!/usr/bin/env bash
# Issue 40: a fit that warns says so on stderr and in its report, and `plumage fit --strict`
# exits 3 for it (its results written all the same); without --strict the exit is 0. The data: a
# Lambertian 0.1/sr over 60 direction pairs and three wavelengths, without σ, which a fit cannot
# judge (analysis/fits/fit_summary.h's fit_warnings: "the data give no standard errors").
#   cli_fit_strict.sh PLUMAGE
set -u
plumage=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
csv=$work/lambert.csv
echo "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,wavelength_nm,value_per_sr" >"$csv"
for ti in 10 30 50 70; do
  for to in 5 20 35 50 65; do
    for po in 0 120 240; do
      for l in 450 550 650; do echo "$ti,90,$to,$po,$l,0.1" >>"$csv"; done
    done
  done
done
"$plumage" --out "$work/results" --no-plots fit --model filip2024 --name plain "$csv" \
  >"$work/out" 2>"$work/err"
code=$?
[[ $code -eq 0 ]] || fail "without --strict: exit $code, expected 0: $(cat "$work/err")"
grep -q "WARNING: the data give no standard errors" "$work/err" ||
  fail "no warning on stderr: $(cat "$work/err")"
grep -q "the data give no standard errors" "$work/results/plain/report.md" ||
  fail "no warning in the report"
grep -q '"warnings": \["the data give no standard errors' "$work/results/plain/parameters.json" ||
  fail "no warning in parameters.json"
"$plumage" --out "$work/results" --no-plots fit --strict --model filip2024 --name strict "$csv" \
  >"$work/out" 2>"$work/err"
code=$?
[[ $code -eq 3 ]] || fail "with --strict: exit $code, expected 3: $(cat "$work/err")"
[[ -f $work/results/strict/parameters.json ]] || fail "with --strict the results were not written"
echo "ok"

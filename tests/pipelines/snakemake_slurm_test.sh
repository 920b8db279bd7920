#!/usr/bin/env bash
# The Slurm profile (pipelines/batch/profiles/slurm) end to end against a fake Slurm kept
# in tests/pipelines/fake-slurm (issue 45): its sbatch runs each job script here in the
# background, sacct and squeue report the jobs' states, and it "kills" one chosen job as
# Slurm does at a time limit. Checks that every cluster rule submits (the report rule
# crashed on --time={resources.runtime} before), each with --parsable and a valid --time
# and --mem; that the killed bake is detected through cluster-status and retried once
# (before, snakemake waited forever: the run here is bounded); that the report is
# written. Then the same without Slurm accounting (sacct fails): the status falls back
# to squeue, and the killed job is still found (its output is missing) and retried. Last,
# a re-bake that fails on the cluster keeps the last good bundle and fails the report.
# Not tested here (no Slurm on the test machine): real sbatch option parsing, queueing,
# shared file-system latency, scancel. pipelines/batch/README.md says so too.
# Usage: snakemake_slurm_test.sh FISSURE_BAKE REPOSITORY_ROOT
set -euo pipefail
bake=$1 root=$2
here=$(cd "$(dirname "$0")" && pwd)
top=$(mktemp -d)
trap 'wait; rm -rf "$top"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

mkdir -p "$top/library" "$top/run"
cp "$root"/data/meshes/bunny-5k.obj "$root"/data/cages/bunny-5k-cage-10.* "$root"/data/cages/bunny-5k-cage-100.* "$top/library/"
cp "$top/library/bunny-5k.obj" "$top/library/prop.obj"
cat >"$top/library/assets.yaml" <<'YAML'
assets:
  hero: {mesh: bunny-5k.obj, cage: bunny-5k-cage-100.node, options: --skip collision}
  prop: {mesh: prop.obj, cage: bunny-5k-cage-10.node, options: --wall-res 16}
YAML

export PATH="$here/fake-slurm:$PATH" CI=true  # CI=true: snakemake polls every second, not 10
# kill_once NAME: the next run's fake Slurm (a fresh one) kills the bake of asset NAME once.
kill_once() {
  export FAKE_SLURM_DIR=$top/slurm-$1 FAKE_SLURM_KILL="bake-name=$1"
  mkdir -p "$FAKE_SLURM_DIR"
}
# One run through the profile; at most 300 s, so a job whose end goes unseen fails the
# test instead of hanging it.
run() {
  (cd "$top/run" && timeout -k 10 300 snakemake --snakefile "$root/pipelines/batch/Snakefile" \
    --profile "$root/pipelines/batch/profiles/slurm" --latency-wait 5 \
    --config manifest="$top/library/assets.yaml" bake="$bake" 2>&1)
}
# submitted RULE NAME: how many sbatch lines the fake Slurm got for that job.
submitted() { grep -c -- "--job-name=fissure-$1-${2:+name=$2}" "$FAKE_SLURM_DIR/submissions" || true; }

kill_once prop
out=$(run) || fail "the run through the Slurm profile failed (exit $?; 124 or 137: it hung on the killed job)"$'\n'"$out"
[ "$(submitted bake hero)" = 1 ] || fail "hero's bake was submitted $(submitted bake hero) times"$'\n'"$(cat "$FAKE_SLURM_DIR/submissions")"
[ "$(submitted bake prop)" = 2 ] || fail "prop's bake, killed once, was submitted $(submitted bake prop) times, not twice"
[ "$(submitted verify_report)" = 1 ] || fail "the report rule was not submitted: $(cat "$FAKE_SLURM_DIR/submissions")"
[ "$(submitted publish)" = 0 ] || fail "publish, a local rule, went to the cluster"
while read -r id arguments; do
  for flag in --parsable "--time=[0-9]+ " "--mem=[0-9]+ " "--cpus-per-task=[0-9]+ "; do
    [[ "$arguments " =~ $flag ]] || fail "job $id was submitted without $flag: $arguments"
  done
done <"$FAKE_SLURM_DIR/submissions"
killed=$(cat "$FAKE_SLURM_DIR/killed")
[ "$(cat "$FAKE_SLURM_DIR/$killed.state")" = TIMEOUT ] || fail "the fake Slurm did not kill job $killed"
grep -q "Error in rule bake:" <<<"$out" && grep -q "cluster_jobid: $killed;fake" <<<"$out" \
  || fail "the killed job $killed was not reported failed"$'\n'"$out"
grep -q "Trying to restart job" <<<"$out" || fail "the killed job was not restarted: $out"
report=$top/run/bundles/verify-report.xml
[ -f "$report" ] && grep -q 'failures="0" errors="0">' "$report" || fail "the report: $(head -3 "$report" 2>&1)"
"$bake" status "$top"/run/bundles/hero.h5 "$top"/run/bundles/prop.h5 >/dev/null || fail "status calls a bundle from the cluster stale"

# Without accounting: sacct fails, squeue no longer lists an ended job; the killed bake's
# output is missing, so snakemake still calls it failed and retries it.
rm -rf "$top/run/bundles"
kill_once hero
out=$(FAKE_SLURM_NO_ACCOUNTING=1 run) || fail "the run without accounting failed (exit $?)"$'\n'"$out"
[ "$(submitted bake hero)" = 2 ] || fail "without accounting, the killed bake was submitted $(submitted bake hero) times"$'\n'"$out"
grep -q "Trying to restart job" <<<"$out" || fail "without accounting, the killed job was not restarted: $out"
grep -q 'failures="0" errors="0">' "$report" || fail "the report without accounting: $(head -3 "$report")"
# A re-bake that fails on the cluster keeps the last good bundle and fails the report.
before=$(sha256sum <"$top/run/bundles/prop.h5")
echo "f 1 2 999999" >>"$top/library/prop.obj"
kill_once nothing
set +e
out=$(run)
rc=$?
set -e
[ "$rc" != 0 ] || fail "a broken asset did not fail the run on the cluster: $out"
[ "$rc" -lt 124 ] || fail "the run with a broken asset hung (exit $rc)"
[ "$before" = "$(sha256sum <"$top/run/bundles/prop.h5")" ] || fail "the failed re-bake on the cluster changed the last good bundle"
grep -q '<testcase classname="bundles/prop.h5" name="bake"><failure' "$report" \
  || fail "the report has no failing bake case after a failed bake on the cluster: $(cat "$report")"
echo "snakemake on the Slurm profile: all checks passed"

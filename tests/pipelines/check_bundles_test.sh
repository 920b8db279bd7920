#!/usr/bin/env bash
# pipelines/ci/check-bundles.sh (issue 45): the JUnit report and the exit status agree for
# every outcome a CI job meets: pass (0, no failure in the report), a budget over its
# limit (1), a stale bundle (3), a missing input (4) and an unreadable bundle (3). Before
# issue 45 a stale bundle was exit 3 with failures="0": a green CI page on a red job.
# Usage: check_bundles_test.sh FISSURE_BAKE REPOSITORY_ROOT
set -euo pipefail
bake=$1 root=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
mkdir -p "$work/assets" "$work/bundles"
cp "$root"/data/meshes/bunny-5k.obj "$work/assets/"
cp "$root"/data/cages/bunny-5k-cage-10.* "$work/assets/"
"$bake" -q -j 2 bake --mesh "$work/assets/bunny-5k.obj" --cage "$work/assets/bunny-5k-cage-10.node" \
  -o "$work/bundles/a.h5" --skip collision >/dev/null
cp "$work/bundles/a.h5" "$work/bundles/b.h5"

# check EXPECTED_EXIT WHAT [VAR=VALUE...]: runs the check on both bundles and compares
# its exit status and the report's failures + errors with what is expected.
check() {
  local expected=$1 what=$2 rc out bad
  shift 2
  rm -f "$work/report.xml"
  set +e
  out=$(env FISSURE_BAKE="$bake" "$@" bash "$root/pipelines/ci/check-bundles.sh" "$work/report.xml" "$work"/bundles/*.h5 2>&1)
  rc=$?
  set -e
  [ "$rc" = "$expected" ] || fail "$what: exit $rc, not $expected"$'\n'"$out"
  [ -f "$work/report.xml" ] || fail "$what: no report"
  bad=$(python3 -c 'import sys, xml.etree.ElementTree as E; r = E.parse(sys.argv[1]).getroot(); print(int(r.get("failures")) + int(r.get("errors")))' "$work/report.xml")
  if [ "$expected" = 0 ]; then
    [ "$bad" = 0 ] || fail "$what: exit 0 but the report counts $bad failures"$'\n'"$(cat "$work/report.xml")"
  else
    [ "$bad" -gt 0 ] || fail "$what: exit $rc but the report is green"$'\n'"$(cat "$work/report.xml")"
  fi
  echo "$out"
}

check 0 "fresh bundles" >/dev/null
out=$(check 1 "a budget over its limit" FISSURE_MAX_TILES=1)
grep -q "a.h5: over budget" <<<"$out" || fail "the budget failure is not named: $out"
grep -q 'name="budget:tiles">' "$work/report.xml" || fail "the budget is not in the report"

echo "# edited" >>"$work/assets/bunny-5k-cage-10.ele"
check 3 "a stale bundle" >/dev/null
grep -q 'name="status">' "$work/report.xml" || fail "the stale bundle has no status case"
mv "$work/assets/bunny-5k.obj" "$work/assets/moved.obj"
out=$(check 4 "a missing input")
grep -q "pass --mesh and --cage" <<<"$out" || fail "a missing input does not say how to point at it: $out"
mv "$work/assets/moved.obj" "$work/assets/bunny-5k.obj"
sed -i '$d' "$work/assets/bunny-5k-cage-10.ele"  # the cage as baked again

check 0 "fresh bundles again" >/dev/null
echo "not a bundle" >"$work/bundles/b.h5"
check 3 "an unreadable bundle" >/dev/null
grep -q 'name="read">' "$work/report.xml" || fail "the unreadable bundle is not in the report"
echo "check-bundles: the report and the exit status agree for every outcome"

#!/usr/bin/env bash
# The CI check for a project's bundles: are they up to date with their inputs, do they
# hold every invariant, and do they fit the project's budgets? Writes a JUnit report
# for the CI's test page, which fails whenever the exit status does. Exit 0 all good; 1 a
# check or budget failed; 3 a bundle is stale (re-bake and commit it) or unreadable; 4 an
# input of one is missing.
#
# Usage: check-bundles.sh REPORT.xml BUNDLE... (budgets from the environment:
#   FISSURE_MAX_INSTANCES_PER_TRIANGLE, FISSURE_MAX_SIZE_MIB, FISSURE_MAX_SPHERES,
#   FISSURE_MAX_TILES; FISSURE_BAKE: the tool, default fissure-bake on the PATH)
set -uo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 REPORT.xml BUNDLE..." >&2
  exit 1
fi
bake=${FISSURE_BAKE:-fissure-bake}
report=$1
shift

budgets=()
[ -n "${FISSURE_MAX_INSTANCES_PER_TRIANGLE:-}" ] && budgets+=(--max-instances-per-triangle "$FISSURE_MAX_INSTANCES_PER_TRIANGLE")
[ -n "${FISSURE_MAX_SIZE_MIB:-}" ] && budgets+=(--max-size-mib "$FISSURE_MAX_SIZE_MIB")
[ -n "${FISSURE_MAX_SPHERES:-}" ] && budgets+=(--max-spheres "$FISSURE_MAX_SPHERES")
[ -n "${FISSURE_MAX_TILES:-}" ] && budgets+=(--max-tiles "$FISSURE_MAX_TILES")

# Invariants, budgets and freshness (--status: one "status" case per bundle) into the
# report, so the CI page fails exactly when this job does; then status for the exit code.
"$bake" -q verify --status "$@" "${budgets[@]}" --junit "$report"
verify=$?
"$bake" status "$@"
status=$?
if [ "$status" -ne 0 ]; then exit "$status"; fi
exit "$verify"

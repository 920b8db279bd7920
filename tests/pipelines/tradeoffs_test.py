#!/usr/bin/env python3
"""pipelines/tradeoffs (issue 18): the reduced sweep CI runs, so the scripts cannot rot.

Runs `tradeoffs.py --quick` into a temporary folder and checks what the figures must
show whatever the machine: the trends each knob is known for (first-order convergence in
dt and wall resolution, replication growing with tets, the exact model never ending
above its start), every plot written as a PNG, and that a failed sweep leaves the files
of the last good run as they were. No timing is asserted: the machine is shared.

usage: tradeoffs_test.py BUILD_DIR REPOSITORY_ROOT
"""

import csv
import subprocess
import sys
import tempfile
from pathlib import Path

failures = []


def check(condition: bool, what: str) -> None:
    if not condition:
        failures.append(what)
        print(f"FAIL: {what}", file=sys.stderr)


def rows(folder: Path, name: str) -> list:
    with open(folder / name, newline="") as f:
        return list(csv.DictReader(f))


def values(rs: list, key: str) -> list:
    return [float(r[key]) for r in rs]


def check_walls(out: Path) -> None:
    walls = sorted(rows(out, "walls.csv"), key=lambda r: float(r["resolution"]))
    check(len(walls) == 3, f"the quick sweep bakes walls at 3 resolutions, not {len(walls)}")
    errors = values(walls, "coverage_error")
    check(len(walls) >= 2 and all(a > b for a, b in zip(errors, errors[1:])),
          f"coverage error falls as the wall resolution grows: {errors}")
    # About one texel row along each region boundary: first order in the texel size.
    res = values(walls, "resolution")
    order = (errors[0] / errors[-1]) / (res[-1] / res[0])
    check(0.7 < order < 1.4, f"coverage error is first order in the texel size (ratio to first order {order:.2f})")
    check(len({r["tiles"] for r in walls}) == 1, "the resolution changes the tiles' texels, not their number")


def check_spheres(out: Path) -> None:
    bake = {float(r["radius_over_default"]): r for r in rows(out, "spheres-bake.csv")}
    check(sorted(bake) == [0.5, 1.0], f"the quick sweep bakes spheres at 0.5 and 1 times the default: {sorted(bake)}")
    check(float(bake[0.5]["max_gap_over_default"]) < float(bake[1.0]["max_gap_over_default"]),
          "smaller spheres leave a smaller worst gap to the surface")
    player = rows(out, "contacts.csv")
    check(len(player) == 3, f"two sphere radii and the exact mode are played, not {len(player)} runs")
    check([r["collision_points"] for r in player].count("vertices") == 1, "one exact (every-vertex) reference run")
    check(all(r["stopped"] == "0" for r in player), "no contacts run passed its time limit")
    for r in player:
        if r["collision_points"] == "spheres":
            check(float(r["sphere_radius_median_m"]) <= float(r["target_radius_m"]) * (1 + 1e-3),
                  f"the bake's spheres are no larger than the target radius: {r}")


def check_draw(out: Path) -> None:
    draw = rows(out, "draw.csv")
    check(len(draw) == 4, f"the quick draw sweep has 4 rows (3 cages, 2 meshes in one), not {len(draw)}")
    five_k = sorted((r for r in draw if r["triangles"] == "5000"), key=lambda r: float(r["tets"]))
    per_triangle = [float(r["instances"]) / 5000 for r in five_k]
    check(len(five_k) >= 3 and all(a < b for a, b in zip(per_triangle, per_triangle[1:])),
          f"replication grows with the cage's tets: {per_triangle}")
    check(all(p >= 1 for p in per_triangle), "every triangle is drawn at least once")
    by_tets = {}
    for r in draw:
        by_tets.setdefault(r["tets"], set()).add(r["upload_bytes_per_frame"])
    check(all(len(u) == 1 for u in by_tets.values()), "uploads per frame depend on the cage only, not the triangles")


def check_solver(out: Path) -> None:
    dt = rows(out, "dt.csv")
    check(len(dt) == 12, f"3 rates × 2 models × 2 cases, not {len(dt)} rows")
    for case in ("beam", "bunny"):
        for model in ("warped", "exact"):
            rs = sorted((r for r in dt if r["case"] == case and r["stiffness"] == model), key=lambda r: -float(r["dt_s"]))
            errors = values(rs, "rms_error_relative")
            check(all(a > b for a, b in zip(errors, errors[1:])), f"{case}, {model}: error falls with dt: {errors}")
            check(all(r["failed_steps"] == "0" for r in rs), f"{case}, {model}: no step failed")
    beam = sorted((r for r in dt if r["case"] == "beam" and r["stiffness"] == "warped"), key=lambda r: float(r["dt_s"]))
    order = (float(beam[-1]["rms_error_relative"]) / float(beam[0]["rms_error_relative"])) / \
            (float(beam[-1]["dt_s"]) / float(beam[0]["dt_s"]))
    check(0.6 < order < 1.4, f"backward Euler is first order on the beam (ratio to first order {order:.2f})")
    tolerance = rows(out, "tolerance.csv")
    check(len(tolerance) == 10, f"(direct + 2 tolerances × 2 preconditioners) × 2 cases, not {len(tolerance)} rows")
    for case in ("beam", "bunny"):
        for solver in ("cg-jacobi", "cg-lagged-cholesky"):
            rs = sorted((r for r in tolerance if r["case"] == case and r["solver"] == solver),
                        key=lambda r: -float(r["tolerance"]))
            errors = values(rs, "error_vs_direct")
            check(errors[-1] < errors[0] / 100, f"{case}, {solver}: a tighter tolerance comes closer to the direct solve")
    spin = rows(out, "spin.csv")
    check(len(spin) == 4, f"2 steps × 2 models on the spinning beam, not {len(spin)} rows")
    for r in spin:
        if r["stiffness"] == "exact":
            check(float(r["final_energy_ratio"]) <= 1.0, f"the exact model ends below its start: {r}")


def check_cage_method(out: Path) -> None:
    """Issue 43: the automatic cages' replication is at most 1.2 times the hand-made cage's
    of the same count; every cage that was made was played."""
    table = {(r["method"], r["tets_asked"]): r for r in rows(out, "cage-method.csv")}
    check(sorted(table) == sorted((m, n) for m in ("hand-made", "lattice", "wrap") for n in ("51", "987")),
          f"the quick sweep has 3 methods at 51 and 987 tets: {sorted(table)}")
    for (method, asked), r in table.items():
        if method == "lattice":
            check(not r["failed"], f"the lattice reaches every count: {r}")
        if r["failed"]:
            continue
        check(abs(int(r["tets"]) / int(asked) - 1) <= 0.15, f"{method} lands within ±15 % of {asked}: {r['tets']}")
        check(float(r["step_ms_mean"]) > 0, f"the {method} cage of {asked} tets was played: {r}")
        hand = float(table[("hand-made", asked)]["instances_per_triangle"])
        check(float(r["instances_per_triangle"]) <= 1.2 * hand,
              f"{method} at {asked} tets: replication {r['instances_per_triangle']} within 1.2 × {hand}")


def check_debris(out: Path) -> None:
    """Record 0072: with sweeps, the sequential impulses answer the shattered bunny's debris;
    at 0, the augmented Lagrangian answers everything; both keep the energy bound."""
    table = {int(r["contact_sweeps"]): r for r in rows(out, "debris.csv")}
    check(sorted(table) == [0, 16], f"the quick sweep plays contact_sweeps 0 and 16: {sorted(table)}")
    check(all(r["stopped"] == "0" for r in table.values()), "no debris run passed its time limit")
    check(float(table[0]["sweeps_per_step"]) == 0, f"contact_sweeps = 0 runs no sweep: {table[0]}")
    check(float(table[16]["sweeps_per_step"]) > 0, f"contact_sweeps = 16 answers some debris by sweeps: {table[16]}")
    for r in table.values():
        check(int(r["fragments"]) >= 100, f"toughness 0 shatters the bunny into hundreds of fragments: {r}")
        check(float(r["energy_peak_over_given"]) <= 1.01, f"energy stays within what was given +1 %: {r}")


def check_rigid(out: Path) -> None:
    """Record 0073: at the default speed the resting bunny is answered rigidly, at 0 never;
    every run keeps the energy bound."""
    table = {(r["scene"], float(r["rigid_resting_speed"])): r for r in rows(out, "rigid.csv")}
    check(sorted(table) == [("as shipped", 0.0), ("as shipped", 0.2), ("fracture off", 0.0), ("fracture off", 0.2)],
          f"the quick sweep plays speeds 0 and 0.2 on both scenes: {sorted(table)}")
    check(all(r["stopped"] == "0" for r in table.values()), "no rigid run passed its time limit")
    for scene in ("as shipped", "fracture off"):
        check(float(table[(scene, 0.0)]["rigid_answers_per_step"]) == 0, f"speed 0 answers nothing rigidly: {scene}")
        check(float(table[(scene, 0.2)]["rigid_answers_per_step"]) > 0.5,
              f"speed 0.2 answers the resting bunny rigidly in most steps: {table[(scene, 0.2)]}")
    for r in table.values():
        check(float(r["energy_peak_over_given"]) <= 1.01, f"energy stays within what was given +1 %: {r}")


def check_plots(out: Path) -> None:
    for name in ("walls", "contacts", "cages", "triangles", "dt", "tolerance", "spin", "cage-method", "debris", "rigid"):
        png = out / f"{name}.png"
        check(png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000,
              f"{name}.png is a plot")
    check(not list(out.glob(".staging-*")), "no staging folder is left")


def check_failure_keeps_files(script: Path, build: Path, out: Path) -> None:
    """A sweep that fails, before or while it runs, leaves every CSV file and plot as the
    last good run left them; one that fails while running also leaves its log."""
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    run = subprocess.run([sys.executable, str(script), "--only", "bake", "--out", str(out), "--build",
                          str(out / "no-build-here")], capture_output=True, text=True)
    check(run.returncode == 1 and "is not built" in run.stderr, f"a missing build is named: {run.stderr!r}")
    check(before == {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()},
          "a sweep that cannot start changes nothing")

    # A build whose draw benchmark fails halfway: the solver sweep, run first, succeeds,
    # but nothing of the run may be published.
    broken = out.parent / "broken-build"
    (broken / "tests" / "bench").mkdir(parents=True)
    (broken / "tests" / "bench" / "fissure_tradeoff_sweep").symlink_to(build / "tests" / "bench" / "fissure_tradeoff_sweep")
    stub = broken / "tests" / "bench" / "fissure_render_bench"
    stub.write_text("#!/bin/sh\necho 'error: the GL context went away' >&2\nexit 3\n")
    stub.chmod(0o755)
    run = subprocess.run([sys.executable, str(script), "--quick", "--only", "solver,draw", "--out", str(out),
                          "--build", str(broken)], capture_output=True, text=True)
    check(run.returncode == 1 and "the draw sweep failed" in run.stderr and "exited with 3" in run.stderr,
          f"a failing sweep is named with its exit status: {run.stderr!r}")
    log = out / "draw.failed.log"
    check(log.is_file() and "the GL context went away" in log.read_text(), "the failed sweep's log is kept")
    log.unlink(missing_ok=True)
    check(before == {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()},
          "a run with a failed sweep publishes nothing, not even the sweeps that succeeded")
    check(not list(out.glob(".staging-*")), "no staging folder is left after a failure")

    run = subprocess.run([sys.executable, str(script), "--only", "bakes"], capture_output=True, text=True)
    check(run.returncode == 2 and "unknown sweep bakes" in run.stderr, f"an unknown sweep is named: {run.stderr!r}")


def main() -> int:
    build, repo = Path(sys.argv[1]), Path(sys.argv[2])
    script = repo / "pipelines" / "tradeoffs" / "tradeoffs.py"
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "tradeoffs"
        run = subprocess.run([sys.executable, str(script), "--quick", "--out", str(out), "--build", str(build)],
                             capture_output=True, text=True)
        print(run.stdout)
        if run.returncode != 0:
            print(f"FAIL: tradeoffs.py --quick exited with {run.returncode}\n{run.stderr}", file=sys.stderr)
            return 1
        for checks in (check_walls, check_spheres, check_draw, check_solver, check_cage_method, check_debris,
                       check_rigid, check_plots):
            try:
                checks(out)
            except (OSError, KeyError, IndexError, ValueError) as e:  # a missing file or column: report, go on
                check(False, f"{checks.__name__}: {type(e).__name__}: {e}")
        check_failure_keeps_files(script, build, out)
    print(f"{len(failures)} failure(s)" if failures else "all trade-study checks hold")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

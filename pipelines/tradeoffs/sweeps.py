"""The measurements of the trade-study: each sweep runs Fissure's programs and leaves CSV
files (and the programs' own Markdown tables) in a folder. Plotting is plots.py's job.

Six sweeps, each named by what it varies:
  bake      wall resolution and bake-side sphere radius (tests/bench/fissure_stage2_sweep)
  draw      cage tet count and triangle count against replication, step and draw time
            (tests/bench/fissure_render_bench)
  solver    dt, CG tolerance, exact against warped stiffness (tests/bench/fissure_tradeoff_sweep)
  contacts  sphere radius in the player against the exact every-vertex mode (fissure-bake
            and fissure-player, through their command lines)
  cage-method  the cage: hand-made (data/cages) against automatic (`fissure-bake cage
            --method lattice|wrap`) at the same counts: replication and the physics step
  debris    the contact response's sequential-impulse sweeps (`solver.contact_sweeps`) on
            the bunny shattered into hundreds of fragments: collision time against sinking
  rigid     large fragments at rest answered as rigid bodies (`solver.rigid_resting_speed`,
            0 = every answer deformable): the step against the deepest render vertex and
            the sag a rigid answer does not make, on the sample with and without fracture
"""

import csv
import json
import re
import shutil
import statistics
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path


class SweepError(Exception):
    """A sweep could not finish; the message says which program failed and where its log is."""


@dataclass(frozen=True)
class Tools:
    """Where the programs are: a build folder (release preset) and the repository."""

    build: Path
    repo: Path

    def bench(self, name: str) -> Path:
        return self.build / "tests" / "bench" / name

    @property
    def bake(self) -> Path:
        return self.build / "bake" / "fissure-bake"

    @property
    def player(self) -> Path:
        return self.build / "player" / "app" / "fissure-player"

    def missing(self, sweep: str) -> list:
        """What `sweep` needs and cannot find: a program not built, or h5dump."""
        needs = {
            "bake": [self.bench("fissure_stage2_sweep")],
            "draw": [self.bench("fissure_render_bench")],
            "solver": [self.bench("fissure_tradeoff_sweep")],
            "contacts": [self.bake, self.player],
            "cage-method": [self.bake, self.player],
            "debris": [self.bake, self.player],
            "rigid": [self.bake, self.player],
        }[sweep]
        missing = [f"{p} is not built" for p in needs if not p.is_file()]
        if sweep == "contacts" and shutil.which("h5dump") is None:
            missing.append("h5dump is not installed (hdf5-tools)")
        return missing


def run_logged(command: list, stdout: Path, log: Path, timeout: float = 1800) -> None:
    """Runs `command` with stdout to `stdout` and stderr to `log` (appended, after the
    command line); SweepError if it fails or passes `timeout` seconds."""
    with open(stdout, "w") as out, open(log, "a") as err:
        err.write("$ " + " ".join(str(c) for c in command) + "\n")
        err.flush()
        try:
            status = subprocess.run([str(c) for c in command], stdout=out, stderr=err, timeout=timeout).returncode
        except subprocess.TimeoutExpired:
            raise SweepError(f"{Path(command[0]).name} ran past {timeout:.0f} s")
    if status != 0:
        raise SweepError(f"{Path(command[0]).name} exited with {status}")


# --- bake, draw, solver: the benchmark programs write their own CSV files -------------

# The cages of data/cages, bunny-5k-cage-N: N = 10 … 100 are near the thesis's Table II sizes.
# (987 and 10,024 are drawn with every mesh as well; see bench_arguments.)
FULL_CAGES = "10,20,29,38,51,58,68,80,89,100"


def bench_arguments(sweep: str, quick: bool, repo: Path) -> tuple:
    """(program, arguments) of a benchmark sweep, full or quick (the CI's reduced sweep)."""
    if sweep == "bake":
        return "fissure_stage2_sweep", ["--quick"] if quick else []
    if sweep == "draw":
        if quick:
            return "fissure_render_bench", ["--size", "480x270", "--frames", "3", "--subdivisions", "1",
                                            "--cage-sweep", "10,100", "--no-tessellation"]
        # --shared names the folder holding cages/bunny-5k-cage-10024: with it, the 10,024-tet
        # cage is drawn with every mesh too (Fig. 22 at two cage sizes).
        return "fissure_render_bench", ["--frames", "10", "--subdivisions", "2", "--shared", repo / "data",
                                        "--cage-sweep", FULL_CAGES, "--no-tessellation"]
    if sweep == "solver":
        # One thread, so the costs per simulated second compare across machines.
        return "fissure_tradeoff_sweep", ["--threads", "1"] + (["--quick"] if quick else [])
    raise ValueError(sweep)


def run_bench(tools: Tools, sweep: str, quick: bool, staging: Path) -> None:
    program, arguments = bench_arguments(sweep, quick, tools.repo)
    run_logged([tools.bench(program), *arguments, "--csv", staging], staging / f"{sweep}.md", staging / f"{sweep}.log")


# --- contacts: sphere radius in the player --------------------------------------------

MESH = "data/meshes/bunny-5k.obj"
CAGE = "data/cages/bunny-5k-cage-987.node"
BASE_SCENE = "data/scenes/bunny-drop.toml"


@dataclass(frozen=True)
class ContactPlan:
    radius_factors: tuple  # multiples of the bake's default radius
    steps: int             # bunny-drop's ball is launched at step 120 and hits at about 132
    time_limit_s: float    # a run past this is recorded as stopped, not measured


FULL_CONTACTS = ContactPlan((0.25, 0.5, 1.0, 2.0, 4.0), 480, 180.0)
QUICK_CONTACTS = ContactPlan((0.5, 1.0), 150, 120.0)


def scene_with(base: str, bundle: str, collision_mode: str) -> str:
    """bunny-drop.toml with its one bundle replaced and these [features]: the collision mode
    under test, fracture off (every run keeps the same topology, so only the collision
    points differ) and one thread (collision times compare across runs)."""
    if len(re.findall(r"^\s*bundle\s*=", base, flags=re.M)) != 1:
        raise SweepError(f"{BASE_SCENE} must name exactly one bundle for the contacts sweep")
    scene = re.sub(r"^(\s*bundle\s*=).*$", rf'\1 "{bundle}"', base, flags=re.M)
    features = {"collision_mode": f'"{collision_mode}"', "fracture": "false"}
    for key, value in features.items():
        if re.search(rf"^\s*{key}\s*=", scene, flags=re.M):
            scene = re.sub(rf"^(\s*{key}\s*=).*$", rf"\1 {value}", scene, flags=re.M)
        else:
            scene = re.sub(r"^\[features\].*$", lambda m: f"{m.group(0)}\n{key} = {value}", scene, count=1, flags=re.M)
    return scene


def output_of(command: list) -> str:
    """The standard output of `command`; SweepError naming it if it fails."""
    run = subprocess.run([str(c) for c in command], capture_output=True, text=True)
    if run.returncode != 0:
        raise SweepError(f"'{' '.join(str(c) for c in command)}' exited with {run.returncode}: {run.stderr.strip()}")
    return run.stdout


def default_radius(tools: Tools, bundle: Path) -> float:
    """The radius the bake picks without --sphere-radius (a fifth of the cage's median edge)."""
    text = output_of([tools.bake, "inspect", bundle])
    match = re.search(r"target radius ([0-9.eE+-]+)\)", text)
    if not match:
        raise SweepError(f"could not read the target radius from 'fissure-bake inspect {bundle}'")
    return float(match.group(1))


def sphere_radii(bundle: Path) -> list:
    """The radii the bake chose (it halves a tet's radius until the tet holds 3 spheres, so
    the target is only an upper bound), read with h5dump (hdf5-tools)."""
    text = output_of(["h5dump", "-y", "-w", "0", "-d", "/collision/sphere_radius", bundle])
    match = re.search(r"DATA \{([^}]*)\}", text)
    if not match:
        raise SweepError(f"no sphere radii in h5dump's output for {bundle}")
    return [float(x) for x in match.group(1).replace(",", " ").split()]


def bake_bundle(tools: Tools, bundle: Path, log: Path, radius: float = None) -> None:
    command = [tools.bake, "-q", "bake", "--mesh", tools.repo / MESH, "--cage", tools.repo / CAGE, "-o", bundle,
               "--skip", "walls"]  # the player needs no walls without rendering
    if radius is not None:
        command += ["--sphere-radius", f"{radius:.6g}"]
    run_logged(command, log.with_suffix(".out"), log)


def play(tools: Tools, scene: Path, report: Path, plan: ContactPlan, log: Path) -> dict:
    """The run's JSON report, or None when it passed the time limit."""
    try:
        run_logged([tools.player, "-q", "run", scene, "--no-render", "--steps", str(plan.steps), "-j", "1",
                    "--report", report], log.with_suffix(".out"), log, timeout=plan.time_limit_s)
    except SweepError as e:
        if "ran past" in str(e):
            return None
        raise
    try:
        return json.loads(report.read_text())
    except (OSError, ValueError) as e:
        raise SweepError(f"could not read the player's report {report.name}: {e}")


def write_csv(path: Path, columns: list, rows: list) -> None:
    """One sweep's rows as a CSV file with a header."""
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, columns)
        writer.writeheader()
        writer.writerows(rows)


CONTACT_COLUMNS = ["collision_points", "radius_over_default", "target_radius_m", "spheres", "sphere_radius_median_m",
                   "vertex_penetration_max_m", "sphere_penetration_max_m", "collisions_ms_mean", "step_ms_mean",
                   "contacts", "stopped"]


def contact_row(mode: str, factor, target: float, radii: list, report: dict) -> dict:
    row = {"collision_points": mode, "radius_over_default": factor, "target_radius_m": target,
           "spheres": len(radii), "sphere_radius_median_m": statistics.median(radii) if radii else "",
           "stopped": int(report is None)}
    if report is not None:
        try:
            summary, timings = report["summary"], report["timings"]
            row.update(vertex_penetration_max_m=summary["vertex_penetration_max_m"],
                       sphere_penetration_max_m=summary["sphere_penetration_max_m"],
                       collisions_ms_mean=timings["collisions"]["mean_ms"], step_ms_mean=timings["step"]["mean_ms"],
                       contacts=summary["contacts"])
        except KeyError as e:
            raise SweepError(f"the player's report has no {e} (run it with diagnostics on)")
    return row


def player_sweep_start(tools: Tools, staging: Path, sweep: str) -> tuple:
    """What a sweep that plays bunny-drop starts from: its scratch folder (made), its log
    and the base scene's text."""
    work = staging / f"{sweep}-work"
    work.mkdir()
    return work, staging / f"{sweep}.log", (tools.repo / BASE_SCENE).read_text()


def run_contacts(tools: Tools, quick: bool, staging: Path) -> None:
    plan = QUICK_CONTACTS if quick else FULL_CONTACTS
    work, log, base = player_sweep_start(tools, staging, "contacts")
    bake_bundle(tools, work / "default.h5", log)
    radius = default_radius(tools, work / "default.h5")
    rows = []
    for factor in plan.radius_factors:
        bundle = "default.h5" if factor == 1.0 else f"r{factor}x.h5"
        if factor != 1.0:
            bake_bundle(tools, work / bundle, log, factor * radius)
        scene = work / f"spheres-{factor}x.toml"
        scene.write_text(scene_with(base, bundle, "spheres"))
        print(f"    spheres at {factor}× the default radius ({plan.steps} steps)", flush=True)
        report = play(tools, scene, work / f"spheres-{factor}x.json", plan, log)
        rows.append(contact_row("spheres", factor, factor * radius, sphere_radii(work / bundle), report))
    # The exact mode collides every render vertex and never reads the spheres: one run is
    # the reference for every radius.
    scene = work / "vertices.toml"
    scene.write_text(scene_with(base, "default.h5", "vertices"))
    print(f"    every render vertex, the exact mode ({plan.steps} steps)", flush=True)
    rows.append(contact_row("vertices", "", "", [], play(tools, scene, work / "vertices.json", plan, log)))
    write_csv(staging / "contacts.csv", CONTACT_COLUMNS, rows)


# --- cage-method: automatic cages against the hand-made ones ---------------------------

@dataclass(frozen=True)
class CagePlan:
    counts: tuple        # tets asked: the counts of data/cages/bunny-5k-cage-N, so each has its hand-made twin
    steps: int           # of bunny-drop, fracture off, as the contacts sweep plays it
    time_limit_s: float


FULL_CAGE_METHODS = CagePlan((51, 100, 987, 10024), 240, 300.0)
QUICK_CAGE_METHODS = CagePlan((51, 987), 60, 120.0)
CAGE_METHODS = ("hand-made", "lattice", "wrap")
CAGE_METHOD_COLUMNS = ["method", "tets_asked", "tets", "instances_per_triangle", "cage_s", "step_ms_mean", "failed"]


def make_cage(tools: Tools, method: str, tets: int, work: Path, log: Path) -> tuple:
    """(cage file, seconds to make it, None) or (None, None, the error's first line): a
    count the method cannot reach (the wrap at 100 tets on the bunny) is a finding."""
    if method == "hand-made":
        return tools.repo / f"data/cages/bunny-5k-cage-{tets}.node", None, None
    cage = work / f"{method}-{tets}.node"
    # From the repository, the mesh named relative to it: the error recorded names no machine's path.
    command = [tools.bake, "-q", "cage", "--mesh", MESH, "--tets", str(tets), "--method", method, "-o", cage]
    start = time.monotonic()
    run = subprocess.run([str(c) for c in command], capture_output=True, text=True, cwd=tools.repo)
    seconds = time.monotonic() - start
    with open(log, "a") as f:
        f.write("$ " + " ".join(str(c) for c in command) + "\n" + run.stderr)
    if run.returncode == 1:
        errors = [line.removeprefix("error: ") for line in run.stderr.splitlines() if line.startswith("error: ")]
        return None, None, (errors or ["exit 1"])[0]
    if run.returncode != 0:
        raise SweepError(f"fissure-bake cage --method {method} --tets {tets} exited with {run.returncode}")
    return cage, seconds, None


def replication(tools: Tools, cages: list) -> dict:
    """(tets, instances per triangle) of each cage file (by name), in one `fissure-bake replication`."""
    rows = json.loads(output_of([tools.bake, "replication", tools.repo / MESH, "--json", "--cages", *cages]))
    return {r["cage"]: (r["tets"], r["instances"] / sum(r["counts"])) for r in rows}


def run_cage_methods(tools: Tools, quick: bool, staging: Path) -> None:
    plan = QUICK_CAGE_METHODS if quick else FULL_CAGE_METHODS
    work, log, base = player_sweep_start(tools, staging, "cage-method")
    rows, cages = [], []
    for tets in plan.counts:
        for method in CAGE_METHODS:
            cage, seconds, failed = make_cage(tools, method, tets, work, log)
            rows.append({"method": method, "tets_asked": tets, "cage_s": "" if seconds is None else f"{seconds:.3f}",
                         "failed": failed or "", "cage": cage})
            if cage is not None:
                cages.append(cage)
    replicated = replication(tools, cages)
    for row in rows:
        cage = row.pop("cage")
        if cage is None:
            continue
        bundle = work / f"{row['method']}-{row['tets_asked']}.h5"
        run_logged([tools.bake, "-q", "bake", "--mesh", tools.repo / MESH, "--cage", cage, "-o", bundle,
                    "--skip", "walls"], log.with_suffix(".out"), log)
        scene = bundle.with_suffix(".toml")
        scene.write_text(scene_with(base, bundle.name, "spheres"))
        print(f"    {row['method']} cage, {row['tets_asked']} tets asked ({plan.steps} steps)", flush=True)
        report = play(tools, scene, bundle.with_suffix(".json"), ContactPlan((), plan.steps, plan.time_limit_s), log)
        tets, per_triangle = replicated[cage.name]
        row.update(tets=tets, instances_per_triangle=f"{per_triangle:.4f}",
                   step_ms_mean="" if report is None else report["timings"]["step"]["mean_ms"])
    write_csv(staging / "cage-method.csv", CAGE_METHOD_COLUMNS, rows)


# --- debris: sequential impulses against the augmented Lagrangian ---------------------

@dataclass(frozen=True)
class DebrisPlan:
    sweeps: tuple        # solver.contact_sweeps; 0 answers every contact by the augmented Lagrangian
    steps: int           # the bunny lands at about step 24 and is hundreds of fragments by step 40
    time_limit_s: float


FULL_DEBRIS = DebrisPlan((0, 2, 4, 8, 16, 32, 64), 240, 300.0)
QUICK_DEBRIS = DebrisPlan((0, 16), 60, 120.0)
DEBRIS_COLUMNS = ["contact_sweeps", "fragments", "step_ms_mean", "step_ms_p99", "step_ms_max", "collisions_ms_mean",
                  "sweeps_per_step", "cg_per_step", "sphere_penetration_max_m", "sphere_penetration_final_m",
                  "vertex_penetration_max_m", "energy_peak_over_given", "stopped"]


def debris_scene(base: str, bundle: str, sweeps: int) -> str:
    """bunny-drop.toml with its bundle replaced, toughness 0 (the bunny shatters on landing)
    and `solver.contact_sweeps` set."""
    scene = re.sub(r"^(\s*bundle\s*=).*$", rf'\1 "{bundle}"', base, count=1, flags=re.M)
    scene, toughened = re.subn(r"^(\s*toughness\s*=).*$", r"\1 0.0", scene, count=1, flags=re.M)
    scene, solver = re.subn(r"^\[solver\].*$", lambda m: f"{m.group(0)}\ncontact_sweeps = {sweeps}", scene, count=1,
                            flags=re.M)
    if not (toughened and solver):
        raise SweepError(f"{BASE_SCENE} must have a [solver] table and a material toughness for the debris sweep")
    return scene


def debris_row(sweeps: int, report: dict) -> dict:
    row = {"contact_sweeps": sweeps, "stopped": int(report is None)}
    if report is None:
        return row
    try:
        summary, timings, steps = report["summary"], report["timings"], report["steps"]
        given = summary["energy_initial_J"] + summary["energy_put_in_J"]
        row.update(fragments=summary["fragments"], step_ms_mean=timings["step"]["mean_ms"],
                   step_ms_p99=timings["step"]["p99_ms"], step_ms_max=timings["step"]["max_ms"],
                   collisions_ms_mean=timings["collisions"]["mean_ms"],
                   sweeps_per_step=summary["contact_response_sweeps"] / steps,
                   cg_per_step=summary["contact_response_iterations"] / steps,
                   sphere_penetration_max_m=summary["sphere_penetration_max_m"],
                   sphere_penetration_final_m=summary["sphere_penetration_final_m"],
                   vertex_penetration_max_m=summary["vertex_penetration_max_m"],
                   energy_peak_over_given=summary["energy_max_J"] / given)
    except KeyError as e:
        raise SweepError(f"the player's report has no {e} (run it with diagnostics on)")
    return row


def run_debris(tools: Tools, quick: bool, staging: Path) -> None:
    plan = QUICK_DEBRIS if quick else FULL_DEBRIS
    work, log, base = player_sweep_start(tools, staging, "debris")
    bake_bundle(tools, work / "bunny.h5", log)
    rows = []
    for sweeps in plan.sweeps:
        scene = work / f"sweeps-{sweeps}.toml"
        scene.write_text(debris_scene(base, "bunny.h5", sweeps))
        print(f"    contact_sweeps = {sweeps}, toughness 0 ({plan.steps} steps)", flush=True)
        report = play(tools, scene, work / f"sweeps-{sweeps}.json", ContactPlan((), plan.steps, plan.time_limit_s), log)
        rows.append(debris_row(sweeps, report))
    write_csv(staging / "debris.csv", DEBRIS_COLUMNS, rows)


# --- rigid: large fragments at rest as rigid bodies against all deformable -------------

@dataclass(frozen=True)
class RigidPlan:
    speeds: tuple        # solver.rigid_resting_speed [m/s]; 0 answers every contact deformably
    steps: int           # the bunny lands at about step 24; the ball hits at about 132
    time_limit_s: float


FULL_RIGID = RigidPlan((0.0, 0.05, 0.1, 0.2, 0.5, 1.0), 480, 300.0)
QUICK_RIGID = RigidPlan((0.0, 0.2), 150, 120.0)
RIGID_SCENES = {"fracture off": "false", "as shipped": "true"}  # name: [features] fracture
RIGID_COLUMNS = ["scene", "rigid_resting_speed", "fragments", "rigid_answers_per_step", "step_ms_mean", "step_ms_p99",
                 "collisions_ms_mean", "vertex_penetration_max_m", "sphere_penetration_max_m", "elastic_final_J",
                 "energy_peak_over_given", "stopped"]


def rigid_scene(base: str, bundle: str, fracture: str, speed: float) -> str:
    """bunny-drop.toml with its bundle replaced, fracture on or off and
    `solver.rigid_resting_speed` set."""
    scene = re.sub(r"^(\s*bundle\s*=).*$", rf'\1 "{bundle}"', base, count=1, flags=re.M)
    scene, fractured = re.subn(r"^(\s*fracture\s*=).*$", rf"\1 {fracture}", scene, count=1, flags=re.M)
    scene, solver = re.subn(r"^\[solver\].*$", lambda m: f"{m.group(0)}\nrigid_resting_speed = {speed}", scene,
                            count=1, flags=re.M)
    if not (fractured and solver):
        raise SweepError(f"{BASE_SCENE} must have a [solver] table and a fracture feature for the rigid sweep")
    return scene


def rigid_row(scene: str, speed: float, report: dict) -> dict:
    row = {"scene": scene, "rigid_resting_speed": speed, "stopped": int(report is None)}
    if report is None:
        return row
    try:
        summary, timings, steps = report["summary"], report["timings"], report["steps"]
        given = summary["energy_initial_J"] + summary["energy_put_in_J"]
        row.update(fragments=summary["fragments"], rigid_answers_per_step=summary["contact_rigid_answers"] / steps,
                   step_ms_mean=timings["step"]["mean_ms"], step_ms_p99=timings["step"]["p99_ms"],
                   collisions_ms_mean=timings["collisions"]["mean_ms"],
                   vertex_penetration_max_m=summary["vertex_penetration_max_m"],
                   sphere_penetration_max_m=summary["sphere_penetration_max_m"],
                   elastic_final_J=summary["elastic_final_J"], energy_peak_over_given=summary["energy_max_J"] / given)
    except KeyError as e:
        raise SweepError(f"the player's report has no {e} (run it with diagnostics on)")
    return row


def run_rigid(tools: Tools, quick: bool, staging: Path) -> None:
    plan = QUICK_RIGID if quick else FULL_RIGID
    work, log, base = player_sweep_start(tools, staging, "rigid")
    bake_bundle(tools, work / "bunny.h5", log)
    rows = []
    for name, fracture in RIGID_SCENES.items():
        for speed in plan.speeds:
            stem = f"{'fracture' if fracture == 'true' else 'intact'}-{speed}"
            scene = work / f"{stem}.toml"
            scene.write_text(rigid_scene(base, "bunny.h5", fracture, speed))
            print(f"    {name}, rigid_resting_speed = {speed} ({plan.steps} steps)", flush=True)
            report = play(tools, scene, work / f"{stem}.json", ContactPlan((), plan.steps, plan.time_limit_s), log)
            rows.append(rigid_row(name, speed, report))
    write_csv(staging / "rigid.csv", RIGID_COLUMNS, rows)


def run_sweep(tools: Tools, sweep: str, quick: bool, staging: Path) -> None:
    if sweep == "contacts":
        run_contacts(tools, quick, staging)
    elif sweep == "debris":
        run_debris(tools, quick, staging)
    elif sweep == "rigid":
        run_rigid(tools, quick, staging)
    elif sweep == "cage-method":
        run_cage_methods(tools, quick, staging)
    else:
        run_bench(tools, sweep, quick, staging)


SWEEPS = ("bake", "draw", "solver", "contacts", "cage-method", "debris", "rigid")
# The files each sweep leaves; the rest of its staging folder (bundles, scenes) is scratch.
OUTPUTS = {
    "bake": ("walls.csv", "spheres-bake.csv", "bake.md"),
    "draw": ("draw.csv", "draw.md"),
    "solver": ("dt.csv", "tolerance.csv", "spin.csv", "solver.md"),
    "contacts": ("contacts.csv",),
    "cage-method": ("cage-method.csv",),
    "debris": ("debris.csv",),
    "rigid": ("rigid.csv",),
}

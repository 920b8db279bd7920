"""The trade-study's plots: each reads the CSV files of one sweep (sweeps.py) and makes
one figure. A plot whose CSV files are missing is skipped, so a partial run still plots
what it measured."""

import csv
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display: the plots are files
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)
from matplotlib.ticker import FixedLocator, FuncFormatter, LogLocator, NullFormatter  # noqa: E402

WARPED, EXACT = "tab:blue", "tab:red"
DEFAULTS = "0.5"  # the grey of the lines marking the player's and the bake's defaults

# Thesis Table II: total (triangle, tet) instances of the 5,000-triangle bunny in cages of
# 10 … 100 tets. Our cages are not the thesis's (data/README.md), so the sizes differ a
# little; the trend is what compares.
THESIS_TABLE_II = ((10, 5715), (20, 6231), (31, 6629), (41, 6880), (50, 6907), (60, 7057), (72, 7328),
                   (82, 7472), (91, 7472), (100, 7586))
THESIS_TRIANGLES = 5000
DEFAULT_STEPS_PER_S = 240     # the player's dt, 1/240 s
DEFAULT_TOLERANCE = 1e-4      # solver.tolerance, CG with the lagged Cholesky preconditioner
DEFAULT_CONTACT_SWEEPS = 16   # solver.contact_sweeps (ContactSettings::sequential_impulse_sweeps)
ENERGY_BOUND = 1.01           # energy never above what was put in, +1 % (the energy grid's bound)
# solver.rigid_resting_speed [m/s] by scene: 0.5 where it can break, 1 where it cannot
# (formats::rigid_resting_speed, records 0073 and 0078)
DEFAULT_RIGID_SPEED = {"as shipped": 0.5, "fracture off": 1.0}


def read(folder: Path, name: str) -> list:
    """The rows of folder/name as dicts of strings, or [] when the file is absent."""
    path = folder / name
    if not path.is_file():
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def column(rows: list, key: str) -> list:
    return [float(r[key]) for r in rows]


def figure(columns: int, title: str):
    fig, axes = plt.subplots(1, columns, figsize=(5.2 * columns, 4.2), squeeze=False)
    fig.suptitle(title)
    return fig, axes[0]


def number(value: float, _position=None) -> str:
    """A tick label: plain digits where they stay short, else 2e-05."""
    if value == 0:
        return "0"
    if 1e-3 <= abs(value) < 1e5:
        return f"{value:g}"
    return f"{value:.0e}".replace("e-0", "e-").replace("e+0", "e+")


def readable_axes(fig) -> None:
    """Every log axis labelled densely enough to read values off (issue 45: one label per
    decade could not be read): linear where the data span less than a decade; else labels
    at 1, 2, 5 × 10ⁿ (up to 2.5 decades), 1 and 3 (up to 4.5), or each decade with
    unlabelled minor ticks between. Axes with ticks at the swept values are left alone."""
    for ax in fig.axes:
        for name, axis, limits in (("x", ax.xaxis, ax.dataLim.intervalx), ("y", ax.yaxis, ax.dataLim.intervaly)):
            if axis.get_scale() != "log" or isinstance(axis.get_major_locator(), FixedLocator):
                continue
            low, high = (float(v) for v in limits)
            if not (0 < low < high) or not math.isfinite(high):
                continue
            decades = math.log10(high / low)
            if decades < 1:
                (ax.set_xscale if name == "x" else ax.set_yscale)("linear")
                axis.set_major_formatter(FuncFormatter(number))
                continue
            subs = (1.0, 2.0, 5.0) if decades <= 2.5 else (1.0, 3.0) if decades <= 4.5 else (1.0,)
            axis.set_major_locator(LogLocator(base=10, subs=subs, numticks=40))
            axis.set_major_formatter(FuncFormatter(number))
            axis.set_minor_locator(LogLocator(base=10, subs=[m for m in range(2, 10) if m not in subs], numticks=40))
            axis.set_minor_formatter(NullFormatter())
        ax.autoscale_view()


def mark_default_point(ax, x: float, y: float, label: str = "default") -> None:
    """The default's point on an accuracy-against-cost chart: a ring and its name."""
    ax.plot([x], [y], "o", markersize=13, markerfacecolor="none", markeredgecolor="k", label=label)
    ax.annotate(label, (x, y), xytext=(8, -12), textcoords="offset points", fontsize=8)


def finish(fig) -> None:
    """What every figure gets before it is written: readable axes, a tight layout."""
    readable_axes(fig)
    fig.tight_layout()


def save(fig, path: Path) -> None:
    finish(fig)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def ticks_at(ax, values, text) -> None:
    """x ticks at the swept values only, written as `text(value)`: a log axis's own ticks
    (5×10⁻¹) say less than the values themselves."""
    values = sorted(set(values))
    ax.set_xticks(values, [text(v) for v in values])
    ax.minorticks_off()


def mark_default(ax, x: float, label: str = "default", line: int = 0) -> None:
    """A dotted line at x, labelled at the top (`line` labels further down, for a second default)."""
    ax.axvline(x, color=DEFAULTS, linestyle=":", linewidth=1)
    ax.annotate(label, (x, 1), xycoords=("data", "axes fraction"), xytext=(3, -12 - 10 * line),
                textcoords="offset points", color=DEFAULTS, fontsize=8)


def walls(folder: Path):
    rows = sorted(read(folder, "walls.csv"), key=lambda r: float(r["resolution"]))
    if not rows:
        return None
    res = column(rows, "resolution")
    error_values, mib = column(rows, "coverage_error"), column(rows, "walls_stored_mib")
    fig, (error, seconds, memory, tradeoff) = figure(4, "Wall tile resolution (bunny-5k, 987-tet cage)")
    error.loglog(res, error_values, "o-")
    error.set(xlabel="tile resolution (texels)", ylabel="coverage error (relative area)", title="what it buys")
    seconds.loglog(res, column(rows, "walls_stage_s"), "o-")
    seconds.set(xlabel="tile resolution (texels)", ylabel="s", title="bake: walls stage")
    memory.loglog(res, mib, "s-")
    memory.set(xlabel="tile resolution (texels)", ylabel="MiB", title="bundle: /walls")
    for ax in (error, seconds, memory):
        ticks_at(ax, res, lambda r: f"{int(r)}²")
        mark_default(ax, 64)
    tradeoff.loglog(mib, error_values, "o-")
    label_points(tradeoff, mib, error_values, [f"{int(r)}²" for r in res])
    if 64 in res:
        mark_default_point(tradeoff, mib[res.index(64)], error_values[res.index(64)])
    tradeoff.set(xlabel="bundle: /walls, MiB", ylabel="coverage error (relative area)", title="accuracy against cost")
    return "walls.png", fig


def contacts(folder: Path):
    bake_rows = read(folder, "spheres-bake.csv")
    player = [r for r in read(folder, "contacts.csv") if r["stopped"] == "0"]
    spheres = [r for r in player if r["collision_points"] == "spheres"]
    exact = [r for r in player if r["collision_points"] == "vertices"]
    if not bake_rows and not spheres:
        return None
    fig, (count, depth, cost, tradeoff) = figure(4, "Collision sphere radius (bunny-5k, 987-tet cage; ×1 = a fifth of the median cage edge)")
    if bake_rows:
        count.semilogx(column(bake_rows, "radius_over_default"), column(bake_rows, "spheres"), "o-")
    count.set(xlabel="target radius ÷ default", ylabel="spheres", title="spheres the bake makes")
    count.set_ylim(bottom=0)
    if spheres:
        x = column(spheres, "radius_over_default")
        depth.semilogx(x, [1e3 * v for v in column(spheres, "vertex_penetration_max_m")], "o-", label="spheres")
        cost.semilogx(x, column(spheres, "collisions_ms_mean"), "o-", label="spheres")
    if exact:
        depth.axhline(1e3 * float(exact[0]["vertex_penetration_max_m"]), color=EXACT, linestyle="--",
                      label="every render vertex (exact)")
        cost.axhline(float(exact[0]["collisions_ms_mean"]), color=EXACT, linestyle="--",
                     label="every render vertex (exact)")
    depth.set(xlabel="target radius ÷ default", ylabel="mm", title="deepest render vertex in an obstacle")
    depth.set_ylim(bottom=0)
    cost.set(xlabel="target radius ÷ default", ylabel="ms per step (mean, 1 thread)", title="collision phase")
    factors = column(bake_rows, "radius_over_default") + column(spheres, "radius_over_default")
    for ax in (count, depth, cost):
        ticks_at(ax, factors, lambda f: f"×{f:g}")
        mark_default(ax, 1.0)
    depth.legend()
    cost.legend()
    accuracy_against_cost_contacts(tradeoff, spheres, exact)
    return "contacts.png", fig


def accuracy_against_cost_contacts(ax, spheres: list, exact: list) -> None:
    """Deepest penetration against the collision phase's time, one point per radius."""
    if spheres:
        x, y = column(spheres, "collisions_ms_mean"), [1e3 * v for v in column(spheres, "vertex_penetration_max_m")]
        ax.plot(x, y, "o", label="spheres")  # no line: the radii do not order the cost
        factors = column(spheres, "radius_over_default")
        label_points(ax, x, y, [f"×{f:g}" for f in factors])
        if 1.0 in factors:
            mark_default_point(ax, x[factors.index(1.0)], y[factors.index(1.0)])
    if exact:
        ax.plot([float(exact[0]["collisions_ms_mean"])], [1e3 * float(exact[0]["vertex_penetration_max_m"])], "s",
                color=EXACT, label="every render vertex (exact)")
    ax.set(xlabel="collision phase, ms per step (mean, 1 thread)", ylabel="deepest render vertex, mm",
           title="accuracy against cost")
    ax.set_ylim(bottom=0)
    ax.legend()


def cages(folder: Path):
    rows = [r for r in read(folder, "draw.csv") if r["triangles"] == "5000"]
    if not rows:
        return None
    rows.sort(key=lambda r: float(r["tets"]))
    tets = column(rows, "tets")
    fig, (replication, step, draw) = figure(3, "Cage tet count, bunny-5k (thesis Table II, Fig. 21)")
    per_triangle = [i / t for i, t in zip(column(rows, "instances"), column(rows, "triangles"))]
    replication.semilogx(tets, per_triangle, "o-", label="ours")
    replication.semilogx([t for t, _ in THESIS_TABLE_II], [n / THESIS_TRIANGLES for _, n in THESIS_TABLE_II], "x",
                         color="k", label="thesis Table II")
    replication.set(xlabel="cage tets", ylabel="instances per triangle", title="replication")
    replication.legend()
    step.loglog(tets, column(rows, "physics_ms_per_step"), "o-")
    step.set(xlabel="cage tets", ylabel="ms per step (median)", title="physics step (no contacts)")
    draw.semilogx(tets, column(rows, "embedded_draw_ms"), "o-", label="embedded (clipped instances)")
    draw.semilogx(tets, column(rows, "plain_draw_ms"), "s--", label="plain mesh, same triangles")
    draw.set(xlabel="cage tets", ylabel="ms per frame (median)", title="draw (llvmpipe)")
    draw.set_ylim(bottom=0)
    draw.legend()
    return "cages.png", fig


def triangles(folder: Path):
    rows = read(folder, "draw.csv")
    by_cage = {}
    for r in rows:
        by_cage.setdefault(r["tets"], []).append(r)
    by_cage = {t: sorted(rs, key=lambda r: float(r["triangles"])) for t, rs in by_cage.items() if len(rs) > 1}
    if not by_cage:
        return None
    fig, (draw, step) = figure(2, "Triangle count with the cage fixed (thesis Fig. 22)")
    for tets, rs in sorted(by_cage.items(), key=lambda kv: float(kv[0])):
        tris = column(rs, "triangles")
        line, = draw.semilogx(tris, column(rs, "embedded_draw_ms"), "o-", label=f"embedded, {tets} tets")
        draw.semilogx(tris, column(rs, "plain_draw_ms"), "s--", color=line.get_color(), label=f"plain, {tets} tets")
        step.semilogx(tris, column(rs, "physics_ms_per_step"), "o-", label=f"{tets} tets")
    draw.set(xlabel="render triangles", ylabel="ms per frame (median)", title="draw (llvmpipe)")
    step.set(xlabel="render triangles", ylabel="ms per step (median)", title="physics: flat in triangles")
    for ax in (draw, step):
        ax.set_ylim(bottom=0)
        ax.legend()
    return "triangles.png", fig


def label_points(ax, xs, ys, labels) -> None:
    for x, y, text in zip(xs, ys, labels):
        ax.annotate(text, (x, y), xytext=(4, 3), textcoords="offset points", fontsize=7)


def dt(folder: Path):
    rows = read(folder, "dt.csv")
    cases = sorted({r["case"] for r in rows})
    if not cases:
        return None
    fig, axes = figure(len(cases), "Time step: error against a small-dt reference vs cost (direct solver, 1 thread)")
    for ax, case in zip(axes, cases):
        for model, colour in (("warped", WARPED), ("exact", EXACT)):
            rs = [r for r in rows if r["case"] == case and r["stiffness"] == model]
            x, y = column(rs, "wall_s_per_simulated_s"), column(rs, "rms_error_relative")
            ax.loglog(x, y, "o-", color=colour, label=f"{model} stiffness")
            label_points(ax, x, y, [f"1/{round(1 / float(r['dt_s']))}" for r in rs])
            default = [i for i, r in enumerate(rs) if round(1 / float(r["dt_s"])) == DEFAULT_STEPS_PER_S]
            if model == "warped" and default:
                mark_default_point(ax, x[default[0]], y[default[0]], "default (1/240, warped)")
        ax.set(xlabel="wall s per simulated s", ylabel="RMS node error ÷ RMS displacement",
               title=f"{case}: accuracy against cost")
        ax.legend()
    return "dt.png", fig


def tolerance(folder: Path):
    rows = read(folder, "tolerance.csv")
    cases = sorted({r["case"] for r in rows})
    if not cases:
        return None
    fig, axes = figure(len(cases), "CG tolerance at dt = 1/240 s: what it adds to the step's error vs cost (1 thread)")
    for ax, case in zip(axes, cases):
        for solver, marker in (("cg-jacobi", "o-"), ("cg-lagged-cholesky", "s-")):
            rs = [r for r in rows if r["case"] == case and r["solver"] == solver]
            x, y = column(rs, "wall_s_per_simulated_s"), column(rs, "error_vs_direct")
            ax.loglog(x, y, marker, label=solver.replace("cg-", "CG, ").replace("-", " "))
            label_points(ax, x, y, [f"{float(r['tolerance']):.0e}" for r in rs])
            default = [i for i, r in enumerate(rs) if float(r["tolerance"]) == DEFAULT_TOLERANCE]
            if solver == "cg-lagged-cholesky" and default:
                mark_default_point(ax, x[default[0]], y[default[0]], "default (1e-4)")
        direct = [r for r in rows if r["case"] == case and r["solver"] == "direct"]
        if direct:
            ax.axvline(float(direct[0]["wall_s_per_simulated_s"]), color="k", linestyle="--", label="direct solver")
        ax.set(xlabel="wall s per simulated s", ylabel="RMS error against the direct solve, same dt",
               title=f"{case}: accuracy against cost")
        ax.legend()
    return "tolerance.png", fig


def spin(folder: Path):
    rows = read(folder, "spin.csv")
    if not rows:
        return None
    fig, (energy, tip, tradeoff) = figure(3, "Exact vs warped stiffness: a free beam spinning at 10 rad/s for 0.5 s")
    for model, colour in (("warped", WARPED), ("exact", EXACT)):
        rs = sorted((r for r in rows if r["stiffness"] == model), key=lambda r: float(r["rad_per_step"]))
        x = column(rs, "rad_per_step")
        energy.semilogx(x, column(rs, "peak_energy_ratio"), "o-", color=colour, label=f"{model}: peak")
        energy.semilogx(x, column(rs, "final_energy_ratio"), "s--", color=colour, label=f"{model}: at the end")
        tip.loglog(x, column(rs, "tip_error_m"), "o-", color=colour, label=model)
        # The knob is the model; rotation per step is the scene's. The default model is warped.
        cost, error = column(rs, "ms_per_step"), column(rs, "tip_error_m")
        tradeoff.loglog(cost, error, "o-" if model == "warped" else "s--", color=colour,
                        label=f"{model} (default)" if model == "warped" else model)
        label_points(tradeoff, cost, error, [f"{r:g} rad" for r in x])
    tradeoff.set(xlabel="ms per step", ylabel="tip error, m", title="accuracy against cost (points: rad per step)")
    tradeoff.legend()
    for ax in (energy, tip):
        ticks_at(ax, column(rows, "rad_per_step"), lambda r: f"{r:g}")
    energy.axhline(1.0, color=DEFAULTS, linewidth=1)
    energy.set(xlabel="rotation per step (rad)", ylabel="E / E₀", title="energy (the true motion keeps E₀)")
    tip.set(xlabel="rotation per step (rad)", ylabel="m", title="tip position against the reference")
    energy.legend()
    tip.legend()
    return "spin.png", fig


CAGE_METHOD_STYLE = {"hand-made": ("s-", "k"), "lattice": ("o-", "tab:green"), "wrap": ("^-", "tab:purple")}


def cage_method(folder: Path):
    rows = read(folder, "cage-method.csv")
    if not rows:
        return None
    fig, (replication, ratio, step, making) = figure(
        4, "Cage method at the hand-made cages' counts (bunny-5k; bunny-drop, fracture off, 1 thread)")
    hand = {r["tets_asked"]: float(r["instances_per_triangle"])
            for r in rows if r["method"] == "hand-made" and not r["failed"]}
    for method, (style, colour) in CAGE_METHOD_STYLE.items():
        made = sorted((r for r in rows if r["method"] == method and not r["failed"]), key=lambda r: float(r["tets"]))
        if not made:
            continue
        tets = column(made, "tets")
        replication.semilogx(tets, column(made, "instances_per_triangle"), style, color=colour, label=method)
        timed = [r for r in made if r["step_ms_mean"]]
        step.loglog(column(timed, "tets"), column(timed, "step_ms_mean"), style, color=colour, label=method)
        if method != "hand-made":
            making.loglog(tets, column(made, "cage_s"), style, color=colour, label=f"--method {method}")
            paired = [r for r in made if r["tets_asked"] in hand]
            ratio.semilogx([float(r["tets_asked"]) for r in paired],
                           [float(r["instances_per_triangle"]) / hand[r["tets_asked"]] for r in paired], style,
                           color=colour, label=f"--method {method}")
    failed = [r for r in rows if r["failed"]]
    for r in failed:  # a count the method cannot reach is a finding: say so where the point would be
        replication.annotate(f"{r['method']}: none at {r['tets_asked']}", (float(r["tets_asked"]), 1),
                             xycoords=("data", "axes fraction"), xytext=(2, -6), textcoords="offset points",
                             fontsize=7, rotation=90, va="top", color=CAGE_METHOD_STYLE[r["method"]][1])
    replication.set(xlabel="cage tets", ylabel="instances per triangle", title="replication (draw cost)")
    ratio.axhline(1.2, color=EXACT, linestyle="--", linewidth=1, label="issue 43's bound (1.2×)")
    ratio.axhline(1.0, color=DEFAULTS, linewidth=1)
    ratio.set(xlabel="tets asked", ylabel="÷ the hand-made cage's", title="replication against hand-made")
    step.set(xlabel="cage tets", ylabel="ms per step (mean)", title="physics step")
    making.set(xlabel="cage tets", ylabel="s", title="making the cage (fissure-bake cage)")
    for ax in (replication, ratio, step, making):
        ax.legend()
    return "cage-method.png", fig


def sweeps_label(n: float) -> str:
    return "0 (AL)" if n == 0 else f"{int(n)}"


def debris(folder: Path):
    rows = sorted((r for r in read(folder, "debris.csv") if r["stopped"] == "0"), key=lambda r: float(r["contact_sweeps"]))
    if not rows:
        return None
    fig, (cost, depth, energy, tradeoff) = figure(
        4, "Sequential-impulse sweeps for debris (bunny-drop at toughness 0, hundreds of fragments; 1 thread)")
    n = column(rows, "contact_sweeps")
    collisions, sunk = column(rows, "collisions_ms_mean"), [1e3 * v for v in column(rows, "sphere_penetration_max_m")]
    cost.plot(n, collisions, "o-", label="collision phase")
    cost.plot(n, column(rows, "step_ms_mean"), "s--", label="whole step")
    cost.set(xlabel="solver.contact_sweeps", ylabel="ms per step (mean)", title="cost")
    cost.set_ylim(bottom=0)
    cost.legend()
    depth.plot(n, sunk, "o-", label="deepest over the run")
    depth.plot(n, [1e3 * v for v in column(rows, "sphere_penetration_final_m")], "s--", label="deepest at the end")
    depth.set(xlabel="solver.contact_sweeps", ylabel="mm", title="collision spheres in obstacles")
    depth.set_ylim(0, 1.25 * max(sunk))
    depth.legend()
    energy.plot(n, column(rows, "energy_peak_over_given"), "o-")
    energy.axhline(ENERGY_BOUND, color=EXACT, linestyle="--", linewidth=1, label="bound: what was put in +1 %")
    energy.set(xlabel="solver.contact_sweeps", ylabel="peak energy ÷ energy given", title="energy")
    energy.legend()
    for ax in (cost, depth, energy):
        ax.set_xscale("symlog", linthresh=1)
        ticks_at(ax, n, sweeps_label)
        mark_default(ax, DEFAULT_CONTACT_SWEEPS)
    tradeoff.plot(collisions, sunk, "o")  # no line: the sweeps do not order the cost
    label_points(tradeoff, collisions, sunk, [sweeps_label(v) for v in n])
    if DEFAULT_CONTACT_SWEEPS in n:
        i = n.index(DEFAULT_CONTACT_SWEEPS)
        mark_default_point(tradeoff, collisions[i], sunk[i])
    tradeoff.set(xlabel="collision phase, ms per step (mean)", ylabel="deepest sphere, mm",
                 title="accuracy against cost")
    tradeoff.set_xlim(0, 1.15 * max(collisions))
    tradeoff.set_ylim(0, 1.25 * max(sunk))
    return "debris.png", fig


def speed_label(v: float) -> str:
    return "0 (FEM)" if v == 0 else f"{v:g}"


def rigid(folder: Path):
    rows = [r for r in read(folder, "rigid.csv") if r["stopped"] == "0"]
    scenes = sorted({r["scene"] for r in rows}, reverse=True)
    if not scenes:
        return None
    fig, (cost, depth, pieces, tradeoff) = figure(
        4, "Large fragments at rest as rigid bodies (bunny-drop, 480 steps; 1 thread)")
    for scene, marker in zip(scenes, "os"):
        mine = sorted((r for r in rows if r["scene"] == scene), key=lambda r: float(r["rigid_resting_speed"]))
        speed, step = column(mine, "rigid_resting_speed"), column(mine, "step_ms_mean")
        vertex = [1e3 * v for v in column(mine, "vertex_penetration_max_m")]
        cost.plot(speed, step, f"{marker}-", label=f"{scene}: whole step")
        cost.plot(speed, column(mine, "collisions_ms_mean"), f"{marker}--", label=f"{scene}: collision phase")
        depth.plot(speed, vertex, f"{marker}-", label=scene)
        pieces.plot(speed, column(mine, "fragments"), f"{marker}-", label=scene)
        tradeoff.plot(step, vertex, marker, label=scene)
        label_points(tradeoff, step, vertex, [speed_label(v) for v in speed])
        if DEFAULT_RIGID_SPEED.get(scene) in speed:
            i = speed.index(DEFAULT_RIGID_SPEED[scene])
            mark_default_point(tradeoff, step[i], vertex[i], label="default" if marker == "o" else "")
    cost.set(xlabel="solver.rigid_resting_speed [m/s]", ylabel="ms per step (mean)", title="cost")
    depth.set(xlabel="solver.rigid_resting_speed [m/s]", ylabel="mm", title="deepest render vertex in an obstacle")
    pieces.set(xlabel="solver.rigid_resting_speed [m/s]", ylabel="fragments at the end",
               title="break-up (chaotic: compare the spread)")
    for ax in (cost, depth, pieces):
        ax.set_xscale("symlog", linthresh=0.05)
        ticks_at(ax, column(rows, "rigid_resting_speed"), speed_label)
        for line, (scene, default) in enumerate(DEFAULT_RIGID_SPEED.items()):
            mark_default(ax, default, label=f"default, {scene}", line=line)
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=7)
    tradeoff.set(xlabel="ms per step (mean)", ylabel="deepest render vertex, mm", title="accuracy against cost")
    tradeoff.set_xlim(left=0)
    tradeoff.set_ylim(bottom=0)
    tradeoff.legend(fontsize=7)
    return "rigid.png", fig


PLOTS = (walls, contacts, cages, triangles, dt, tolerance, spin, cage_method, debris, rigid)


def plot_all(data: Path, out: Path) -> list:
    """Every plot whose CSV files are in `data`, written to `out`; returns the PNG names."""
    written = []
    for plot in PLOTS:
        made = plot(data)
        if made is not None:
            name, fig = made
            save(fig, out / name)
            written.append(name)
    return written

#!/usr/bin/env python3
"""The trade-study's plots (pipelines/tradeoffs/plots.py), drawn from the CSV files
committed in docs/tradeoffs/, so no sweep runs (issue 45):

- every axis of every panel carries at least three tick labels inside its range, so a
  value can be read off (one label per decade could not be);
- no axis label mixes units (a panel had seconds and MiB on one axis);
- each knob group with an accuracy measure (walls, contacts, dt, tolerance, spin) has an
  "accuracy against cost" panel with the default marked. The cage and triangle counts
  have no accuracy measure in the sweeps: they are costs only.

usage: tradeoff_plots_test.py REPOSITORY_ROOT
"""

import os
import re
import subprocess
import sys
from pathlib import Path

SYSTEM_PYTHON = "/usr/bin/python3"  # Debian's python3-matplotlib is for Debian's interpreter
try:
    import matplotlib  # noqa: F401
except ImportError:
    if os.path.realpath(sys.executable) != os.path.realpath(SYSTEM_PYTHON) and os.path.exists(SYSTEM_PYTHON) and \
            subprocess.run([SYSTEM_PYTHON, "-c", "import matplotlib"], capture_output=True).returncode == 0:
        os.execv(SYSTEM_PYTHON, [SYSTEM_PYTHON, *sys.argv])
    print("FAIL: matplotlib is not installed (scripts/install-deps.sh: python3-matplotlib)", file=sys.stderr)
    sys.exit(1)

failures = []
UNITS = re.compile(r"(?<![\w/])(s|ms|MiB|mm|m)(?![\w/])")
WITH_ACCURACY = {"walls.png", "contacts.png", "dt.png", "tolerance.png", "spin.png"}


def check(condition: bool, what: str) -> None:
    if not condition:
        failures.append(what)
        print(f"FAIL: {what}", file=sys.stderr)


def labelled_ticks(ax, axis) -> list:
    low, high = sorted(ax.get_xlim() if axis is ax.xaxis else ax.get_ylim())
    span = high - low
    return [t.get_text() for t, at in zip(axis.get_ticklabels(), axis.get_ticklocs())
            if t.get_text() and low - 1e-9 * span <= at <= high + 1e-9 * span]


def check_figure(name: str, fig) -> None:
    fig.canvas.draw()  # tick labels exist once drawn
    accuracy_panels = []
    for ax in fig.axes:
        panel = f"{name}, panel {ax.get_title()!r}"
        for axis, label in ((ax.xaxis, ax.get_xlabel()), (ax.yaxis, ax.get_ylabel())):
            ticks = labelled_ticks(ax, axis)
            check(len(ticks) >= 3, f"{panel}: {axis.axis_name} axis ({label!r}, {axis.get_scale()}) has "
                                   f"{len(ticks)} tick labels {ticks}: values cannot be read off")
            units = set(UNITS.findall(label))
            check(len(units) <= 1, f"{panel}: the {axis.axis_name} axis {label!r} mixes units {sorted(units)}")
        if "accuracy against cost" in ax.get_title():
            accuracy_panels.append(ax)
    if name in WITH_ACCURACY:
        check(bool(accuracy_panels), f"{name}: no accuracy-against-cost panel")
        for ax in accuracy_panels:
            labels = [artist.get_label() for artist in ax.get_lines()]
            check(any("default" in label for label in labels),
                  f"{name}, panel {ax.get_title()!r}: the default is not marked ({labels})")


def main() -> int:
    root = Path(sys.argv[1])
    sys.path.insert(0, str(root / "pipelines" / "tradeoffs"))
    import plots  # noqa: E402  (from the repository given)
    made = [plot(root / "docs" / "tradeoffs") for plot in plots.PLOTS]
    names = {m[0] for m in made if m is not None}
    check(names >= WITH_ACCURACY | {"cages.png", "triangles.png"}, f"plots made from docs/tradeoffs: {sorted(names)}")
    for made_plot in made:
        if made_plot is not None:
            name, fig = made_plot
            plots.finish(fig)  # as plot_all does before saving
            check_figure(name, fig)
    print(f"{len(failures)} failure(s)" if failures else "the trade-study plots can be read")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

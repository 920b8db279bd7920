#!/usr/bin/env python3
"""The batch workflow's JUnit report (Snakefile): `fissure-bake verify --status` over every
asset's bundle, plus a failing "bake" case for each asset whose last bake failed (its
OUT/logs/NAME.failed holds that bake's log; the bundle beside it is the last good one).

The report is written whole under a temporary name and renamed. Exit 0 when every case
passes, 1 otherwise (the same verdict the report gives a CI page).

usage: report.py FISSURE_BAKE REPORT.xml OUT NAME...
"""

import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

LOG_TAIL_LINES = 20  # of a failed bake's log, into the report's failure text


def count(element: ET.Element, key: str) -> int:
    return int(element.get(key, "0"))


def add(element: ET.Element, key: str, n: int) -> None:
    element.set(key, str(count(element, key) + n))


def add_bake_failure(root: ET.Element, bundle: str, log: Path) -> None:
    """A failing "bake" case in the bundle's suite (made if verify wrote none)."""
    suite = next((s for s in root.iter("testsuite") if s.get("name") == bundle), None)
    if suite is None:
        suite = ET.SubElement(root, "testsuite", {"name": bundle, "tests": "0", "failures": "0", "errors": "0"})
    lines = log.read_text(errors="replace").splitlines()[-LOG_TAIL_LINES:]
    case = ET.Element("testcase", {"classname": bundle, "name": "bake"})
    failure = ET.SubElement(case, "failure", {
        "message": f"the last bake failed; {bundle} is the last good bundle, if any (log: {log})"})
    failure.text = "\n".join(lines)
    suite.insert(0, case)
    for element in (suite, root):
        add(element, "tests", 1)
        add(element, "failures", 1)


def main() -> int:
    if len(sys.argv) < 5:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    bake, report, out, names = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3]), sys.argv[4:]
    bundles = [str(out / f"{name}.h5") for name in names]
    report.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=report.parent, prefix=".report-") as tmp:
        verified = Path(tmp) / "verify.xml"
        run = subprocess.run([bake, "-q", "verify", "--status", *bundles, "--junit", str(verified)])
        if not verified.is_file():
            print(f"report.py: {bake} verify wrote no report (exit {run.returncode})", file=sys.stderr)
            return 1
        root = ET.parse(verified).getroot()
        failed = [name for name in names if (out / "logs" / f"{name}.failed").is_file()]
        for name in failed:
            add_bake_failure(root, str(out / f"{name}.h5"), out / "logs" / f"{name}.failed")
            print(f"{out / name}.h5: the last bake failed (kept the last good bundle, if any): see "
                  f"{out / 'logs' / name}.failed", file=sys.stderr)
        staged = Path(tmp) / "report.xml"
        ET.ElementTree(root).write(staged, encoding="UTF-8", xml_declaration=True)
        os.replace(staged, report)
    passed = count(root, "failures") + count(root, "errors") == 0
    print(f"{report}: {len(names)} bundles, {'all pass' if passed else 'FAILED'}")
    return 0 if passed else 1


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""The automatic-cage table of BENCHMARKS.md: `fissure-bake cage` on each mesh at each count.

For every mesh, method (--methods, default lattice,wrap) and asked count N: the tets made, the dihedral range, the clearance (how
near the surface comes to the cage's hull, and how far the hull reaches beyond the
surface, both in mean edge lengths), the cage's volume against the solid's, the
replication (instances per triangle, thesis Table II) and the seconds (making the cage
alone, and the whole command: import, cage, exact containment check, quality, write).
Where a hand-made cage of the same mesh and count is given (--hand-made N=FILE), its
replication is shown beside the lattice's.

Usage:
  scripts/cage-benchmarks.py --bake build/release/bake/fissure-bake --out DIR \\
      --counts 50,500,5000,20000 [--methods lattice,wrap] MESH...
      [--hand-made 987=data/cages/bunny-5k-cage-987.node ...]
Prints a Markdown table; writes the cages under DIR. Standard library only.
"""
import argparse
import json
import pathlib
import re
import subprocess
import time


def replication(bake, mesh, cage):
    out = subprocess.run([bake, "-q", "replication", mesh, "--cages", cage, "--json"], check=True,
                         capture_output=True, text=True).stdout
    row = json.loads(out)[0] if out.lstrip().startswith("[") else json.loads(out)["rows"][0]
    return row


def per_triangle(row, triangles):
    return row["instances"] / triangles


def row_for(args, hand, mesh, name, method, n, out):
    cage = out / f"{name}-{method}-{n}.node"
    start = time.monotonic()
    run = subprocess.run([args.bake, "cage", "--mesh", mesh, "--tets", str(n), "--method", method, "-o", str(cage), "--json"],
                         capture_output=True, text=True)
    seconds = time.monotonic() - start
    if run.returncode != 0:
        error = [line for line in run.stderr.splitlines() if line.startswith("error: ")]
        reason = error[-1].split(": ", 2)[-1] if error else "?"
        print(f"| {name} | {method} | | {n} | fails: {reason} | | | | | | | {seconds:.2f} |")
        return
    q = json.loads(run.stdout)
    made = re.search(r"tries \(([0-9.]+) s\)", run.stderr)
    row = replication(args.bake, mesh, str(cage))
    triangles = sum(row["counts"])
    rep = f"{per_triangle(row, triangles):.3f}"
    if str(n) in hand:
        hand_row = replication(args.bake, mesh, hand[str(n)])
        rep += f" ({per_triangle(hand_row, triangles):.3f} at {hand_row['tets']})"
    edge = q["mean_edge"]
    print(f"| {name} | {method} | {triangles} | {n} | {q['tets']} | {q['min_dihedral_deg']:.1f}° / {q['max_dihedral_deg']:.1f}° "
          f"| {q['clearance_min'] / edge:.3f} | {q['overhang_max'] / edge:.2f} "
          f"| {q['cage_volume'] / max(q['solid_volume'], 1e-300):.2f} | {rep} "
          f"| {float(made.group(1)) if made else float('nan'):.3f} | {seconds:.2f} |", flush=True)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--bake", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--counts", default="50,500,5000,20000")
    parser.add_argument("--methods", default="lattice,wrap")
    parser.add_argument("--hand-made", action="append", default=[], help="N=FILE, for the first mesh")
    parser.add_argument("meshes", nargs="+")
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    hand = dict(item.split("=", 1) for item in args.hand_made)
    print("| mesh | method | triangles | N asked | tets made | min / max dihedral | surface to hull (edges) | hull beyond surface (edges) "
          "| cage / solid volume | replication (hand-made) | cage s | command s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for index, mesh in enumerate(args.meshes):
        counts = [int(c) for c in args.counts.split(",")]
        if index == 0:
            counts = sorted(set(counts) | {int(n) for n in hand})
        name = pathlib.Path(mesh).stem
        for n in counts:
            for method in args.methods.split(","):
                row_for(args, hand if index == 0 else {}, mesh, name, method, n, out)

if __name__ == "__main__":
    main()

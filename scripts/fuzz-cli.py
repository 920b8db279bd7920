#!/usr/bin/env python3
"""Mutation-fuzz fissure-bake and fissure-player through their command lines.

Builds small seed inputs (meshes, cages, a scene, a bundle) from the repository's data,
mutates each seed N times (deterministically for a given --seed), runs the program that
reads that format on every mutant under a wall-clock limit and an address-space limit,
and classifies each run:

  ok        exit 0
  error     exit 1: a clean, user-facing error (also noted: does stderr name the input? for
            `verify`, whose failure report goes to stdout, stdout counts too)
  internal  exit 2: "internal error ... this is a bug"
  crash     killed by a signal (SIGSEGV, SIGABRT, ...) for a reason other than memory
  hang      still running after --timeout seconds (killed by `timeout`)
  oom       ran out of the --mem-mib address space: stderr mentions bad_alloc / out of
            memory / cannot allocate (whatever the exit status or signal), or the program
            was SIGKILLed before the time limit (the kernel's OOM killer)
  replaced  an output that was a FIFO, socket or device is something else afterwards
  other     any other exit status

Every crash, hang, internal error and out-of-memory input is kept under
OUT/findings/<format>/<kind>-<case>.<ext> with a .txt holding the mutation, the command
and the stderr tail. The tables go to stdout, OUT/summary.md and OUT/summary.json; every
case's result goes to OUT/results.jsonl. Nothing is written outside OUT.

Usage:
  scripts/fuzz-cli.py --bake BIN --player BIN --out DIR [--cases N] [--seed S]
                      [--timeout SEC] [--mem-mib MIB] [--formats a,b,...] [--jobs J]

--cases takes a number for every format, or per-format counts: "300,ply-ascii=100".
Standard library only.
"""

import argparse
import json
import math
import os
import random
import re
import shutil
import signal
import struct
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fuzz_cli_inputs as inputs  # noqa: E402  (issue 46: more formats and fixed cases)

DATA = Path(__file__).resolve().parent.parent / "data"
CAGE_STEM = "bunny-5k-cage-10"

# name: (extension, what reads it, text format?)
FORMATS = {
    "obj": (".obj", "mesh", True),
    "ply-ascii": (".ply", "mesh", True),
    "ply-bin": (".ply", "mesh", False),
    "stl-ascii": (".stl", "mesh", True),
    "stl-bin": (".stl", "mesh", False),
    "node": (".node", "cage", True),
    "ele": (".ele", "cage", True),
    "msh22": (".msh", "cage", True),
    "msh41": (".msh", "cage", True),
    "medit": (".mesh", "cage", True),
    "scene": (".toml", "scene", True),
    "bundle": (".h5", "bundle", False),
}
# Issue 46: the other formats the bake hands to assimp, each from its own seed, and
# "assimp-any": a mutant of any mesh seed under any extension assimp claims.
for _name, (_ext, _writer) in inputs.ASSIMP_SEEDS.items():
    FORMATS[_name] = (_ext, "mesh", _name != "glb")
FORMATS["assimp-any"] = ("", "mesh", False)
MESH_SEEDS = ["obj", "stl-ascii", "stl-bin"] + list(inputs.ASSIMP_SEEDS)
# Fixed cases, not mutations (fuzz_cli_inputs.py): streams and special files as inputs
# and outputs, flags at their extremes, scenes and meshes with thousands of entries.
for _name in inputs.FIXED_CLASSES:
    FORMATS[_name] = ("", _name, False)
KINDS = ["ok", "error", "internal", "crash", "hang", "oom", "replaced", "other"]
SAVED_KINDS = ("internal", "crash", "hang", "oom", "replaced")
OOM_RE = re.compile(r"bad_alloc|out of memory|cannot allocate memory|memory exhausted|std::length_error"
                    r"|failed to allocate|allocation fail", re.IGNORECASE)


# ----------------------------------------------------------------------------- seeds

def read_tetgen(node_path, ele_path):
    def records(path):
        rows = []
        for line in path.read_text().splitlines():
            line = line.split("#", 1)[0].split()
            if line:
                rows.append(line)
        return rows
    nodes = records(node_path)
    count, _dim, attrs, markers = (int(v) for v in nodes[0][:4])
    base = int(nodes[1][0])
    xyz = [tuple(float(v) for v in row[1:4]) for row in nodes[1:1 + count]]
    ele = records(ele_path)
    tcount, per = int(ele[0][0]), int(ele[0][1])
    tets = [tuple(int(v) - base for v in row[1:5]) for row in ele[1:1 + tcount]]
    return xyz, tets


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def norm(a):
    return math.sqrt(dot(a, a))


def boundary_faces(tets):
    seen = {}
    for t in tets:
        for f in ((t[1], t[2], t[3]), (t[0], t[3], t[2]), (t[0], t[1], t[3]), (t[0], t[2], t[1])):
            key = tuple(sorted(f))
            seen.setdefault(key, []).append(f)
    return [v[0] for v in seen.values() if len(v) == 1]


def icosphere(subdivisions):
    t = (1.0 + math.sqrt(5.0)) / 2.0
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
             (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [tuple(c / norm(v) for c in v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
             (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
             (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        cache = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = tuple((verts[a][k] + verts[b][k]) / 2 for k in range(3))
                verts.append(tuple(c / norm(m) for c in m))
                cache[key] = len(verts) - 1
            return cache[key]
        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return verts, faces


def seed_mesh(cage_xyz, cage_tets):
    """A closed, slightly lumpy sphere (320 triangles) well inside the cage, crossing several tets."""
    centre = tuple(sum(p[k] for p in cage_xyz) / len(cage_xyz) for k in range(3))
    inradius = float("inf")
    for f in boundary_faces(cage_tets):
        a, b, c = (cage_xyz[i] for i in f)
        n = cross(sub(b, a), sub(c, a))
        inradius = min(inradius, abs(dot(n, sub(centre, a))) / norm(n))
    verts, faces = icosphere(2)
    rng = random.Random("fuzz-cli seed mesh")
    radius = 0.6 * inradius
    out = []
    for v in verts:
        r = radius * (1.0 + 0.08 * (rng.random() - 0.5))
        out.append(tuple(centre[k] + r * v[k] for k in range(3)))
    return out, faces


def face_normal(verts, f):
    n = cross(sub(verts[f[1]], verts[f[0]]), sub(verts[f[2]], verts[f[0]]))
    length = norm(n) or 1.0
    return tuple(c / length for c in n)


def vertex_normals(verts, faces):
    acc = [[0.0, 0.0, 0.0] for _ in verts]
    for f in faces:
        n = face_normal(verts, f)
        for i in f:
            for k in range(3):
                acc[i][k] += n[k]
    return [tuple(c / (norm(a) or 1.0) for c in a) for a in acc]


def write_obj(verts, faces):
    normals = vertex_normals(verts, faces)
    lines = ["# fuzz-cli seed: a lumpy sphere inside bunny-5k-cage-10", "o sphere"]
    lines += ["v %.9g %.9g %.9g" % v for v in verts]
    lines += ["vn %.6f %.6f %.6f" % n for n in normals]
    lines += ["f %d//%d %d//%d %d//%d" % (f[0] + 1, f[0] + 1, f[1] + 1, f[1] + 1, f[2] + 1, f[2] + 1) for f in faces]
    return ("\n".join(lines) + "\n").encode()


def ply_header(fmt, nv, nf):
    return ("ply\nformat %s 1.0\ncomment fuzz-cli seed\nelement vertex %d\nproperty float x\nproperty float y\n"
            "property float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty uchar red\n"
            "property uchar green\nproperty uchar blue\nelement face %d\nproperty list uchar int vertex_indices\n"
            "end_header\n" % (fmt, nv, nf)).encode()


def write_ply_ascii(verts, faces):
    normals = vertex_normals(verts, faces)
    body = ["%.9g %.9g %.9g %.6f %.6f %.6f 200 180 160" % (v + n) for v, n in zip(verts, normals)]
    body += ["3 %d %d %d" % f for f in faces]
    return ply_header("ascii", len(verts), len(faces)) + ("\n".join(body) + "\n").encode()


def write_ply_binary(verts, faces):
    normals = vertex_normals(verts, faces)
    body = b"".join(struct.pack("<6f3B", *v, *n, 200, 180, 160) for v, n in zip(verts, normals))
    body += b"".join(struct.pack("<B3i", 3, *f) for f in faces)
    return ply_header("binary_little_endian", len(verts), len(faces)) + body


def write_stl_ascii(verts, faces):
    lines = ["solid sphere"]
    for f in faces:
        lines.append("  facet normal %.6e %.6e %.6e" % face_normal(verts, f))
        lines.append("    outer loop")
        for i in f:
            lines.append("      vertex %.9e %.9e %.9e" % verts[i])
        lines += ["    endloop", "  endfacet"]
    lines.append("endsolid sphere")
    return ("\n".join(lines) + "\n").encode()


def write_stl_binary(verts, faces):
    header = b"fuzz-cli seed binary STL".ljust(80, b" ")
    out = [header, struct.pack("<I", len(faces))]
    for f in faces:
        out.append(struct.pack("<12fH", *face_normal(verts, f), *verts[f[0]], *verts[f[1]], *verts[f[2]], 0))
    return b"".join(out)


def write_msh22(xyz, tets):
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$PhysicalNames", "1", '3 1 "cage"', "$EndPhysicalNames",
             "$Nodes", str(len(xyz))]
    lines += ["%d %.17g %.17g %.17g" % (i + 1, *p) for i, p in enumerate(xyz)]
    lines += ["$EndNodes", "$Elements", str(len(tets) + 2)]
    # Two surface triangles first: the reader must skip them.
    lines += ["1 2 2 1 1 %d %d %d" % (tets[0][0] + 1, tets[0][1] + 1, tets[0][2] + 1),
              "2 2 2 1 1 %d %d %d" % (tets[1][0] + 1, tets[1][1] + 1, tets[1][2] + 1)]
    lines += ["%d 4 2 1 1 %d %d %d %d" % (i + 3, *(c + 1 for c in t)) for i, t in enumerate(tets)]
    lines += ["$EndElements"]
    return ("\n".join(lines) + "\n").encode()


def write_msh41(xyz, tets):
    n, m = len(xyz), len(tets)
    lines = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat", "$Entities", "0 0 0 1", "1 -1 -1 -1 1 1 1 0 0",
             "$EndEntities", "$Nodes", "1 %d 1 %d" % (n, n), "3 1 0 %d" % n]
    lines += [str(i + 1) for i in range(n)]
    lines += ["%.17g %.17g %.17g" % p for p in xyz]
    lines += ["$EndNodes", "$Elements", "2 %d 1 %d" % (m + 1, m + 1), "2 1 2 1",
              "1 %d %d %d" % tuple(c + 1 for c in tets[0][:3]), "3 1 4 %d" % m]
    lines += ["%d %d %d %d %d" % (i + 2, *(c + 1 for c in t)) for i, t in enumerate(tets)]
    lines += ["$EndElements"]
    return ("\n".join(lines) + "\n").encode()


def write_medit(xyz, tets):
    lines = ["MeshVersionFormatted 2", "", "Dimension 3", "", "Vertices", str(len(xyz))]
    lines += ["%.17g %.17g %.17g 0" % p for p in xyz]
    lines += ["", "Triangles", "1", "%d %d %d 1" % tuple(c + 1 for c in tets[0][:3]), "", "Tetrahedra", str(len(tets))]
    lines += ["%d %d %d %d 1" % tuple(c + 1 for c in t) for t in tets]
    lines += ["", "End"]
    return ("\n".join(lines) + "\n").encode()


def scene_text(bundle, centre, radius):
    cx, cy, cz = centre
    return f"""# fuzz-cli seed scene: most of the reader's keys (see docs/scene-example.toml)
[solver]
dt = 0.004166666666666667
min_dt = 0.0
max_substep = 0.016666666666666666
solver = "cg"
tolerance = 1e-4
max_iterations = 500
preconditioner = "cholesky"
refactor_iterations = 8
stiffness = "warped"
rotation = "arc"
threads = 1
max_splits_per_step = 64

[features]
fracture = true
collisions = true
self_collision = true
collision_mode = "spheres"
mass_weighting = true

[environment]
gravity = [0.0, -9.81, 0.0]

[environment.ground]
normal = [0.0, 1.0, 0.0]
offset = 0.0
restitution = 0.2
friction = 0.6

[[environment.box]]
min = [0.5, 0.0, -0.5]
max = [0.7, 0.3, 0.5]
restitution = 0.2
friction = 0.5

[[environment.sphere]]
center = [-0.5, 0.1, 0.0]
radius = 0.1
restitution = 0.2
friction = 0.5

[[object]]
name = "sphere"
bundle = "{bundle}"
translation = [0.0, {-(cy - radius) + 0.002:.6f}, 0.0]
rotation = {{ axis = [0.0, 1.0, 0.0], degrees = 30.0 }}
scale = 1.0
velocity = [0.0, -0.5, 0.0]
angular_velocity = [0.0, 1.0, 0.0]
color = [0.78, 0.74, 0.68]
interior_color = [0.80, 0.45, 0.36]

[object.material]
density = 1000.0
youngs_modulus = 2e5
poisson_ratio = 0.3
toughness = 0.8
rayleigh_mass = 0.0
rayleigh_stiffness = 0.002
restitution = 0.2
friction = 0.5

[[object.pin]]
box = {{ min = [-1.0, -1.0, -1.0], max = [1.0, 0.03, 1.0] }}

[[object.pin]]
nodes = [0, 1, 2]

[camera]
position = [0.5, 0.4, 0.8]
target = [{cx:.4f}, {cy:.4f}, {cz:.4f}]
fov = 30.0
up = [0.0, 1.0, 0.0]

[[projectile]]
radius = 0.02
mass = 0.5
position = [{cx - radius - 0.05:.4f}, {radius + 0.002:.4f}, {cz:.4f}]
velocity = [12.0, 0.0, 0.0]
launch_time = 0.0
restitution = 0.5
friction = 0.3
"""


def bundle_scene_text(bundle):
    return f"""[solver]
dt = 0.004166666666666667
threads = 1

[features]
fracture = true
collisions = true
self_collision = true

[environment]
gravity = [0.0, -9.81, 0.0]

[environment.ground]
normal = [0.0, 1.0, 0.0]
offset = 0.0

[[object]]
bundle = "{bundle}"
velocity = [0.0, -1.0, 0.0]

[object.material]
toughness = 0.8
"""


# ----------------------------------------------------------------------------- mutations

SPECIAL_NUMBERS = ["0", "-0", "-1", "1", "2", "3", "nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1e308", "-1e308",
                   "1e309", "1e-320", "2147483647", "2147483648", "-2147483648", "-2147483649", "4294967295",
                   "4294967296", "9223372036854775807", "9223372036854775808", "18446744073709551615",
                   "18446744073709551616", "-9223372036854775809", "1" + "0" * 40, "9" * 400, "0x7fffffff",
                   "1.5", "1e5", "100000000", "1000000000000", "65536", "256", "", "abc", "1e", "--1", "1.2.3"]
SPECIAL_BYTES = [0x00, 0xFF, 0x7F, 0x80, 0x01, 0x20, 0x0A, 0x0D, 0x2D, 0x23, 0x30, 0x39]
SPECIAL_INTS = [0, 1, 2, 3, 4, 0x7F, 0x80, 0xFF, 0x100, 0x7FFF, 0x8000, 0xFFFF, 0x10000, 0x7FFFFFFF, 0x80000000,
                0xFFFFFFFF, 0x100000000, 0x7FFFFFFFFFFFFFFF, 0x8000000000000000, 0xFFFFFFFFFFFFFFFF, 1000000000]
TEXT_INSERTS = [b"\x00", b"\r", b"\r\n", b"\t", b"\xff\xfe", b"#", b"-", b" ", b"\n", b"\n\n", b" 1e308 ", b" nan ",
                b" -1 ", b" 4294967296 ", b"\xc3\x28", b"\xef\xbb\xbf", b"\\", b"\"", b"'", b"[", b"]", b"{", b"}",
                b"=", b"A" * 5000]
NUMBER_RE = re.compile(rb"(?<![A-Za-z_0-9.\-+])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![A-Za-z_0-9.])")
PLY_TYPES = ["char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8", "uint8", "int16", "uint16",
             "int32", "uint32", "float32", "float64", "quad", "list uchar int", "list int int", "list uint float",
             "list double int", "list uchar uchar", ""]
TOML_VALUES = ['"x"', '""', "[]", "[1, 2]", "[1, 2, 3, 4]", "[0.0, 0.0, 0.0]", "[1e308, 1e308, 1e308]",
               "[nan, nan, nan]", "{}", "{ a = 1 }", "true", "false", "1e400", "nan", "inf", "-inf", "-0.0", "0", "-1",
               "9223372036854775807", "99999999999999999999", "1e-320", "2024-01-01T00:00:00Z", "12:00:00",
               '"' + "A" * 10000 + '"', '"/dev/zero"', '"."', '"../"', "[[1, 2], [3]]", '[1, "a"]', "1_000",
               "0x10", "'lit'", '"""multi\nline"""', "[", '"unterminated']


def pick_pos(rng, n, regions=None):
    if n == 0:
        return 0
    if regions and rng.random() < 0.7:
        a, b = rng.choice(regions)
        b = min(b, n)
        if b > a:
            return rng.randrange(a, b)
    return rng.randrange(n)


def m_bitflip(data, rng, ctx):
    data = bytearray(data)
    k = rng.choice([1, 1, 2, 4, 8])
    where = []
    for _ in range(k):
        if not data:
            break
        p = pick_pos(rng, len(data), ctx.get("regions"))
        bit = rng.randrange(8)
        data[p] ^= 1 << bit
        where.append("%d.%d" % (p, bit))
    return bytes(data), "bitflip@" + ",".join(where)


def m_setbytes(data, rng, ctx):
    if not data:
        return data, "setbytes(empty)"
    data = bytearray(data)
    p = pick_pos(rng, len(data), ctx.get("regions"))
    n = min(rng.choice([1, 2, 4, 8, 16]), len(data) - p)
    value = rng.choice(SPECIAL_BYTES) if rng.random() < 0.5 else None
    for i in range(n):
        data[p + i] = value if value is not None else rng.randrange(256)
    return bytes(data), "setbytes@%d+%d=%s" % (p, n, "%02x" % value if value is not None else "random")


def m_setint(data, rng, ctx, pos=None):
    width = rng.choice([1, 2, 4, 4, 8])
    if len(data) < width:
        return data, "setint(short)"
    p = pos if pos is not None else pick_pos(rng, len(data) - width + 1, ctx.get("regions"))
    p = min(p, len(data) - width)
    v = rng.choice(SPECIAL_INTS) & ((1 << (8 * width)) - 1)
    if rng.random() < 0.3:
        old = int.from_bytes(data[p:p + width], "little")
        v = (old + rng.choice([-1, 1, -2, 2, 1 << (8 * width - 1)])) & ((1 << (8 * width)) - 1)
    order = "little" if rng.random() < 0.8 else "big"
    return data[:p] + v.to_bytes(width, order) + data[p + width:], "setint@%d:%d%s=%d" % (p, width, order[0], v)


def m_insert(data, rng, ctx):
    p = pick_pos(rng, len(data) + 1, ctx.get("regions"))
    if ctx.get("text") and rng.random() < 0.6:
        ins = rng.choice(TEXT_INSERTS)
        desc = "insert@%d %r" % (p, ins[:12])
    else:
        ins = bytes(rng.randrange(256) for _ in range(rng.choice([1, 2, 4, 16, 64])))
        desc = "insert@%d %d random bytes" % (p, len(ins))
    return data[:p] + ins + data[p:], desc


def m_delete(data, rng, ctx):
    if not data:
        return data, "delete(empty)"
    p = pick_pos(rng, len(data), ctx.get("regions"))
    n = rng.randint(1, max(1, min(256, (len(data) - p) // 2 or 1)))
    return data[:p] + data[p + n:], "delete@%d+%d" % (p, n)


def m_duplicate(data, rng, ctx):
    if not data:
        return data, "duplicate(empty)"
    p = pick_pos(rng, len(data), ctx.get("regions"))
    n = rng.randint(1, max(1, min(1024, len(data) - p)))
    q = rng.randrange(len(data) + 1)
    return data[:q] + data[p:p + n] + data[q:], "duplicate %d+%d to %d" % (p, n, q)


def m_truncate(data, rng, ctx):
    p = rng.randrange(len(data) + 1) if data else 0
    return data[:p], "truncate@%d of %d" % (p, len(data))


def split_lines(data):
    return data.splitlines(keepends=True)


def m_line_dup(data, rng, ctx):
    lines = split_lines(data)
    if not lines:
        return data, "dupline(empty)"
    i = rng.randrange(len(lines))
    times = rng.choice([1, 1, 2, 10, 1000])
    line = lines[i] if lines[i].endswith(b"\n") else lines[i] + b"\n"
    lines[i:i] = [line] * times
    return b"".join(lines), "dupline %d x%d" % (i + 1, times)


def m_line_delete(data, rng, ctx):
    lines = split_lines(data)
    if not lines:
        return data, "delline(empty)"
    i = rng.randrange(len(lines))
    del lines[i]
    return b"".join(lines), "delline %d" % (i + 1)


def m_line_swap(data, rng, ctx):
    lines = split_lines(data)
    if len(lines) < 2:
        return data, "swaplines(short)"
    i, j = rng.sample(range(len(lines)), 2)
    if not lines[-1].endswith(b"\n"):
        lines[-1] += b"\n"
    lines[i], lines[j] = lines[j], lines[i]
    return b"".join(lines), "swaplines %d %d" % (i + 1, j + 1)


def m_cut_midline(data, rng, ctx):
    lines = split_lines(data)
    if not lines:
        return data, "cut(empty)"
    i = rng.randrange(len(lines))
    start = sum(len(l) for l in lines[:i])
    p = start + rng.randrange(max(1, len(lines[i].rstrip(b"\r\n"))))
    return data[:p], "cut at line %d col %d" % (i + 1, p - start + 1)


def replace_number(data, rng, matches, where):
    if not matches:
        return data, "number(none %s)" % where
    m = rng.choice(matches)
    old = m.group(0)
    choices = list(SPECIAL_NUMBERS)
    try:
        v = int(old)
        choices += [str(v + 1), str(v - 1), str(v * 2), str(v * 1000), str(-v)]
    except ValueError:
        pass
    new = rng.choice(choices).encode()
    line = data.count(b"\n", 0, m.start()) + 1
    return data[:m.start()] + new + data[m.end():], "number %s line %d: %s -> %s" % (where, line, old[:20].decode(
        "latin-1"), new[:20].decode("latin-1") + ("…" if len(new) > 20 else ""))


def header_span(ctx, data):
    """(start, end) byte offsets of the header lines, per format."""
    fmt = ctx["format"]
    lines = split_lines(data)
    idx = []
    if fmt.startswith("ply"):
        for i, l in enumerate(lines):
            idx.append(i)
            if l.strip() == b"end_header":
                break
    elif fmt in ("node", "ele", "stl-ascii", "obj"):
        for i, l in enumerate(lines):
            if l.strip() and not l.lstrip().startswith(b"#"):
                idx.append(i)
                break
        if fmt == "stl-ascii":
            idx.append(len(lines) - 1)
        if fmt == "obj":
            idx += [i for i, l in enumerate(lines[:4]) if not l.startswith(b"v")]
    elif fmt.startswith("msh"):
        for i, l in enumerate(lines):
            if l.startswith(b"$"):
                idx.append(i)
                if i + 1 < len(lines) and not lines[i + 1].startswith(b"$"):
                    idx.append(i + 1)
    elif fmt == "medit":
        for i, l in enumerate(lines):
            if l[:1].isalpha():
                idx.append(i)
                if i + 1 < len(lines) and lines[i + 1].strip()[:1].isdigit():
                    idx.append(i + 1)
    elif fmt == "scene":
        idx = [i for i, l in enumerate(lines) if l.lstrip().startswith(b"[")]
    return lines, sorted(set(idx))


def m_number(data, rng, ctx):
    if rng.random() < 0.5:
        lines, idx = header_span(ctx, data)
        if idx:
            offsets = []
            pos = 0
            starts = []
            for l in lines:
                starts.append(pos)
                pos += len(l)
            for i in idx:
                offsets.append((starts[i], starts[i] + len(lines[i])))
            matches = [m for m in NUMBER_RE.finditer(data) if any(a <= m.start() < b for a, b in offsets)]
            if ctx.get("format", "").startswith("ply"):
                matches = [m for m in matches if m.start() < ctx.get("header_len", len(data))]
            if matches:
                return replace_number(data, rng, matches, "in header")
    limit = ctx.get("header_len") if ctx.get("format") == "ply-bin" else None
    matches = [m for m in NUMBER_RE.finditer(data[:limit] if limit else data)]
    return replace_number(data, rng, matches, "anywhere")


def m_drop_header_line(data, rng, ctx):
    lines, idx = header_span(ctx, data)
    if not idx:
        return m_line_delete(data, rng, ctx)
    i = rng.choice(idx)
    text = lines[i].strip()[:30].decode("latin-1")
    del lines[i]
    return b"".join(lines), "drop header line %d (%s)" % (i + 1, text)


def ply_split(data):
    k = data.find(b"end_header\n")
    if k < 0:
        return data, b""
    return data[:k + len(b"end_header\n")], data[k + len(b"end_header\n"):]


def m_ply_header(data, rng, ctx):
    head, body = ply_split(data)
    lines = head.split(b"\n")
    choice = rng.choice(["count", "count", "count", "end_header", "proptype", "proptype", "propdel", "propdup",
                         "format", "elemswap", "extraelem"])
    elems = [i for i, l in enumerate(lines) if l.startswith(b"element ")]
    props = [i for i, l in enumerate(lines) if l.startswith(b"property ")]
    desc = choice
    if choice == "count" and elems:
        i = rng.choice(elems)
        parts = lines[i].split()
        n = int(parts[2]) if len(parts) > 2 and parts[2].isdigit() else 0
        new = rng.choice([0, 1, n - 1, n + 1, 2 * n, 2 ** 31 - 1, 2 ** 31, 2 ** 32 - 1, 2 ** 32, 2 ** 63, 2 ** 64,
                          10 ** 9, 10 ** 12, -1, 100000000])
        lines[i] = b" ".join(parts[:2] + [str(new).encode()])
        desc = "ply count %s %d -> %d" % (parts[1].decode(), n, new)
    elif choice == "end_header":
        lines = [l for l in lines if l != b"end_header"]
        desc = "ply end_header removed"
    elif choice == "proptype" and props:
        i = rng.choice(props)
        parts = lines[i].split()
        name = parts[-1]
        new_type = rng.choice(PLY_TYPES).encode()
        lines[i] = b"property " + new_type + b" " + name
        desc = "ply property %s: %s -> %s" % (name.decode(), b" ".join(parts[1:-1]).decode(), new_type.decode())
    elif choice == "propdel" and props:
        i = rng.choice(props)
        desc = "ply property line removed: %s" % lines[i].decode()
        del lines[i]
    elif choice == "propdup" and props:
        i = rng.choice(props)
        desc = "ply property line duplicated: %s" % lines[i].decode()
        lines.insert(i, lines[i])
    elif choice == "format":
        new = rng.choice([b"format ascii 1.0", b"format binary_little_endian 1.0", b"format binary_big_endian 1.0",
                          b"format ascii 2.0", b"format binary 1.0", b"format"])
        for i, l in enumerate(lines):
            if l.startswith(b"format"):
                desc = "ply %s -> %s" % (l.decode(), new.decode())
                lines[i] = new
                break
    elif choice == "elemswap" and len(elems) >= 2:
        a, b = elems[0], elems[1]
        lines[a], lines[b] = lines[b], lines[a]
        desc = "ply element lines swapped"
    else:
        k = lines.index(b"end_header") if b"end_header" in lines else len(lines)
        n = rng.choice([1, 1000, 10 ** 9, 2 ** 32])
        lines[k:k] = [b"element junk %d" % n, b"property float a"]
        desc = "ply extra element junk %d before end_header" % n
    return b"\n".join(lines) + body, desc


def m_ply_face_count(data, rng, ctx):
    """Binary PLY: set a face's list-count byte."""
    head, body = ply_split(data)
    nv, nf = ctx["ply_nv"], ctx["ply_nf"]
    vsize = 6 * 4 + 3
    i = rng.randrange(nf)
    off = nv * vsize + i * 13
    new = rng.choice([0, 1, 2, 4, 5, 127, 128, 255])
    body = body[:off] + bytes([new]) + body[off + 1:]
    return head + body, "ply face %d list count 3 -> %d" % (i, new)


def m_stl_count(data, rng, ctx):
    return m_setint(data, rng, ctx, pos=80) if rng.random() < 0.3 else _stl_count_exact(data, rng)


def _stl_count_exact(data, rng):
    n = struct.unpack_from("<I", data, 80)[0]
    new = rng.choice([0, 1, n - 1, n + 1, 2 * n, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF, 10 ** 9, 85899345])
    return data[:80] + struct.pack("<I", new) + data[84:], "stl count %d -> %d" % (n, new)


def m_toml_value(data, rng, ctx):
    lines = split_lines(data)
    cand = [i for i, l in enumerate(lines) if re.match(rb"^\s*[A-Za-z_][\w.]*\s*=", l)]
    if not cand:
        return m_line_dup(data, rng, ctx)
    i = rng.choice(cand)
    key, _, old = lines[i].partition(b"=")
    new = rng.choice(TOML_VALUES).encode()
    lines[i] = key + b"= " + new + b"\n"
    return b"".join(lines), "toml %s = %s -> %s" % (key.strip().decode(), old.strip()[:30].decode("latin-1"),
                                                     new[:30].decode("latin-1"))


BYTE_MUTATORS = [(m_bitflip, 3), (m_setbytes, 3), (m_setint, 2), (m_insert, 2), (m_delete, 2), (m_duplicate, 1),
                 (m_truncate, 1)]
LINE_MUTATORS = [(m_line_dup, 2), (m_line_delete, 2), (m_line_swap, 2), (m_number, 5), (m_cut_midline, 1),
                 (m_drop_header_line, 1)]


def mutators_for(fmt):
    if fmt == "bundle":
        return [(m_bitflip, 4), (m_setbytes, 3), (m_setint, 4), (m_insert, 1), (m_delete, 1), (m_duplicate, 1),
                (m_truncate, 1)]
    if fmt == "stl-bin":
        return BYTE_MUTATORS + [(m_stl_count, 3)]
    if fmt == "ply-bin":
        return BYTE_MUTATORS + [(m_ply_header, 6), (m_ply_face_count, 2), (m_number, 2)]
    muts = BYTE_MUTATORS + LINE_MUTATORS
    if fmt == "ply-ascii":
        muts = muts + [(m_ply_header, 6)]
    if fmt == "scene":
        muts = muts + [(m_toml_value, 8)]
    return muts


def mutate(seed_data, fmt, rng, ctx):
    muts = mutators_for(fmt)
    total = sum(w for _, w in muts)
    r = rng.random()
    count = 1 if r < 0.75 else 2 if r < 0.9 else 3
    data, descs = seed_data, []
    for _ in range(count):
        x = rng.uniform(0, total)
        for fn, w in muts:
            x -= w
            if x <= 0:
                break
        data, d = fn(data, rng, ctx)
        descs.append(d)
    return data, "; ".join(descs)


def hdf5_regions(data):
    """Byte ranges of an HDF5 file's metadata, so most bundle mutations hit structure rather than
    array contents: the superblock (v0), every v1 object header (prefix and messages, following
    continuation messages: the attributes and most dataspace/layout messages live in those
    continuation chunks), and the B-tree (TREE), local heap (HEAP) and symbol-table (SNOD) nodes."""
    n = len(data)
    regions = [(0, 96)]
    if data[:8] != b"\x89HDF\r\n\x1a\n" or n < 96 or data[8] != 0:
        return regions
    headers = {struct.unpack_from("<Q", data, 56 + 8)[0]}
    p = data.find(b"SNOD")
    while p >= 0:
        count = struct.unpack_from("<H", data, p + 6)[0] if p + 8 <= n else 0
        regions.append((p, p + 8 + 40 * count))
        for k in range(min(count, 256)):
            e = p + 8 + 40 * k
            if e + 16 <= n:
                headers.add(struct.unpack_from("<Q", data, e + 8)[0])
        p = data.find(b"SNOD", p + 1)
    p = data.find(b"TREE")
    while p >= 0:
        if p + 8 <= n:
            node_type, _level, used = struct.unpack_from("<BBH", data, p + 4)
            key = 8 if node_type == 0 else 8 + 8 * 4  # group keys: a heap offset; chunk keys: size, mask, offsets
            regions.append((p, p + 24 + used * (key + 8) + key))
        p = data.find(b"TREE", p + 1)
    p = data.find(b"HEAP")
    while p >= 0:
        regions.append((p, p + 32))
        if p + 32 <= n:
            size, _free, seg = struct.unpack_from("<QQQ", data, p + 8)
            if seg < n:
                regions.append((seg, seg + min(size, 4096)))
        p = data.find(b"HEAP", p + 1)
    for a in sorted(headers):
        if a + 16 > n or data[a] != 1:
            continue
        regions.append((a, a + 16))
        chunks, seen = [(a + 16, a + 16 + struct.unpack_from("<I", data, a + 8)[0])], set()
        while chunks:
            q, end = chunks.pop()
            if (q, end) in seen:
                continue
            seen.add((q, end))
            end = min(end, n)
            while q + 8 <= end:
                mtype, size = struct.unpack_from("<HH", data, q)
                regions.append((q, min(q + 8 + size, end)))
                if mtype == 0x10 and q + 24 <= n:  # continuation: address, length
                    off, length = struct.unpack_from("<QQ", data, q + 8)
                    if off < n:
                        chunks.append((off, off + min(length, 65536)))
                q += 8 + size
    return [(a, min(b, n)) for a, b in regions if a < min(b, n)]


# ----------------------------------------------------------------------------- running

def signal_name(num):
    try:
        return signal.Signals(num).name
    except ValueError:
        return "SIG%d" % num


class Runner:
    def __init__(self, args, out):
        self.timeout = args.timeout
        self.mem_bytes = args.mem_mib * 1024 * 1024
        self.out = out

    def run(self, argv, cwd):
        """Run argv under timeout, /usr/bin/time and prlimit; return a result dict."""
        rss_file = Path(cwd) / ".rss"
        cmd = ["timeout", "-k", "5", str(self.timeout), "/usr/bin/time", "-f", "%M", "-o", str(rss_file),
               "prlimit", "--as=%d" % self.mem_bytes, "--core=0", "--"] + [str(a) for a in argv]
        start = time.monotonic()
        python_timeout = False
        proc = subprocess.Popen(cmd, cwd=str(cwd), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, start_new_session=True)
        try:
            stdout, stderr = proc.communicate(timeout=self.timeout + 30)
        except subprocess.TimeoutExpired:
            python_timeout = True
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            stdout, stderr = proc.communicate()
        elapsed = time.monotonic() - start
        rc = proc.returncode
        info = rss_file.read_text(errors="replace").splitlines() if rss_file.exists() else []
        rss_file.unlink(missing_ok=True)
        rss_kib, sig, status = None, None, None
        for line in info:
            m = re.match(r"Command terminated by signal (\d+)", line)
            if m:
                sig = int(m.group(1))
            m = re.match(r"Command exited with non-zero status (\d+)", line)
            if m:
                status = int(m.group(1))
            if line.strip().isdigit():
                rss_kib = int(line.strip())
        err = stderr.decode("utf-8", "replace")
        # timeout exits 124 after TERMing the group; 137/-9 when it had to SIGKILL (or was killed itself).
        hung = python_timeout or rc == 124 or (rc in (137, -9) and elapsed >= self.timeout - 0.5)
        if hung:
            kind, detail = "hang", "killed after %.1f s" % elapsed
        elif sig is not None or rc < 0:
            s = sig if sig is not None else -rc
            detail = signal_name(s)
            if OOM_RE.search(err) or s == signal.SIGKILL:
                kind = "oom"
            else:
                kind = "crash"
        elif rc == 0:
            kind, detail = "ok", ""
        else:
            code = status if status is not None else rc
            detail = "exit %d" % code
            if OOM_RE.search(err):
                kind = "oom"
            elif code == 1:
                kind = "error"
            elif code == 2:
                kind = "internal"
            else:
                kind = "other"
        return {"kind": kind, "detail": detail, "rc": rc, "signal": signal_name(sig) if sig else None,
                "elapsed": round(elapsed, 3), "rss_kib": rss_kib, "stderr": err, "stdout": stdout.decode(
                    "utf-8", "replace")}


# ----------------------------------------------------------------------------- campaign

class Campaign:
    def __init__(self, args):
        self.args = args
        self.out = Path(args.out).resolve()
        self.seeds = self.out / "seeds"
        self.work = self.out / "work"
        self.findings = self.out / "findings"
        self.bake = str(Path(args.bake).resolve())
        self.player = str(Path(args.player).resolve())
        self.runner = Runner(args, self.out)
        self.lock = threading.Lock()

    def prepare(self):
        self.out.mkdir(parents=True, exist_ok=True)
        for d in (self.seeds, self.work, self.findings):
            shutil.rmtree(d, ignore_errors=True)
            d.mkdir()
        for f in ("summary.md", "summary.json", "results.jsonl"):
            (self.out / f).unlink(missing_ok=True)
        node, ele = DATA / "cages" / (CAGE_STEM + ".node"), DATA / "cages" / (CAGE_STEM + ".ele")
        xyz, tets = read_tetgen(node, ele)
        verts, faces = seed_mesh(xyz, tets)
        self.centre = tuple(sum(v[k] for v in verts) / len(verts) for k in range(3))
        self.radius = max(norm(sub(v, self.centre)) for v in verts)
        s = self.seeds
        files = {
            "obj": ("seed.obj", write_obj(verts, faces)),
            "ply-ascii": ("seed-ascii.ply", write_ply_ascii(verts, faces)),
            "ply-bin": ("seed-bin.ply", write_ply_binary(verts, faces)),
            "stl-ascii": ("seed-ascii.stl", write_stl_ascii(verts, faces)),
            "stl-bin": ("seed-bin.stl", write_stl_binary(verts, faces)),
            "node": ("cage.node", node.read_bytes()),
            "ele": ("cage.ele", ele.read_bytes()),
            "msh22": ("cage-22.msh", write_msh22(xyz, tets)),
            "msh41": ("cage-41.msh", write_msh41(xyz, tets)),
            "medit": ("cage.mesh", write_medit(xyz, tets)),
        }
        self.seed_files = {}
        for fmt, (name, data) in files.items():
            (s / name).write_bytes(data)
            self.seed_files[fmt] = s / name
        for name, (ext, writer) in inputs.ASSIMP_SEEDS.items():
            (s / ("seed" + ext)).write_bytes(writer(verts, faces))
            self.seed_files[name] = s / ("seed" + ext)
        self.seed_verts, self.seed_faces = verts, faces
        self.seed_mesh = s / "seed.obj"
        self.seed_cage = s / "cage.node"
        # The bundle: baked here with the given fissure-bake.
        bundle = s / "seed.h5"
        res = self.runner.run([self.bake, "-q", "-j", "1", "bake", "--mesh", self.seed_mesh, "--cage",
                               self.seed_cage, "-o", bundle], self.work)
        if res["kind"] != "ok" or not bundle.exists():
            sys.exit("fuzz-cli: baking the seed bundle failed (%s %s):\n%s" % (res["kind"], res["detail"],
                                                                               res["stderr"][-2000:]))
        self.seed_files["bundle"] = bundle
        # Scene cases live in work/<case>/, two levels below OUT.
        (s / "scene.toml").write_text(scene_text("../../seeds/seed.h5", self.centre, self.radius))
        self.seed_files["scene"] = s / "scene.toml"
        self.seed_data = {fmt: p.read_bytes() for fmt, p in self.seed_files.items()}
        self.fixed = {name: make(self) for name, make in inputs.FIXED_CLASSES.items()}
        head, _ = ply_split(self.seed_data["ply-bin"])
        self.ctx_extra = {"ply_nv": len(verts), "ply_nf": len(faces), "header_len": len(head)}
        self.hdf5_regions = hdf5_regions(self.seed_data["bundle"])

    def bake_argv(self, mesh, cage, out):
        return [self.bake, "-q", "-j", "1", "bake", "--mesh", mesh, "--cage", cage, "-o", out]

    def case_scene(self, case_dir):
        """The seed scene in a case folder (work/<case>/), where its bundle path holds."""
        path = case_dir / "scene.toml"
        path.write_bytes(self.seed_data["scene"])
        return path

    def run_argv(self, scene, render=False, steps="3"):
        return [self.player, "-q", "run", scene, "--steps", steps, "-j", "1"] + ([] if render else ["--no-render"])

    def run_fixed_case(self, fmt, case):
        desc, build = self.fixed[fmt][case]
        case_dir = self.work / ("%s-%04d" % (fmt, case))
        shutil.rmtree(case_dir, ignore_errors=True)
        case_dir.mkdir(parents=True)
        results = []
        for label, argv, named, check in build(self, case_dir):
            res = self.runner.run(argv, case_dir)
            res["label"] = label
            res["argv"] = [str(a) for a in argv]
            res["names_file"] = named is None or named.name in res["stderr"] or named.name in res["stdout"]
            problem = check()
            if problem:
                res["kind"], res["detail"] = "replaced", problem
            results.append(res)
        saved = []
        if any(r["kind"] in SAVED_KINDS for r in results):
            d = self.findings / fmt
            d.mkdir(parents=True, exist_ok=True)
            lines = ["class: %s" % fmt, "case:  %d: %s" % (case, desc), ""]
            for r in results:
                lines += ["$ " + " ".join(shquote(a) for a in r["argv"]),
                          "-> %s (%s), %.2f s, peak RSS %s KiB" % (r["kind"], r["detail"], r["elapsed"], r["rss_kib"]),
                          "stderr tail:", tail(r["stderr"], 20), ""]
            (d / ("case-%04d.txt" % case)).write_text("\n".join(lines))
            saved.append(str((d / ("case-%04d.txt" % case)).relative_to(self.out)))
        shutil.rmtree(case_dir, ignore_errors=True)
        return {"format": fmt, "case": case, "mutation": desc, "size": 0, "ran_rejected": False, "saved": saved,
                "results": results}

    def commands(self, fmt, case_path, case_dir):
        """[(label, argv, path of the file the message should name)]"""
        kind = FORMATS[fmt][1]
        out_h5 = case_dir / "out.h5"
        if kind == "mesh":
            return [("bake", [self.bake, "-q", "-j", "1", "bake", "--mesh", case_path, "--cage", self.seed_cage,
                              "-o", out_h5], case_path)]
        if kind == "cage":
            return [("bake", [self.bake, "-q", "-j", "1", "bake", "--mesh", self.seed_mesh, "--cage", case_path,
                              "-o", out_h5], case_path)]
        if kind == "scene":
            return [("run", [self.player, "-q", "run", case_path, "--steps", "3", "--no-render", "-j", "1"],
                     case_path)]
        scene = case_dir / (case_path.stem + "-scene.toml")
        scene.write_text(bundle_scene_text(case_path.name))
        return [("inspect", [self.bake, "-q", "inspect", case_path], case_path),
                ("verify", [self.bake, "-q", "verify", case_path], case_path),
                ("run", [self.player, "-q", "run", scene, "--steps", "3", "--no-render", "-j", "1"], case_path)]

    def write_case(self, fmt, case, data, ext=None):
        ext = ext or FORMATS[fmt][0]
        case_dir = self.work / ("%s-%04d" % (fmt, case))
        shutil.rmtree(case_dir, ignore_errors=True)
        case_dir.mkdir(parents=True)
        path = case_dir / ("case-%04d%s" % (case, ext))
        path.write_bytes(data)
        if fmt == "node":
            (case_dir / ("case-%04d.ele" % case)).write_bytes(self.seed_data["ele"])
        if fmt == "ele":
            (case_dir / ("case-%04d.node" % case)).write_bytes(self.seed_data["node"])
        return case_dir, path

    def run_case(self, fmt, case):
        if fmt in inputs.FIXED_CLASSES:
            return self.run_fixed_case(fmt, case)
        rng = random.Random("%s:%s:%d" % (self.args.seed, fmt, case))
        source, ext = fmt, None
        if fmt == "assimp-any":
            source = rng.choice(MESH_SEEDS)
            ext = "." + rng.choice(inputs.ASSIMP_EXTENSIONS)
        ctx = {"format": source, "text": FORMATS[source][2], **self.ctx_extra}
        if fmt == "bundle":
            ctx["regions"] = self.hdf5_regions
        if source != "ply-bin":
            ctx.pop("header_len", None)
        data, desc = mutate(self.seed_data[source], source, rng, ctx)
        if ext:
            desc = "%s seed as %s: %s" % (source, ext, desc)
        case_dir, path = self.write_case(fmt, case, data, ext)
        results = []
        for label, argv, named in self.commands(fmt, path, case_dir):
            res = self.runner.run(argv, case_dir)
            res["label"] = label
            res["argv"] = [str(a) for a in argv]
            # verify prints its failure report (ending "NAME: INVALID") on stdout, the others on stderr.
            res["names_file"] = named.name in res["stderr"] or (label == "verify" and named.name in res["stdout"])
            results.append(res)
        # Player ran a bundle that verify rejects.
        ran_rejected = False
        if fmt == "bundle":
            by = {r["label"]: r for r in results}
            ran_rejected = by["verify"]["kind"] == "error" and by["run"]["kind"] == "ok"
        saved = self.save_findings(fmt, case, desc, case_dir, path, results, ran_rejected)
        shutil.rmtree(case_dir, ignore_errors=True)
        return {"format": fmt, "case": case, "mutation": desc, "size": len(data), "ran_rejected": ran_rejected,
                "saved": saved, "results": results}

    def save_findings(self, fmt, case, desc, case_dir, path, results, ran_rejected):
        saved = []
        kinds = sorted({r["kind"] for r in results if r["kind"] in SAVED_KINDS})
        if ran_rejected:
            kinds.append("ran-rejected")
        for kind in kinds:
            d = self.findings / fmt
            d.mkdir(parents=True, exist_ok=True)
            stem = "%s-%04d" % (kind, case)
            target = d / (stem + path.suffix)
            shutil.copyfile(path, target)
            mapping = {str(path): str(target)}
            for other in case_dir.iterdir():  # the TetGen partner and the bundle's scene
                if other == path or other.name.startswith(".") or other.name == "out.h5":
                    continue
                if other.suffix in (".node", ".ele"):
                    o = d / (stem + other.suffix)
                    shutil.copyfile(other, o)
                elif other.suffix == ".toml":
                    o = d / (stem + "-scene.toml")
                    o.write_text(bundle_scene_text(target.name))
                else:
                    continue
                mapping[str(other)] = str(o)
            lines = ["format:   %s" % fmt, "case:     %d (--seed %s)" % (case, self.args.seed),
                     "mutation: %s" % desc, ""]
            for r in results:
                if r["kind"] != kind and not (kind == "ran-rejected" and r["label"] in ("verify", "run")):
                    continue
                argv = [mapping.get(a, a).replace(str(case_dir / "out.h5"), str(d / "out.h5")) for a in r["argv"]]
                lines += ["$ " + " ".join(shquote(a) for a in argv),
                          "-> %s (%s), %.2f s, peak RSS %s KiB" % (r["kind"], r["detail"], r["elapsed"], r["rss_kib"]),
                          "stderr tail:", tail(r["stderr"], 40)]
                if r["label"] == "verify" or not r["stderr"].strip():
                    lines += ["stdout tail:", tail(r["stdout"], 20)]
                lines.append("")
            (d / (stem + ".txt")).write_text("\n".join(lines))
            saved.append(str(target.relative_to(self.out)))
        return saved


def shquote(s):
    return s if re.match(r"^[\w@%+=:,./-]+$", s) else "'" + s.replace("'", "'\\''") + "'"


def tail(text, n):
    lines = text.rstrip("\n").splitlines()
    return "\n".join(("    " + l)[:400] for l in lines[-n:]) if lines else "    (empty)"


def parse_cases(spec, formats):
    counts = {}
    default = 300
    for part in spec.split(","):
        part = part.strip()
        if not part:
            continue
        if "=" in part:
            k, v = part.split("=", 1)
            counts[k.strip()] = int(v)
        else:
            default = int(part)
    unknown = set(counts) - set(FORMATS)
    if unknown:
        sys.exit("fuzz-cli: unknown format in --cases: %s" % ", ".join(sorted(unknown)))
    # A fixed class runs all its cases unless given a count of its own.
    return {f: counts.get(f, -1 if f in inputs.FIXED_CLASSES else default) for f in formats}


def row_key(fmt, label):
    return "%s:%s" % (fmt, label) if FORMATS[fmt][1] in ("bundle", "special", "flags", "many") else fmt


def summarise(records, counts):
    rows = {}
    for rec in records:
        for r in rec["results"]:
            key = row_key(rec["format"], r["label"])
            row = rows.setdefault(key, {"cases": 0, **{k: 0 for k in KINDS}, "errors_naming_file": 0,
                                        "signals": {}, "other_codes": {}, "peak_rss_kib": 0, "max_seconds": 0.0,
                                        "ran_rejected": 0, "findings": {k: [] for k in SAVED_KINDS}})
            row["cases"] += 1
            row[r["kind"]] += 1
            if r["kind"] == "error" and r["names_file"]:
                row["errors_naming_file"] += 1
            if r["kind"] in ("crash", "oom") and r["signal"]:
                row["signals"][r["signal"]] = row["signals"].get(r["signal"], 0) + 1
            if r["kind"] == "other":
                row["other_codes"][r["detail"]] = row["other_codes"].get(r["detail"], 0) + 1
            row["peak_rss_kib"] = max(row["peak_rss_kib"], r["rss_kib"] or 0)
            row["max_seconds"] = max(row["max_seconds"], r["elapsed"])
            if r["label"] == "run" and rec["ran_rejected"]:
                row["ran_rejected"] += 1
            if r["kind"] in SAVED_KINDS:
                row["findings"][r["kind"]].append({"case": rec["case"], "mutation": rec["mutation"],
                                                   "detail": r["detail"],
                                                   "stderr_tail": tail(r["stderr"], 6).strip()})
    return rows


def markdown(rows, meta):
    out = ["# fuzz-cli summary", "",
           "seed %s, timeout %s s, address space %s MiB; cases per format: %s" % (
               meta["seed"], meta["timeout"], meta["mem_mib"],
               ", ".join("%s=%d" % kv for kv in meta["cases"].items())), "",
           "| format | cases | ok | clean errors (name file) | internal (exit 2) | crashes | hangs | out of memory "
           "| outputs replaced | other | peak RSS max (MiB) | max s | notes |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for key, r in rows.items():
        notes = []
        if r["signals"]:
            notes.append("signals " + ", ".join("%s×%d" % kv for kv in sorted(r["signals"].items())))
        if r["other_codes"]:
            notes.append("other " + ", ".join("%s×%d" % kv for kv in sorted(r["other_codes"].items())))
        if key.endswith(":run") and key.startswith("bundle"):
            notes.append("ran a bundle verify rejects: %d" % r["ran_rejected"])
        out.append("| %s | %d | %d | %d (%d) | %d | %d | %d | %d | %d | %d | %.1f | %.2f | %s |" % (
            key, r["cases"], r["ok"], r["error"], r["errors_naming_file"], r["internal"], r["crash"], r["hang"],
            r["oom"], r["replaced"], r["other"], r["peak_rss_kib"] / 1024.0, r["max_seconds"], "; ".join(notes)))
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bake", required=True, help="fissure-bake binary")
    ap.add_argument("--player", required=True, help="fissure-player binary")
    ap.add_argument("--out", required=True, help="output folder (seeds, work, findings, summaries)")
    ap.add_argument("--cases", default="300", help='cases per format: "300" or "300,ply-ascii=100,bundle=150"')
    ap.add_argument("--seed", default="1", help="campaign seed (same seed, same mutants)")
    ap.add_argument("--timeout", type=float, default=20.0, help="seconds per run before it counts as a hang")
    ap.add_argument("--mem-mib", type=int, default=4096, help="address-space limit per run (prlimit --as)")
    ap.add_argument("--formats", default=",".join(FORMATS), help="comma-separated subset of: " + ", ".join(FORMATS))
    ap.add_argument("--jobs", type=int, default=1, help="cases run in parallel")
    ap.add_argument("--fail-on", default="",
                    help='exit 1 when any run ends in one of these kinds, e.g. "crash,hang,oom" (CI)')
    args = ap.parse_args()
    formats = [f.strip() for f in args.formats.split(",") if f.strip()]
    bad = [f for f in formats if f not in FORMATS]
    if bad:
        ap.error("unknown format(s): %s" % ", ".join(bad))
    for program in (args.bake, args.player):
        if not os.access(program, os.X_OK):
            sys.exit("fuzz-cli: %s is not an executable (build it first)" % program)
    for tool in ("timeout", "prlimit"):
        if not shutil.which(tool):
            sys.exit("fuzz-cli: needs %s on PATH" % tool)
    if not Path("/usr/bin/time").exists():
        sys.exit("fuzz-cli: needs GNU time at /usr/bin/time")
    counts = parse_cases(args.cases, formats)
    camp = Campaign(args)
    camp.prepare()
    for fmt in formats:
        if counts[fmt] < 0 or fmt in camp.fixed:
            total = len(camp.fixed.get(fmt, []))
            counts[fmt] = total if counts[fmt] < 0 else min(counts[fmt], total)

    # The seeds themselves must pass, or the campaign measures nothing.
    for fmt in formats:
        if fmt not in camp.seed_data:
            continue  # assimp-any and the fixed classes have no seed of their own
        case_dir, path = camp.write_case(fmt, -1, camp.seed_data[fmt])
        for label, argv, _ in camp.commands(fmt, path, case_dir):
            r = camp.runner.run(argv, case_dir)
            if r["kind"] != "ok":
                print("fuzz-cli: WARNING: the %s seed fails %s: %s %s\n%s" % (fmt, label, r["kind"], r["detail"],
                                                                             tail(r["stderr"], 8)), flush=True)
            else:
                print("seed %-10s %-8s ok  %.2f s  %.1f MiB" % (fmt, label, r["elapsed"], (r["rss_kib"] or 0) / 1024),
                      flush=True)
        shutil.rmtree(case_dir, ignore_errors=True)

    records = []
    started = time.monotonic()
    with open(camp.out / "results.jsonl", "w") as log:
        for fmt in formats:
            t0 = time.monotonic()
            tally = {k: 0 for k in KINDS}
            done = 0
            with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
                for rec in pool.map(lambda c: camp.run_case(fmt, c), range(counts[fmt])):
                    records.append(rec)
                    slim = dict(rec)
                    slim["results"] = [{k: v for k, v in r.items() if k not in ("stdout", "argv")} | {
                        "stderr": tail(r["stderr"], 6).strip()} for r in rec["results"]]
                    log.write(json.dumps(slim) + "\n")
                    done += 1
                    for r in rec["results"]:
                        tally[r["kind"]] += 1
                    if done % 50 == 0 or done == counts[fmt]:
                        print("%-10s %4d/%d  %s  (%.0f s)" % (fmt, done, counts[fmt], " ".join(
                            "%s=%d" % (k, v) for k, v in tally.items() if v), time.monotonic() - t0), flush=True)
    shutil.rmtree(camp.work, ignore_errors=True)

    meta = {"seed": args.seed, "timeout": args.timeout, "mem_mib": args.mem_mib, "cases": counts,
            "bake": os.path.basename(args.bake), "player": os.path.basename(args.player),
            "wall_seconds": round(time.monotonic() - started, 1)}
    rows = summarise(records, counts)
    md = markdown(rows, meta)
    (camp.out / "summary.md").write_text(md)
    (camp.out / "summary.json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    print()
    print(md)
    print("findings: %s (%d files); summary: %s" % (
        camp.findings, sum(1 for p in camp.findings.rglob("*") if p.is_file() and p.suffix != ".txt"),
        camp.out / "summary.md"))
    failing = {k.strip() for k in args.fail_on.split(",") if k.strip()}
    found = sum(1 for rec in records for r in rec["results"] if r["kind"] in failing)
    if found:
        sys.exit("fuzz-cli: %d runs ended in %s" % (found, ", ".join(sorted(failing))))


if __name__ == "__main__":
    main()

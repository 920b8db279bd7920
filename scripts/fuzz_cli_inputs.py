"""Input classes for scripts/fuzz-cli.py beyond the mutated seeds of its first round
(issue 46): seeds in more of the formats assimp reads for the bake, and fixed cases
(streams and special files, flags at their extremes, scenes with thousands of entries).
Standard library only; imported by fuzz-cli.py."""

import base64
import json
import os
import socket
import stat
import struct

# ----------------------------------------------------------------------------- assimp seeds
# The same lumpy sphere as the OBJ seed, in each text or binary format the bake hands to
# assimp whose writer fits in a few lines. Each one bakes (fuzz-cli checks the seeds first).


def write_off(verts, faces):
    lines = ["OFF", "%d %d 0" % (len(verts), len(faces))]
    lines += ["%.9g %.9g %.9g" % v for v in verts]
    lines += ["3 %d %d %d" % f for f in faces]
    return ("\n".join(lines) + "\n").encode()


def write_collada(verts, faces):
    positions = " ".join("%.9g %.9g %.9g" % v for v in verts)
    indices = " ".join("%d %d %d" % f for f in faces)
    return ("""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="meter" meter="1"/><up_axis>Y_UP</up_axis></asset>
  <library_geometries>
    <geometry id="g" name="sphere">
      <mesh>
        <source id="g-pos">
          <float_array id="g-pos-array" count="%d">%s</float_array>
          <technique_common>
            <accessor source="#g-pos-array" count="%d" stride="3">
              <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="g-vtx"><input semantic="POSITION" source="#g-pos"/></vertices>
        <triangles count="%d">
          <input semantic="VERTEX" source="#g-vtx" offset="0"/>
          <p>%s</p>
        </triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="s"><node id="n" name="sphere"><instance_geometry url="#g"/></node></visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
""" % (3 * len(verts), positions, len(verts), len(faces), indices)).encode()


def write_smd(verts, faces):
    lines = ["version 1", "nodes", '0 "root" -1', "end", "skeleton", "time 0", "0 0 0 0 0 0 0", "end", "triangles"]
    for f in faces:
        lines.append("material")
        for i in f:
            lines.append("0 %.9g %.9g %.9g 0 0 1 0 0" % verts[i])
    lines.append("end")
    return ("\n".join(lines) + "\n").encode()


def write_nff(verts, faces):
    lines = ["# fuzz-cli seed: a lumpy sphere", "f 0.8 0.7 0.6 1 0 0 0 0"]
    for f in faces:
        lines.append("p 3")
        lines += ["%.9g %.9g %.9g" % verts[i] for i in f]
    return ("\n".join(lines) + "\n").encode()


def write_raw(verts, faces):
    lines = ["sphere"]
    lines += [" ".join("%.9g %.9g %.9g" % verts[i] for i in f) for f in faces]
    return ("\n".join(lines) + "\n").encode()


def write_ac3d(verts, faces):
    lines = ["AC3Db", 'MATERIAL "m" rgb 1 1 1  amb 0.2 0.2 0.2  emis 0 0 0  spec 0.5 0.5 0.5  shi 10  trans 0',
             "OBJECT world", "kids 1", "OBJECT poly", 'name "sphere"', "numvert %d" % len(verts)]
    lines += ["%.9g %.9g %.9g" % v for v in verts]
    lines.append("numsurf %d" % len(faces))
    for f in faces:
        lines += ["SURF 0x10", "mat 0", "refs 3"] + ["%d 0 0" % i for i in f]
    lines.append("kids 0")
    return ("\n".join(lines) + "\n").encode()


def gltf_parts(verts, faces):
    positions = b"".join(struct.pack("<3f", *v) for v in verts)
    indices = b"".join(struct.pack("<3I", *f) for f in faces)
    lo = [min(v[k] for v in verts) for k in range(3)]
    hi = [max(v[k] for v in verts) for k in range(3)]
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "sphere"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(positions) + len(indices)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(positions), "target": 34962},
                        {"buffer": 0, "byteOffset": len(positions), "byteLength": len(indices), "target": 34963}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(verts), "type": "VEC3", "min": lo,
                       "max": hi},
                      {"bufferView": 1, "componentType": 5125, "count": 3 * len(faces), "type": "SCALAR"}],
    }
    return doc, positions + indices


def write_gltf(verts, faces):
    doc, data = gltf_parts(verts, faces)
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    return json.dumps(doc, indent=1).encode()


def write_glb(verts, faces):
    doc, data = gltf_parts(verts, faces)
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    data += b"\0" * (-len(data) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(data), 0x004E4942) + data
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


# name: (extension, writer). Each becomes a mutated format of the campaign ("assimp-dae" …).
ASSIMP_SEEDS = {
    "off": (".off", write_off),
    "dae": (".dae", write_collada),
    "smd": (".smd", write_smd),
    "nff": (".nff", write_nff),
    "raw": (".raw", write_raw),
    "ac": (".ac", write_ac3d),
    "gltf": (".gltf", write_gltf),
    "glb": (".glb", write_glb),
}

# Every extension assimp 5.2 claims (Assimp::Importer::GetExtensionList), less .ply
# (Fissure's own reader). The "assimp-any" class hands a mutant of a random seed to the
# bake under one of these, so each reader sees bytes it did not expect.
ASSIMP_EXTENSIONS = (
    "3d 3ds 3mf ac ac3d acc amf ase ask assbin b3d blend bsp bvh cob csm dae dxf enff fbx glb gltf hmp ifc ifczip "
    "iqm irr irrmesh lwo lws lxo m3d md2 md3 md5anim md5camera md5mesh mdc mdl mesh mesh.xml mot ms3d ndo nff obj off "
    "ogex pk3 pmx prj q3o q3s raw scn sib smd step stl stp ter uc vta x x3d x3db xgl xml zae zgl").split()


# ----------------------------------------------------------------------------- fixed cases
# Each class is a list of cases; a case is (description, build) where build(camp, d) makes
# whatever the case needs in its folder d and returns [(label, argv, file the message should
# name, check)]. check() runs after the command and returns "" or what went wrong with an
# output that must survive (a FIFO replaced by a regular file is kind "replaced").


def _link(d, name, target):
    path = d / name
    os.symlink(target, path)
    return path


def _fifo(d, name):
    path = d / name
    os.mkfifo(path, 0o600)
    return path


def _socket(d, name):
    path = d / name
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.bind(str(path))
    s.close()  # the socket file stays
    return path


def _device(d, name):
    """A character device node of our own (a copy of /dev/null's numbers): only as root.
    Never /dev/null itself: an old binary would replace the system's."""
    path = d / name
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    except (PermissionError, OSError):
        return None
    return path


def _kind(path):
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return "missing"
    for test, name in ((stat.S_ISFIFO, "fifo"), (stat.S_ISSOCK, "socket"), (stat.S_ISCHR, "char"),
                       (stat.S_ISBLK, "block"), (stat.S_ISLNK, "link"), (stat.S_ISDIR, "dir"), (stat.S_ISREG, "file")):
        if test(mode):
            return name
    return "other"


def _survives(path):
    before = _kind(path)
    return lambda: "" if _kind(path) == before else "%s: was a %s, now a %s" % (path.name, before, _kind(path))


def _none():
    return ""


# Input sources that are not regular files. Opening a FIFO without a writer blocks for
# ever: a reader must refuse it before opening.
STREAMS = {
    "dev-zero": lambda d, name: _link(d, name, "/dev/zero"),
    "dev-urandom": lambda d, name: _link(d, name, "/dev/urandom"),
    "dev-null": lambda d, name: _link(d, name, "/dev/null"),
    "fifo": _fifo,
    "socket": _socket,
    "directory": lambda d, name: (d / name).mkdir() or d / name,
    "link-loop": lambda d, name: _link(d, name, name),
    "empty": lambda d, name: (d / name).write_bytes(b"") or d / name,
}


def special_cases(camp):
    cases = []
    for source, make in STREAMS.items():
        def mesh(c, d, make=make):
            path = make(d, "mesh.obj")
            return [("bake", c.bake_argv(path, c.seed_cage, d / "out.h5"), path, _none)]

        def cage(c, d, make=make):
            path = make(d, "cage.node")
            (d / "cage.ele").write_bytes(c.seed_data["ele"])
            return [("bake", c.bake_argv(c.seed_mesh, path, d / "out.h5"), path, _none)]

        def scene(c, d, make=make):
            path = make(d, "scene.toml")
            return [("run", c.run_argv(path), path, _none)]

        def bundle(c, d, make=make):
            path = make(d, "bundle.h5")
            scene_path = d / "bundle-scene.toml"
            scene_path.write_text('[[object]]\nbundle = "bundle.h5"\n')
            return [("inspect", [c.bake, "-q", "inspect", path], path, _none),
                    ("verify", [c.bake, "-q", "verify", path], path, _none),
                    ("run", c.run_argv(scene_path), path, _none)]
        for role, build in (("mesh", mesh), ("cage", cage), ("scene", scene), ("bundle", bundle)):
            cases.append(("%s is %s" % (role, source), build))

    outputs = {"fifo": _fifo, "socket": _socket, "device": _device}
    for kind, make in outputs.items():
        def bake_out(c, d, make=make):
            path = make(d, "out.h5")
            if path is None:
                return []
            return [("bake", c.bake_argv(c.seed_mesh, c.seed_cage, path), path, _survives(path))]

        def junit_out(c, d, make=make):
            path = make(d, "junit.xml")
            if path is None:
                return []
            return [("verify", [c.bake, "-q", "verify", c.seed_files["bundle"], "--junit", path], path, _survives(path))]

        def player_out(c, d, make=make):
            runs = []
            for option in ("--report", "--trajectory", "--video", "--frames"):
                path = make(d, "out" + option.replace("-", "_"))
                if path is None:
                    return []
                argv = c.run_argv(c.case_scene(d), render=option in ("--video", "--frames")) + [option, path]
                runs.append(("run", argv, path, _survives(path)))
            return runs
        cases += [("-o is a %s" % kind, bake_out), ("--junit is a %s" % kind, junit_out),
                  ("player outputs are %ss" % kind, player_out)]
    return cases


# Flags at their extremes, each given alone to an otherwise good command.
BAKE_FLAGS = [
    ["--sphere-radius", v] for v in ("nan", "inf", "-inf", "-1", "0", "1e-300", "1e-12", "1e-5", "1e-4", "1e308",
                                     "1e999", "0x10", "")] + [
    ["--wall-res", v] for v in ("0", "1", "2", "1024", "4096", "4097", "-1", "2147483648", "1e9", "nan")] + [
    ["--wall-memory-budget", v] for v in ("nan", "inf", "0", "-1", "1e-12", "1e15", "1e308")] + [
    ["--winding-accuracy", v] for v in ("nan", "-nan", "inf", "0", "1", "100", "100.0001", "1e308")] + [
    ["-j", v] for v in ("-1", "0", "256", "257", "1e9", "nan")] + [
    ["--only", "walls", "--skip", "collision"], ["--only", "frobnicate"], ["--weld", "--weld"], ["--frobnicate"], []]

PLAYER_FLAGS = [
    ["--steps", v] for v in ("-1", "0", "1e9", "9223372036854775807", "9223372036854775808", "nan", "")] + [
    ["--fps", v] for v in ("0", "-1", "1001", "2147483648", "nan")] + [
    ["--size", v] for v in ("0x0", "1x1", "100000x100000", "65536x65536", "-1x-1", "nanxnan", "x", "1x")] + [
    ["--tessellation", v] for v in ("nan", "-nan", "inf", "-1", "0", "64", "64.5", "1e308")] + [
    ["--trajectory-every", v] for v in ("0", "-1", "1e9", "2147483648", "nan")] + [
    ["-j", v] for v in ("-1", "257", "nan")] + [
    ["--backend", "vulkan"], ["--no-render", "--frames", "x"], ["--frobnicate"]]


def flag_cases(camp):
    cases = []
    for flags in BAKE_FLAGS:
        def build(c, d, flags=flags):
            # Options that belong to the program come before the subcommand.
            argv = c.bake_argv(c.seed_mesh, c.seed_cage, d / "out.h5")
            if flags[:1] == ["-j"]:
                argv = [c.bake, "-q"] + flags + argv[argv.index("bake"):]
            else:
                argv = argv + flags
            return [("bake", argv, None, _none)]
        cases.append(("bake " + " ".join(flags), build))
    for flags in PLAYER_FLAGS:
        def build(c, d, flags=flags):
            render = any(f in ("--size", "--fps", "--tessellation", "--backend") for f in flags)
            argv = c.run_argv(c.case_scene(d), render=render, steps="3")
            if render:
                argv += ["--frames", d / "frames"]
            argv = [a for a in argv if not (flags[:1] == ["--steps"] and a in ("--steps", "3"))]
            return [("run", argv + flags, None, _none)]
        cases.append(("run " + " ".join(flags), build))
    return cases


# Scenes and meshes with many entries: at and past each limit, and far past it.
def _scene_with(camp, d, extra):
    bundle = os.path.relpath(camp.seed_files["bundle"], d)
    text = '[solver]\ndt = 0.004166666666666667\nthreads = 1\n\n[environment.ground]\n\n'
    text += '[[object]]\nbundle = "%s"\ntranslation = [0.0, 0.1, 0.0]\n\n' % bundle
    path = d / "many.toml"
    path.write_text(text + extra(bundle))
    return path


SCENE_ENTRIES = {
    "objects overlapping x%d": lambda n: lambda b: ''.join(
        '[[object]]\nbundle = "%s"\ntranslation = [0.0, 0.1, 0.0]\n\n' % b for _ in range(n - 1)),
    "projectiles x%d": lambda n: lambda b: ''.join(
        '[[projectile]]\nradius = 0.01\nmass = 0.1\nposition = [%g, 0.5, 0.0]\nvelocity = [0.0, -1.0, 0.0]\n\n' %
        (0.001 * i) for i in range(n)),
    "boxes x%d": lambda n: lambda b: ''.join(
        '[[environment.box]]\nmin = [%g, 0.0, 1.0]\nmax = [%g, 0.1, 1.1]\n\n' % (0.01 * i, 0.01 * i + 0.005)
        for i in range(n)),
    "spheres x%d": lambda n: lambda b: ''.join(
        '[[environment.sphere]]\ncenter = [%g, 0.0, 1.0]\nradius = 0.01\n\n' % (0.01 * i) for i in range(n)),
    "pins x%d": lambda n: lambda b: '[[object]]\nbundle = "%s"\ntranslation = [1.0, 0.1, 0.0]\n\n' % b + ''.join(
        '[[object.pin]]\nnodes = [0]\n\n' for _ in range(n)),
    "pin nodes x%d": lambda n: lambda b: '[[object]]\nbundle = "%s"\ntranslation = [1.0, 0.1, 0.0]\n\n' % b +
        '[[object.pin]]\nnodes = [%s]\n\n' % ", ".join(str(i % 7) for i in range(n)),
}
SCENE_COUNTS = {
    "objects overlapping x%d": (2, 64, 256, 257, 1001),
    "projectiles x%d": (1024, 1025, 5000),
    "boxes x%d": (4096, 4097, 100000),
    "spheres x%d": (4096, 100000),
    "pins x%d": (4096, 4097),
    "pin nodes x%d": (100000,),
}


def _obj_many_objects(verts, faces, copies):
    lines = []
    for k in range(copies):
        lines.append("o piece%d" % k)
        lines += ["v %.9g %.9g %.9g" % v for v in verts[:3]]
        lines.append("f -3 -2 -1")
    return ("\n".join(lines) + "\n").encode()


def _obj_repeated(verts, faces, copies):
    lines = ["v %.9g %.9g %.9g" % v for v in verts]
    body = ["f %d %d %d" % (f[0] + 1, f[1] + 1, f[2] + 1) for f in faces]
    return ("\n".join(lines + body * copies) + "\n").encode()


def _gltf_instances(verts, faces, copies, primitives=1):
    doc = json.loads(write_gltf(verts, faces))
    doc["meshes"][0]["primitives"] = doc["meshes"][0]["primitives"] * primitives
    doc["nodes"] = [{"mesh": 0} for _ in range(copies)]
    doc["scenes"] = [{"nodes": list(range(copies))}]
    return json.dumps(doc).encode()


MESH_ENTRIES = [
    ("obj faces repeated x5000", ".obj", lambda v, f: _obj_repeated(v, f, 5000)),
    ("obj 20000 one-triangle objects", ".obj", lambda v, f: _obj_many_objects(v, f, 20000)),
    ("gltf 5000 node instances", ".gltf", lambda v, f: _gltf_instances(v, f, 5000)),
    ("gltf 3000 primitives", ".gltf", lambda v, f: _gltf_instances(v, f, 1, 3000)),
]


def many_cases(camp):
    cases = []
    for name, counts in SCENE_COUNTS.items():
        for n in counts:
            def build(c, d, name=name, n=n):
                path = _scene_with(c, d, SCENE_ENTRIES[name](n))
                # The energy check would stop most piles at step 1: run all 40 steps.
                return [("run", c.run_argv(path, steps="40") + ["--no-energy-check"], path, _none)]
            cases.append((name % n, build))
    for name, ext, write in MESH_ENTRIES:
        def build(c, d, ext=ext, write=write):
            path = d / ("many" + ext)
            path.write_bytes(write(c.seed_verts, c.seed_faces))
            return [("bake", c.bake_argv(path, c.seed_cage, d / "out.h5"), path, _none)]
        cases.append((name, build))
    return cases


FIXED_CLASSES = {"special": special_cases, "flags": flag_cases, "many": many_cases}

#!/usr/bin/python3
"""Side-by-side comparison of align3d, Open3D 0.16 and PCL 1.13 on the same data in the same run.

Usage:
  bench/compare.py [SCENE_DIR ...] [--scenes chapter,parts-100k,parts-1m] [--runs 5] [--warmup 1]
                   [--systems align3d,align3d-auto,align3d-all-normals,open3d,pcl] [--tasks icp-point,icp-plane,...]
                   [--init perturbed|identity] [--max-distance D] [--json FILE]
                   [--load N] [--wait-idle PCT] [--baseline-build [LABEL=]DIR ...]

A scene is a directory with model.ply (the target), scan.ply (the source) and ground_truth.txt
(4x4, model ≈ T·scan). Named scenes (--scenes) are generated with the align3d CLI into --cache:
  chapter          `align3d synth DIR` (the chapter's conveyor scene)
  wide-plane, small-features, large-offset, extreme   `align3d synth DIR --variant NAME`
  parts-100k, parts-1m, parts-N   `align3d synth DIR --scene parts --points N` (k = 1e3, m = 1e6)

Runners (one command-line contract, bench/runner_common.hpp): build/align3d_run (main build with
-DALIGN3D_BUILD_BENCH=ON; also runs the `align3d (auto)` row with --auto and, for point-to-plane,
the `align3d (all normals)` row with --all-normals), build-peers/open3d_run and build-peers/pcl_run
(cmake -S bench/peers -B build-peers). A runner that is not built is skipped with a note.

Settings, the same for every system:
  init  ground truth × P, P = rotation by 4° about the axis (1, -1, 2)/√6 through the scan's
        centroid, then a translation of 1 % of the target's bounding-box diagonal L along
        (2, 1, -2)/3 (in the scan frame); --init identity starts from the identity instead.
  D     maximum correspondence distance = 2 % of L (--max-distance overrides).
  N     iteration cap 60 (--max-iterations); convergence at relative RMS change 1e-6.
  K     20 nearest neighbours for normals (--k);  T = threads (--threads, default: all cores).
  V     coarse-stage voxel = L / 50 (--voxel).
Each task is timed inside the runner after the files are read (wall clock; CPU time of all the
process's threads alongside, a check when the machine is busy). Runs are interleaved (A B C A B C
...) after --warmup warm-up rounds; the table gives the median time of --runs runs. Peak memory is
the whole process's maximum resident set (getrusage), so it includes each library's own footprint;
bytes/point divides it by source + target points.

A shared machine: --load N keeps N CPUs busy during all runs (warm-ups included) with N busy-loop
processes, the k-th pinned to the k-th CPU this script may use, so that a run meets the same
competition every time (bench/README.md, "Shared machine"). On a host shared with other work,
--wait-idle PCT waits before each round until the CPUs not kept busy by --load were at least PCT %
idle over half a second (Linux's /proc/stat), so that other jobs' bursts do not land in some
rounds only. --baseline-build [LABEL=]DIR adds
the row `align3d (LABEL)` (default label: baseline): DIR/align3d_run, another build of align3d
(e.g. main's), interleaved with the others, to compare versions on the same data in the same run;
it may be given more than once.

The deviation step of `align3d inspect` (signed distances of a scan to a CAD mesh) against
CloudCompare's C2M and Open3D's RaycastingScene: `bench/compare.py inspect [OPTIONS]`, which runs
bench/compare_inspect.py (its own --help; it shares this file's machine helpers).
"""
import argparse
import atexit
import json
import math
import os
import re
import statistics
import struct
import subprocess
import sys
import time

TASKS = ["normals", "icp-point", "icp-plane", "global"]
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# ---------------------------------------------------------------------------------------------
# Small linear algebra on 4x4 row-major lists (no numpy).


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def rotation(axis, deg):
    n = math.sqrt(sum(x * x for x in axis))
    x, y, z = (v / n for v in axis)
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    C = 1 - c
    return [[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
            [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
            [z * x * C - y * s, z * y * C + x * s, c + z * z * C]]


def transform(R, t):
    return [R[0] + [t[0]], R[1] + [t[1]], R[2] + [t[2]], [0.0, 0.0, 0.0, 1.0]]


def rotation_error_deg(T, truth):
    """Angle of E = R_estᵀ·R_gt, from both its trace and its skew part (atan2), so that it stays
    accurate for tiny angles and for single-precision matrices (PCL's), where acos of the trace
    alone would round 1e-3° to 0 or to 0.02°."""
    E = [[sum(T[k][i] * truth[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    c = (E[0][0] + E[1][1] + E[2][2] - 1) / 2
    s = 0.5 * math.sqrt((E[2][1] - E[1][2]) ** 2 + (E[0][2] - E[2][0]) ** 2 +
                        (E[1][0] - E[0][1]) ** 2)
    return math.degrees(math.atan2(s, c))


def translation_error(T, truth):
    return math.sqrt(sum((T[i][3] - truth[i][3]) ** 2 for i in range(3)))


def read_matrix(path):
    vals = []
    with open(path) as f:
        for line in f:
            vals += [float(x) for x in line.split("#")[0].replace(",", " ").split()]
    if len(vals) != 16:
        sys.exit(f"{path}: expected a 4x4 matrix")
    return [vals[4 * i:4 * i + 4] for i in range(4)]


def write_matrix(path, T):
    with open(path, "w") as f:
        for row in T:
            f.write(" ".join(f"{x:.17g}" for x in row) + "\n")


# ---------------------------------------------------------------------------------------------
# PLY vertices (ascii or binary; enough for the scenes' bounding box and centroid).

PLY_TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
             "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
             "float": "f", "float32": "f", "double": "d", "float64": "d"}


def ply_points(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            sys.exit(f"{path}: not a PLY file")
        fmt, count, props, element = None, 0, [], None
        while True:
            line = f.readline().decode("ascii", "replace").split()
            if not line:
                continue
            if line[0] == "format":
                fmt = line[1]
            elif line[0] == "element":
                element = line[1]
                if element == "vertex":
                    count = int(line[2])
            elif line[0] == "property" and element == "vertex":
                if line[1] == "list":
                    sys.exit(f"{path}: list properties on vertices are not supported")
                props.append((line[2], PLY_TYPES[line[1]]))
            elif line[0] == "end_header":
                break
        names = [p[0] for p in props]
        ix, iy, iz = names.index("x"), names.index("y"), names.index("z")
        if fmt == "ascii":
            for _ in range(count):
                v = f.readline().split()
                yield float(v[ix]), float(v[iy]), float(v[iz])
        else:
            endian = "<" if fmt == "binary_little_endian" else ">"
            record = struct.Struct(endian + "".join(p[1] for p in props))
            data = f.read(record.size * count)
            for v in record.iter_unpack(data):
                yield v[ix], v[iy], v[iz]


def cloud_stats(path):
    lo, hi, s, n = [math.inf] * 3, [-math.inf] * 3, [0.0] * 3, 0
    for p in ply_points(path):
        for i in range(3):
            lo[i] = min(lo[i], p[i])
            hi[i] = max(hi[i], p[i])
            s[i] += p[i]
        n += 1
    diagonal = math.sqrt(sum((hi[i] - lo[i]) ** 2 for i in range(3)))
    return diagonal, [x / n for x in s], n


# ---------------------------------------------------------------------------------------------
# Scenes.


def make_scene(name, cache, cli):
    """A directory for a scene name or path; None (with a note) when it cannot be made."""
    if os.path.isdir(name):
        return name
    out = os.path.join(cache, name)
    if os.path.isfile(os.path.join(out, "ground_truth.txt")):
        return out
    variants = ["chapter", "wide-plane", "small-features", "large-offset", "extreme"]
    m = re.fullmatch(r"parts-(\d+)([km]?)", name)
    if name in variants:
        cmd = [cli, "synth", out] + ([] if name == "chapter" else ["--variant", name])
    elif m:
        n = int(m.group(1)) * {"": 1, "k": 1000, "m": 1000000}[m.group(2)]
        cmd = [cli, "synth", out, "--scene", "parts", "--points", str(n)]
    else:
        print(f"note: scene {name}: neither a directory nor a known name; skipped", file=sys.stderr)
        return None
    if not os.access(cli, os.X_OK):
        print(f"note: scene {name}: {cli} not built; skipped", file=sys.stderr)
        return None
    print(f"generating {name}: {' '.join(cmd)}", file=sys.stderr)
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        print(f"note: scene {name}: `{' '.join(cmd)}` failed: {p.stderr.strip()}; skipped",
              file=sys.stderr)
        return None
    return out


# ---------------------------------------------------------------------------------------------
# Runs.

SYSTEMS = {  # key: (display name, runner path option, extra arguments)
    "align3d": ("align3d", "align3d_run", []),
    "align3d-auto": ("align3d (auto)", "align3d_run", ["--auto"]),
    "align3d-all-normals": ("align3d (all normals)", "align3d_run", ["--all-normals"]),
    "open3d": ("Open3D", "open3d_run", []),
    "pcl": ("PCL", "pcl_run", []),
}

# The align3d variants run only the tasks they change: `auto` is an ICP setting; `--all-normals`
# estimates every target normal before point-to-plane ICP, as Open3D and PCL do (align3d itself
# estimates only those its pairs use).
VARIANT_TASKS = {"align3d-auto": ("icp-point", "icp-plane"), "align3d-all-normals": ("icp-plane",)}


def start_load(n):
    """N busy-loop processes, the k-th pinned to the k-th allowed CPU; stopped at exit."""
    cpus = sorted(os.sched_getaffinity(0))
    procs = []
    for k in range(n):
        # Spins, and stops by itself once this script is gone (even if killed).
        spin = (f"import os\nwhile os.getppid() == {os.getpid()}:\n"
                "    for _ in range(1000000): pass")
        p = subprocess.Popen([sys.executable, "-c", spin])
        os.sched_setaffinity(p.pid, {cpus[k % len(cpus)]})
        procs.append(p)

    def stop():
        for p in procs:
            p.kill()
            p.wait()
    atexit.register(stop)
    if n:
        print(f"load: {n} busy loop(s) on CPU {', '.join(str(cpus[k % len(cpus)]) for k in range(n))}",
              file=sys.stderr)
    time.sleep(0.2 if n else 0)  # let them start spinning


def cpu_times():
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:9]]
    return v[3] + v[4], sum(v)  # idle + iowait, total


def wait_idle(pct, load, timeout=600):
    """Waits until the CPUs not kept busy by `load` were `pct` % idle over 0.5 s; seconds waited."""
    if not pct or not os.path.exists("/proc/stat"):
        return 0.0
    cpus = os.cpu_count()
    free = max(1, cpus - load) / cpus
    start = time.monotonic()
    while time.monotonic() - start < timeout:
        i0, t0 = cpu_times()
        time.sleep(0.5)
        i1, t1 = cpu_times()
        if t1 > t0 and (i1 - i0) / (t1 - t0) / free >= pct / 100:
            break
    return time.monotonic() - start - 0.5


def run_once(exe, extra, task, scene, init_path, s, timeout):
    cmd = [exe, task, os.path.join(scene, "scan.ply"), os.path.join(scene, "model.ply"),
           "--init", init_path, "--max-distance", repr(s["max_distance"]),
           "--max-iterations", str(s["max_iterations"]), "--k", str(s["k"]),
           "--threads", str(s["threads"]), "--voxel", repr(s["voxel"])] + extra
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {timeout} s", "command": cmd}
    if p.returncode != 0:
        return {"error": p.stderr.strip()[-500:] or f"exit code {p.returncode}", "command": cmd}
    try:
        out = json.loads(p.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return {"error": "no JSON line on stdout: " + p.stdout[-300:], "command": cmd}
    out["command"] = cmd
    return out


def fmt(x, digits=3):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    if isinstance(x, int):
        return str(x)
    if x == 0:
        return "0"
    if abs(x) >= 100:
        return f"{x:.0f}"
    return f"{x:.{max(0, digits - 1 - int(math.floor(math.log10(abs(x)))))}f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dirs", nargs="*", help="scene directories")
    ap.add_argument("--scenes", default="", help="comma-separated scene names or directories")
    ap.add_argument("--cache", default=os.path.join(REPO, "build", "compare-scenes"))
    ap.add_argument("--cli", default=os.path.join(REPO, "build", "align3d"))
    ap.add_argument("--build", default=os.path.join(REPO, "build"), help="holds align3d_run")
    ap.add_argument("--peers-build", default=os.path.join(REPO, "build-peers"),
                    help="holds open3d_run and pcl_run")
    ap.add_argument("--systems", default="align3d,align3d-auto,align3d-all-normals,open3d,pcl")
    ap.add_argument("--tasks", default=",".join(TASKS))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--init", choices=["perturbed", "identity"], default="perturbed")
    ap.add_argument("--max-distance", type=float, help="default: 2 %% of the target diagonal")
    ap.add_argument("--max-iterations", type=int, default=60)
    ap.add_argument("--k", type=int, default=20)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--voxel", type=float, help="coarse-stage voxel; default: target diagonal / 50")
    ap.add_argument("--timeout", type=float, default=900, help="seconds per run")
    ap.add_argument("--json", help="write every run here")
    ap.add_argument("--load", type=int, default=0,
                    help="keep N CPUs busy during the runs (busy loops, one pinned per CPU)")
    ap.add_argument("--wait-idle", type=float, default=0, metavar="PCT",
                    help="before each round, wait until the free CPUs were PCT %% idle")
    ap.add_argument("--baseline-build", action="append", default=[], metavar="[LABEL=]DIR",
                    help="another build's align3d_run: adds the row align3d (LABEL); repeatable")
    args = ap.parse_args()
    if args.runs < 1 or args.warmup < 0 or args.load < 0:
        sys.exit("--runs >= 1, --warmup >= 0 and --load >= 0")

    systems = [s for s in args.systems.split(",") if s]
    # Other builds of align3d, each a system of its own, placed right after align3d.
    builds = {}
    for k, spec in enumerate(args.baseline_build):
        label, _, folder = spec.rpartition("=")
        key = f"align3d-baseline-{k}"
        SYSTEMS[key] = (f"align3d ({label or 'baseline'})", "align3d_run", [])
        builds[key] = folder
        at = systems.index("align3d") + 1 + k if "align3d" in systems else k
        systems.insert(at, key)
    tasks = [t for t in args.tasks.split(",") if t]
    for s in systems:
        if s not in SYSTEMS:
            sys.exit(f"unknown system {s}; known: {', '.join(SYSTEMS)}")
    for t in tasks:
        if t not in TASKS:
            sys.exit(f"unknown task {t}; known: {', '.join(TASKS)}")
    notes = []
    runners = {}
    for key in systems:
        name, exe_name, extra = SYSTEMS[key]
        folder = builds.get(key) or (args.build if exe_name == "align3d_run" else
                                     args.peers_build)
        exe = os.path.join(folder, exe_name)
        if os.access(exe, os.X_OK):
            runners[key] = (name, exe, extra)
        else:
            notes.append(f"{name}: {exe} is not built; skipped")

    scene_names = [d for d in args.dirs] + [s for s in args.scenes.split(",") if s]
    if not scene_names:
        scene_names = ["chapter"]
    os.makedirs(args.cache, exist_ok=True)
    start_load(args.load)
    results = []
    rows = []
    for scene_name in scene_names:
        scene = make_scene(scene_name, args.cache, args.cli)
        if scene is None:
            notes.append(f"scene {scene_name}: could not be made; skipped")
            continue
        label = os.path.basename(os.path.normpath(scene))
        truth = read_matrix(os.path.join(scene, "ground_truth.txt"))
        diagonal, _, n_target = cloud_stats(os.path.join(scene, "model.ply"))
        _, centroid, n_source = cloud_stats(os.path.join(scene, "scan.ply"))
        settings = {"max_distance": args.max_distance or 0.02 * diagonal,
                    "max_iterations": args.max_iterations, "k": args.k, "threads": args.threads,
                    "voxel": args.voxel or diagonal / 50}
        if args.init == "identity":
            init = transform([[1, 0, 0], [0, 1, 0], [0, 0, 1]], [0, 0, 0])
        else:
            # P = translate(c + δ) · R · translate(−c): 4° about a fixed axis through the scan
            # centroid c, then δ = 1 % of L along a fixed direction.
            R = rotation((1, -1, 2), 4.0)
            d = [2 / 3, 1 / 3, -2 / 3]
            Rc = [sum(R[i][j] * centroid[j] for j in range(3)) for i in range(3)]
            t = [centroid[i] - Rc[i] + 0.01 * diagonal * d[i] for i in range(3)]
            init = matmul(truth, transform(R, t))
        init_path = os.path.join(args.cache, f"{label}.init.txt")
        write_matrix(init_path, init)
        print(f"scene {label}: {n_source} source, {n_target} target points, L = {diagonal:.4g}, "
              f"D = {settings['max_distance']:.4g}, init error {rotation_error_deg(init, truth):.2f}°"
              f" / {translation_error(init, truth):.4g}", file=sys.stderr)

        for task in tasks:
            per_system = {key: [] for key in runners}
            waited = 0.0
            for round_ in range(args.warmup + args.runs):
                waited += wait_idle(args.wait_idle, args.load)
                for key, (name, exe, extra) in runners.items():
                    if task not in VARIANT_TASKS.get(key, TASKS):
                        continue
                    r = run_once(exe, extra, task, scene, init_path, settings, args.timeout)
                    r.update({"scene": label, "system_key": key, "round": round_,
                              "warmup": round_ < args.warmup, "settings": settings,
                              "load": args.load})
                    results.append(r)
                    if "error" in r:
                        print(f"  {name} {task}: FAILED: {r['error']}", file=sys.stderr)
                    elif round_ >= args.warmup:
                        per_system[key].append(r)
                    print(f"  {label} {task} round {round_} {name}: "
                          f"{r.get('time_ms', float('nan')):.1f} ms", file=sys.stderr)
            if waited > 1:
                notes.append(f"{label} {task}: waited {waited:.0f} s in all for idle CPUs")
            reference = None
            for key in runners:
                runs = per_system[key]
                name = runners[key][0]
                if not runs:
                    if task in VARIANT_TASKS.get(key, TASKS):
                        rows.append([label, "", name, task, "failed"] + [""] * 10)
                    continue
                times = [r["time_ms"] for r in runs]
                med = statistics.median(times)
                cpu = statistics.median(r.get("cpu_ms", math.nan) for r in runs)
                if key == "align3d":
                    reference = med
                first = runs[0]
                rss_kb = statistics.median(r["peak_rss_kb"] for r in runs)
                points = first["points_source"] + first["points_target"]
                if task == "normals":
                    rot = trans = None
                    zs = [r.get("normals_mean_abs_z") for r in runs]
                    notes.append(f"{label} normals, {name}: mean |n_z| = {fmt(zs[0], 6)}")
                else:
                    rot = max(rotation_error_deg(r["transformation"], truth) for r in runs)
                    trans = max(translation_error(r["transformation"], truth) for r in runs)
                    stops = sorted({str(r.get("stop")) for r in runs if "stop" in r})
                    if stops:
                        notes.append(f"{label} {task}, {name}: stop {', '.join(stops)}")
                rows.append([label, f"{first['points_source']} / {first['points_target']}", name,
                             task, fmt(first["iterations"]), fmt(first["rms"], 4), fmt(rot, 3),
                             fmt(trans, 3), fmt(med, 3), f"{fmt(min(times), 3)}–{fmt(max(times), 3)}",
                             fmt(cpu, 3), fmt(rss_kb / 1024, 3),
                             fmt(rss_kb * 1024 / points, 3),
                             fmt(med / reference, 3) if reference else "—", len(runs)])

    load = f", {args.load} CPU(s) kept busy" if args.load else ""
    print(f"\n{os.cpu_count()} cores, {args.threads} threads, init {args.init}, "
          f"{args.warmup} warm-up + {args.runs} interleaved runs (median time){load}\n")
    print("| scene | points (source / target) | system | task | iterations | RMS | rot err (deg) "
          "| trans err | time (ms) | min–max (ms) | CPU (ms) | peak RSS (MB) | bytes/point "
          "| time ÷ align3d | runs |")
    print("|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for row in rows:
        print("| " + " | ".join(str(c) for c in row) + " |")
    if notes:
        print()
        for n in notes:
            print(f"- {n}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"runs": results, "notes": notes, "load": args.load}, f, indent=1)


if __name__ == "__main__":
    if sys.argv[1:2] == ["inspect"]:  # the deviation step's peers (compare_inspect.py)
        os.execv(sys.executable, [sys.executable, os.path.join(REPO, "bench", "compare_inspect.py")]
                 + sys.argv[2:])
    main()

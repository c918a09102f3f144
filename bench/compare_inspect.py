#!/usr/bin/python3
"""The deviation step side by side: align3d, CloudCompare's C2M and Open3D's RaycastingScene, on the
same points against the same mesh in the same run.

Usage:
  bench/compare_inspect.py [--points 2000000] [--triangles 30000[,200000]]
                           [--cases full,part,shuffled]
                           [--systems align3d,cloudcompare,open3d,open3d-signed] [--runs 5]
                           [--warmup 1] [--threads 2] [--probes 200000] [--wait-idle PCT]
                           [--load N] [--json FILE] [--cli build/align3d] [--build build]
                           [--baseline-build [LABEL=]DIR ...]

Data (generated once into --cache, reused after): `align3d synth DIR --scene part --points N
--triangles M`, the machined part's CAD mesh part_fine.stl (M = 30000 gives 51 968 triangles,
200000 gives 207 872) and its as-built scan (scan.ply, scanner frame, with the fixture). The scan
is moved into the CAD frame ONCE here (ground_truth.txt, in float64) and written as float32 PLY,
the precision of scan.ply and of CloudCompare's and Open3D's points, so that every system reads
identical coordinates. Cases:
  full   every scan point (the fixture too: the table lies up to 66 mm from the part; its
         distances are computed exactly by all three)
  part   the part points only (scan_truth.ply's labels), as after segmenting the fixture away
  shuffled  the full scan's points in a random order (seed 1). The scan files are in the
         scanner's raster order, which align3d searches as it is (MeshIndex::coherent_order); a
         cloud in no useful order is sorted first (spatial_order): this case shows that cost.
Probe points (--probes, uniform in the part's box grown by 10 mm, float32, seed 1) test the signs
far from the surface too.

Systems, each in a process of its own, timed after reading (build and query apart):
  align3d         build/align3d_run_deviation (bench/run_deviation.cpp): MeshIndex + measure_deviations,
                  max_distance = ∞, double precision, signed (pseudo-normals)
  cloudcompare    `CloudCompare -SILENT -AUTO_SAVE OFF -C_EXPORT_FMT PLY -O SCAN -O MESH -C2M_DIST
                  -SAVE_CLOUDS FILE OUT` with QT_QPA_PLATFORM=offscreen (no X server needed;
                  --cc-display xvfb runs it under `xvfb-run -a` instead). Signed by default in 2.11;
                  its times are its own log's: build = "[computeApproxDistances] Time" (the
                  cloud's octree and the approximate distances that choose its level), query =
                  "[ComputeDistances] Time"; all cores (2.11 has no thread option)
  open3d          this script in runner mode: RaycastingScene(nthreads=T).add_triangles(mesh),
                  one query to commit Embree's BVH (build), then compute_distance(points,
                  nthreads=T) (query): unsigned, float32
  open3d-signed   the same with compute_signed_distance: the sign from counting ray hits
  --baseline-build [LABEL=]DIR adds the row `align3d (LABEL)`: DIR/align3d_run_deviation, another
  build of align3d (e.g. main's, or a proposed change), interleaved with the rest; repeatable.
Runs are interleaved (A B C D A B C D ...) after --warmup rounds; the table gives medians.
Memory: bytes per point = (peak RSS − the same process's RSS before the scan is read, with the
library loaded and the mesh read) ÷ points; for CloudCompare, whose process cannot be asked, peak
RSS − the peak of the same command with the mesh alone (no scan, no C2M).

Accuracy: every system's unsigned distance against align3d's (max and 99.9th percentile of
|Δ|, mm); the worst point of each is decided by brute force in float64 over all triangles.
Signs: against the analytic solid the mesh describes (synth::PartModel::contains, written by the
runner's --oracle-out), on every point farther than 1e-5 mm from the surface (the STL's float32
corners move it by up to ~4e-6 mm), and against the sign of the generator's true deviation on
part points where |δ| > 5σ (noise cannot flip it there).
"""
import argparse
import json
import math
import os
import re
import resource
import statistics
import subprocess
import sys
import time

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from compare import fmt, start_load, wait_idle  # noqa: E402  (the shared-machine helpers)

SYSTEMS = {  # key: display name, what it computes
    "align3d": ("align3d", "signed, float64, exact"),
    "cloudcompare": ("CloudCompare C2M", "signed (face normal), float32 out"),
    "open3d": ("Open3D compute_distance", "unsigned, float32"),
    "open3d-signed": ("Open3D compute_signed_distance", "signed (ray parity), float32"),
}
SURFACE_EPS = 1e-5  # mm: closer points have no decidable sign against the analytic solid

# ---------------------------------------------------------------------------------------------
# Files.

PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2",
             "int16": "i2", "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4",
             "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4", "double": "f8",
             "float64": "f8"}


def read_ply(path):
    """The vertex element of a binary PLY as a numpy structured array (scalar properties only)."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            sys.exit(f"{path}: not a PLY file")
        fmt_, count, props, element = None, 0, [], None
        while True:
            line = f.readline().decode("ascii", "replace").split()
            if not line:
                continue
            if line[0] == "format":
                fmt_ = line[1]
            elif line[0] == "element":
                element = line[1]
                if element == "vertex":
                    count = int(line[2])
            elif line[0] == "property" and element == "vertex":
                props.append((line[2], PLY_TYPES[line[1]]))
            elif line[0] == "end_header":
                break
        if fmt_ not in ("binary_little_endian", "binary_big_endian"):
            sys.exit(f"{path}: {fmt_} PLY is not supported here")
        endian = "<" if fmt_ == "binary_little_endian" else ">"
        dtype = np.dtype([(name, endian + t) for name, t in props])
        return np.frombuffer(f.read(dtype.itemsize * count), dtype=dtype, count=count)


def xyz(vertices):
    return np.ascontiguousarray(np.stack([vertices["x"], vertices["y"], vertices["z"]], axis=1))


def write_ply(path, points):
    points = np.ascontiguousarray(points, dtype="<f4")
    with open(path, "wb") as f:
        f.write((f"ply\nformat binary_little_endian 1.0\ncomment bench/compare_inspect.py\n"
                 f"element vertex {len(points)}\nproperty float x\nproperty float y\n"
                 f"property float z\nend_header\n").encode("ascii"))
        f.write(points.tobytes())


def read_stl_triangles(path):
    """A binary STL's corners, (n, 3, 3) float64 (exactly the file's float32 values)."""
    with open(path, "rb") as f:
        data = f.read()
    n = int.from_bytes(data[80:84], "little")
    if len(data) != 84 + 50 * n:
        sys.exit(f"{path}: not a binary STL")
    record = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attr", "<u2")])
    return np.frombuffer(data, dtype=record, count=n, offset=84)["corners"].astype(np.float64)


def point_triangle_distance(p, tris):
    """Exact (float64) distance from p to each triangle: the plane's foot when it falls inside,
    else the nearest of the three edges."""
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    foot = p - (np.einsum("ij,ij->i", p - a, n) / nn)[:, None] * n
    inside = np.ones(len(tris), dtype=bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, foot - u), n) >= 0
    best = np.where(inside, np.linalg.norm(p - foot, axis=1), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        e = v - u
        t = np.clip(np.einsum("ij,ij->i", p - u, e) / np.einsum("ij,ij->i", e, e), 0, 1)
        best = np.minimum(best, np.linalg.norm(p - (u + t[:, None] * e), axis=1))
    return float(best.min())


# ---------------------------------------------------------------------------------------------
# Data.


def make_data(cache, cli, points, triangles, probes):
    """Generates the scene once; returns paths and the arrays the checks need."""
    folder = os.path.join(cache, f"part-{points}-{triangles}")
    if not os.path.isfile(os.path.join(folder, "scene.json")):
        cmd = [cli, "synth", folder, "--scene", "part", "--points", str(points),
               "--triangles", str(triangles)]
        print(f"generating: {' '.join(cmd)}", file=sys.stderr)
        subprocess.run(cmd, check=True, capture_output=True)
    scene = json.load(open(os.path.join(folder, "scene.json")))
    d = {"dir": folder, "mesh": os.path.join(folder, "part_fine.stl"),
         "triangles": scene["part_fine"]["triangles"], "sigma": scene["scan"]["scanner"]["noise_sigma"]}
    truth = read_ply(os.path.join(folder, "scan_truth.ply"))
    d["label"] = np.asarray(truth["label"])
    d["delta"] = np.asarray(truth["deviation"], dtype=np.float64)
    full = os.path.join(folder, "scan_cad.ply")
    part = os.path.join(folder, "scan_cad_part.ply")
    shuffled = os.path.join(folder, "scan_cad_shuffled.ply")
    probe = os.path.join(folder, f"probes_{probes}.ply")
    if not all(os.path.isfile(f) for f in (full, part, shuffled)):
        T = np.loadtxt(os.path.join(folder, "ground_truth.txt"))
        p = xyz(read_ply(os.path.join(folder, "scan.ply"))).astype(np.float64)
        cad = p @ T[:3, :3].T + T[:3, 3]  # once, in float64, then rounded to float32
        write_ply(full, cad)
        write_ply(part, cad[d["label"] == 0])
        write_ply(shuffled, cad[np.random.default_rng(1).permutation(len(cad))])
    if probes and not os.path.isfile(probe):
        corners = read_stl_triangles(d["mesh"]).reshape(-1, 3)
        lo, hi = corners.min(axis=0) - 10, corners.max(axis=0) + 10
        rng = np.random.default_rng(1)
        write_ply(probe, lo + (hi - lo) * rng.random((probes, 3)))
    d["cases"] = {"full": full, "part": part, "shuffled": shuffled}
    if probes:
        d["cases"]["probes"] = probe
    return d


# ---------------------------------------------------------------------------------------------
# Runners.


def run_json_runner(cmd, error_chars):
    """Runs a runner that prints one JSON line last (align3d_run_deviation, the Open3D runner):
    its dict with the process's wall time and the scan's bytes a point, or {"error": the last
    error_chars characters of its stderr}."""
    start = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = (time.perf_counter() - start) * 1e3
    if p.returncode != 0:
        return {"error": p.stderr.strip()[-error_chars:], "command": cmd}
    r = json.loads(p.stdout.strip().splitlines()[-1])
    r.update({"process_ms": wall, "command": cmd,
              "bytes_per_point": (r["peak_rss_kb"] - r["rss_before_scan_kb"]) * 1024 / r["points"]})
    return r


def run_align3d(exe, scan, mesh, out, threads, oracle=None):
    cmd = [exe, scan, mesh, "--threads", str(threads), "--out", out]
    if oracle:
        cmd += ["--oracle-out", oracle]
    return run_json_runner(cmd, 500)


def cc_command(args, files, out):
    cmd = ["CloudCompare", "-SILENT", "-AUTO_SAVE", "OFF", "-C_EXPORT_FMT", "PLY"]
    for f in files:
        cmd += ["-O", f]
    if out:
        cmd += ["-C2M_DIST", "-SAVE_CLOUDS", "FILE", out]
    env = dict(os.environ)
    if args.cc_display == "xvfb":
        cmd = ["xvfb-run", "-a"] + cmd
    else:
        env["QT_QPA_PLATFORM"] = "offscreen"
    return cmd, env


def run_process(cmd, env):
    """Runs cmd; (returncode, output, wall ms, peak RSS in kB of the process tree's largest)."""
    start = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env)
    output = p.stdout.read().decode("utf-8", "replace")
    _, status, usage = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    return p.returncode, output, (time.perf_counter() - start) * 1e3, usage.ru_maxrss


def run_cloudcompare(args, scan, mesh, out, baseline_kb):
    cmd, env = cc_command(args, [scan, mesh], out)
    code, log, wall, peak = run_process(cmd, env)
    times = re.findall(r"\[computeApproxDistances\] Time: ([\d.]+) s", log)
    query = re.findall(r"\[ComputeDistances\] Time: ([\d.]+) s", log)
    level = re.findall(r"Octree level \(auto\): (\d+)", log)
    if code != 0 or not query or not os.path.isfile(out):
        return {"error": f"exit {code}: " + log[-800:], "command": cmd}
    build = 1e3 * float(times[0]) if times else 0.0
    points = int(re.findall(r"Found one cloud with (\d+) points", log)[0])
    return {"system": "cloudcompare", "points": points, "build_ms": build,
            "query_ms": 1e3 * float(query[0]), "process_ms": wall, "peak_rss_kb": peak,
            "octree_level": int(level[0]) if level else None, "command": cmd,
            "bytes_per_point": (peak - baseline_kb) * 1024 / points if baseline_kb else None}


def cloudcompare_baseline(args, mesh):
    cmd, env = cc_command(args, [mesh], None)
    code, log, _, peak = run_process(cmd, env)
    return peak if code == 0 else None


def run_open3d(signed, scan, mesh, out, threads):
    cmd = [sys.executable, os.path.abspath(__file__), "--open3d-runner",
           "signed" if signed else "unsigned", scan, mesh, out, "--threads", str(threads)]
    return run_json_runner(cmd, 800)


def current_rss_kb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024


def open3d_runner(mode, scan, mesh_path, out, threads):
    """Runner mode (a process of its own): Open3D's distances, one JSON line on stdout."""
    import open3d as o3d
    # The legacy reader: Debian's 0.16.1 o3d.t.io.read_triangle_mesh returns a binary STL's
    # vertices in [-1, 1] with zero area (its distances are then off by up to 80 mm).
    legacy = o3d.io.read_triangle_mesh(mesh_path)
    mesh = o3d.t.geometry.TriangleMesh.from_legacy(legacy)
    before = current_rss_kb()
    points = o3d.core.Tensor(xyz(read_ply(scan)))  # float32, as read
    start = time.perf_counter()
    scene = o3d.t.geometry.RaycastingScene(nthreads=threads)
    scene.add_triangles(mesh)
    # Embree's BVH is built on the first query (RaycastingScene commits lazily): one point.
    scene.compute_distance(o3d.core.Tensor([[0.0, 0.0, 0.0]], dtype=o3d.core.float32),
                           nthreads=threads)
    build = time.perf_counter()
    query = scene.compute_signed_distance if mode == "signed" else scene.compute_distance
    d = query(points, nthreads=threads)
    end = time.perf_counter()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    d.numpy().astype("<f8").tofile(out)
    print(json.dumps({"system": "open3d-signed" if mode == "signed" else "open3d",
                      "points": int(points.shape[0]), "triangles": len(legacy.triangles),
                      "build_ms": (build - start) * 1e3, "query_ms": (end - build) * 1e3,
                      "rss_before_scan_kb": before, "peak_rss_kb": peak}))


# ---------------------------------------------------------------------------------------------
# Checks.


def read_distances(system, path):
    if system == "cloudcompare":
        v = read_ply(path)
        field = [n for n in v.dtype.names if n not in ("x", "y", "z")][0]
        return np.asarray(v[field], dtype=np.float64), xyz(v)
    return np.fromfile(path, dtype="<f8"), None


def accuracy(ours, theirs, points, tris):
    """max and 99.9 % of ||theirs| − |ours||, and the worst point decided by brute force."""
    diff = np.abs(np.abs(theirs) - np.abs(ours))
    i = int(np.argmax(diff))
    exact = point_triangle_distance(points[i].astype(np.float64), tris)
    return {"max": float(diff[i]), "p999": float(np.quantile(diff, 0.999)), "worst_point":
            points[i].tolist(), "ours": float(ours[i]), "theirs": float(theirs[i]),
            "brute_force": exact}


def sign_report(name, d, inside, decided):
    wrong = int(((d < 0) != (inside == 1))[decided].sum())
    return f"{name}: {wrong} of {int(decided.sum())} signs wrong ({100 * wrong / max(1, decided.sum()):.3g} %)"


# ---------------------------------------------------------------------------------------------


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=int, default=2000000)
    ap.add_argument("--triangles", default="30000", help="comma-separated --triangles of synth")
    ap.add_argument("--cases", default="full,part,shuffled")
    ap.add_argument("--systems", default=",".join(SYSTEMS))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--probes", type=int, default=200000, help="0: no probe points")
    ap.add_argument("--cache", default=os.path.join(REPO, "build", "compare-inspect"))
    ap.add_argument("--cli", default=os.path.join(REPO, "build", "align3d"))
    ap.add_argument("--build", default=os.path.join(REPO, "build"),
                    help="holds align3d_run_deviation")
    ap.add_argument("--cc-display", choices=["offscreen", "xvfb"], default="offscreen")
    ap.add_argument("--wait-idle", type=float, default=0, metavar="PCT",
                    help="before each round, wait until the free CPUs were PCT %% idle")
    ap.add_argument("--load", type=int, default=0, help="keep N CPUs busy during the runs")
    ap.add_argument("--json", help="write every run here")
    ap.add_argument("--baseline-build", action="append", default=[], metavar="[LABEL=]DIR",
                    help="another build's align3d_run_deviation: adds the row align3d (LABEL)")
    args = ap.parse_args()
    systems = [s for s in args.systems.split(",") if s]
    for s in systems:
        if s not in SYSTEMS:
            sys.exit(f"unknown system {s}; known: {', '.join(SYSTEMS)}")
    if "align3d" not in systems:
        sys.exit("align3d is the reference of every comparison: keep it in --systems")
    exes = {"align3d": os.path.join(args.build, "align3d_run_deviation")}
    for k, spec in enumerate(args.baseline_build):
        label, _, folder = spec.rpartition("=")
        key = f"align3d-baseline-{k}"
        SYSTEMS[key] = (f"align3d ({label or 'baseline'})", SYSTEMS["align3d"][1])
        exes[key] = os.path.join(folder, "align3d_run_deviation")
        systems.insert(systems.index("align3d") + 1 + k, key)
    for key, exe in exes.items():
        if not os.access(exe, os.X_OK):
            sys.exit(f"{exe} is not built (scripts/build.sh -DALIGN3D_BUILD_BENCH=ON)")
    exe = exes["align3d"]
    notes = []
    if "cloudcompare" in systems and subprocess.run(["which", "CloudCompare"],
                                                    capture_output=True).returncode != 0:
        notes.append("CloudCompare: not installed (scripts/setup-peers.sh); skipped")
        systems.remove("cloudcompare")
    os.makedirs(args.cache, exist_ok=True)
    start_load(args.load)
    results, rows, sign_lines = [], [], []
    for triangles in [int(t) for t in args.triangles.split(",") if t]:
        data = make_data(args.cache, args.cli, args.points, triangles, args.probes)
        tris = read_stl_triangles(data["mesh"])
        baseline_kb = cloudcompare_baseline(args, data["mesh"]) if "cloudcompare" in systems else 0
        out_dir = os.path.join(data["dir"], "out")
        os.makedirs(out_dir, exist_ok=True)
        for case in [c for c in args.cases.split(",") if c] + (["probes"] if args.probes else []):
            scan = data["cases"][case]
            timed = case != "probes"  # probes: one untimed run each, for the signs
            out = {s: os.path.join(out_dir, f"{case}.{s}" + (".ply" if s == "cloudcompare"
                                                             else ".f64")) for s in systems}
            oracle = os.path.join(out_dir, f"{case}.inside")
            # The oracle and a first output, untimed.
            r = run_align3d(exe, scan, data["mesh"], out["align3d"], args.threads, oracle)
            if "error" in r:
                sys.exit(f"align3d_run_deviation failed: {r['error']}")
            per_system = {s: [] for s in systems}
            rounds = args.warmup + args.runs if timed else 1
            label = f"{case}, {data['triangles']} triangles"
            for round_ in range(rounds):
                if timed:
                    wait_idle(args.wait_idle, args.load)
                for s in systems:
                    if s in exes:
                        r = run_align3d(exes[s], scan, data["mesh"], out[s], args.threads)
                    elif s == "cloudcompare":
                        r = run_cloudcompare(args, scan, data["mesh"], out[s], baseline_kb)
                    else:
                        r = run_open3d(s == "open3d-signed", scan, data["mesh"], out[s],
                                       args.threads)
                    r.update({"case": case, "triangles": data["triangles"], "round": round_,
                              "warmup": round_ < args.warmup and timed, "system_key": s})
                    results.append(r)
                    if "error" in r:
                        print(f"  {label} {s}: FAILED: {r['error']}", file=sys.stderr)
                        continue
                    print(f"  {label} round {round_} {s}: build {r['build_ms']:.0f} ms, "
                          f"query {r['query_ms']:.0f} ms", file=sys.stderr)
                    if not r["warmup"]:
                        per_system[s].append(r)

            ours, _ = read_distances("align3d", out["align3d"])
            points = xyz(read_ply(scan))
            inside = np.fromfile(oracle, dtype=np.uint8)
            decided = np.abs(ours) > SURFACE_EPS
            checks = {}
            for s in systems:
                if not per_system[s]:
                    continue
                d, cc_points = read_distances(s, out[s])
                if cc_points is not None and not np.array_equal(cc_points, points):
                    notes.append(f"{label}: CloudCompare's output points differ from its input")
                checks[s] = accuracy(ours, d, points, tris) if s != "align3d" else None
                if s.startswith("align3d-baseline"):
                    checks[s]["sign_differences"] = int(((d < 0) != (ours < 0)).sum())
                if s != "open3d":
                    sign_lines.append(f"{label}: " + sign_report(SYSTEMS[s][0], d, inside, decided))
                if s == "open3d-signed":
                    disagree = float(((d < 0) != (ours < 0))[decided].mean())
                    sign_lines.append(f"{label}: Open3D compute_signed_distance disagrees with "
                                      f"align3d's sign on {100 * disagree:.3g} % of the points")
            undecided = int((~decided).sum())
            sign_lines.append(f"{label}: {undecided} points within {SURFACE_EPS} mm of the "
                              "surface left out of the sign checks")
            if case in ("full", "part"):
                labels = data["label"] if case == "full" else data["label"][data["label"] == 0]
                delta = data["delta"] if case == "full" else data["delta"][data["label"] == 0]
                sure = (labels == 0) & (np.abs(delta) > 5 * data["sigma"])
                wrong = int(((ours < 0) != (delta < 0))[sure].sum())
                sign_lines.append(f"{label}: align3d against the sign of the true deviation on "
                                  f"{int(sure.sum())} part points with |δ| > 5σ: {wrong} wrong")
            if not timed:
                continue
            reference = statistics.median(r["build_ms"] + r["query_ms"]
                                          for r in per_system["align3d"])
            for s in systems:
                runs = per_system[s]
                if not runs:
                    rows.append([label, "", SYSTEMS[s][0], SYSTEMS[s][1], "failed"] + [""] * 8)
                    continue
                build = statistics.median(r["build_ms"] for r in runs)
                query = statistics.median(r["query_ms"] for r in runs)
                total = statistics.median(r["build_ms"] + r["query_ms"] for r in runs)
                lo = min(r["build_ms"] + r["query_ms"] for r in runs)
                hi = max(r["build_ms"] + r["query_ms"] for r in runs)
                process = statistics.median(r["process_ms"] for r in runs)
                bpp = [r["bytes_per_point"] for r in runs if r.get("bytes_per_point") is not None]
                c = checks.get(s)
                rows.append([label, f"{runs[0]['points']}", SYSTEMS[s][0], SYSTEMS[s][1],
                             fmt(build), fmt(query), fmt(total), f"{fmt(lo)}–{fmt(hi)}",
                             fmt(total / reference), fmt(process),
                             fmt(statistics.median(bpp)) if bpp else "—",
                             f"{c['max']:.2g}" if c else "—", f"{c['p999']:.2g}" if c else "—"])
                if c:
                    notes.append(f"{label}, {SYSTEMS[s][0]}: worst |Δ| at {np.round(c['worst_point'], 4).tolist()}: "
                                 f"align3d {c['ours']:.9g}, {s} {c['theirs']:.9g}, brute force "
                                 f"(float64) {c['brute_force']:.9g}")
            a = per_system["align3d"][0]
            notes.append(f"{label}: align3d's index {a['index_bytes'] / 1e6:.3g} MB, deviation map "
                         f"{a['map_bytes'] / a['points']:.3g} bytes a point")

    print(f"\n{os.cpu_count()} cores, {args.threads} threads, {args.warmup} warm-up + {args.runs} "
          f"interleaved runs (median){f', {args.load} CPU(s) kept busy' if args.load else ''}; "
          f"load average before: {os.getloadavg()[0]:.2f}\n")
    print("| case | points | system | computes | build (ms) | query (ms) | total (ms) | total min–max "
          "| total ÷ align3d | process wall (ms) | bytes/point | max \\|Δ\\| (mm) | 99.9 % \\|Δ\\| (mm) |")
    print("|---|--:|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|")
    for row in rows:
        print("| " + " | ".join(str(c) for c in row) + " |")
    print()
    for line in sign_lines + notes:
        print(f"- {line}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"runs": results, "notes": notes, "signs": sign_lines}, f, indent=1)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--open3d-runner":
        ap = argparse.ArgumentParser(prog="compare_inspect.py --open3d-runner")
        ap.add_argument("mode", choices=["signed", "unsigned"])
        ap.add_argument("scan")
        ap.add_argument("mesh")
        ap.add_argument("out")
        ap.add_argument("--threads", type=int, default=0)
        a = ap.parse_args(sys.argv[2:])
        open3d_runner(a.mode, a.scan, a.mesh, a.out, a.threads)
    else:
        main()

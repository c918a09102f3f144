#!/usr/bin/python3
"""GICP side by side: align3d's `--method gicp` against small_gicp and Open3D 0.16's generalized
ICP, and align3d's symmetric and point-to-plane ICP, on the same clouds from the same start in the
same run.

Usage:
  bench/compare_gicp.py --small-gicp DRIVER [--scenes chapter,views,parts-1m] [--runs 5]
                        [--threads 2] [--cache DIR] [--json FILE]

DRIVER is bench/peers/small_gicp_driver.cpp built against a small_gicp tree outside this repository
(bench/peers/build_small_gicp_driver.sh TREE OUT; bench/README.md says which version); without it
the small_gicp rows are skipped with a note. Open3D comes from Debian's python3-open3d.

Scenes (generated with the align3d CLI into --cache):
  chapter   `align3d synth DIR` (scan.ply onto model.ply, ground_truth.txt)
  views     `align3d synth DIR --scene views`: view_1 onto view_0 of the test object, two
            partial range scans 60° apart (NaN pixels dropped), truth pair_0_1.txt
  parts-1m  `align3d synth DIR --scene parts --points 1000000`

Settings, the same for every system: start at truth × P (P: 4° about (1, -1, 2)/√6 through the
source's centroid, then 1 % of the target's diagonal L along (2, 1, -2)/3, as bench/compare.py);
maximum correspondence distance D = 2 % of L; 20 neighbours for covariances and normals; at most 64
iterations; no downsampling (every point of both clouds); --threads threads. Timed: everything
after the files are read (covariance or normal estimation, kd-trees, the registration): align3d's
report's `timing_ms.refine` (`register --init FILE --reject distance:D --kernel none`),
small_gicp's driver `time_ms.total`, Open3D's `registration_generalized_icp` call (it estimates
the covariances inside). The table gives medians of --runs runs, interleaved.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import compare  # noqa: E402  (scene generation and pose helpers of the main comparison)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def read_points(cli, path, workdir):
    """Points of a cloud file as an (N, 3) array (through `align3d convert` to text)."""
    out = os.path.join(workdir, os.path.basename(path) + ".xyz")
    if not os.path.exists(out):
        subprocess.run([cli, "convert", path, out], check=True, capture_output=True)
    return out, np.loadtxt(out, usecols=(0, 1, 2))


def scene_paths(name, cache, cli):
    """(source, target, truth) files of a scene (target ≈ truth·source)."""
    if name != "views":
        d = compare.make_scene(name, cache, cli)
        return (os.path.join(d, "scan.ply"), os.path.join(d, "model.ply"),
                os.path.join(d, "ground_truth.txt"))
    d = os.path.join(cache, "views")
    if not os.path.isfile(os.path.join(d, "pair_0_1.txt")):
        subprocess.run([cli, "synth", d, "--scene", "views"], check=True, capture_output=True)
    return (os.path.join(d, "view_1.pcd"), os.path.join(d, "view_0.pcd"),
            os.path.join(d, "pair_0_1.txt"))


def start_pose(truth, source_points, diagonal):
    """truth × P (the module docstring)."""
    c = source_points.mean(axis=0)
    axis = np.array([1.0, -1.0, 2.0]) / np.sqrt(6)
    a = np.radians(4)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K
    P = np.eye(4)
    P[:3, :3] = R
    P[:3, 3] = c - R @ c + 0.01 * diagonal * np.array([2.0, 1.0, -2.0]) / 3
    return truth @ P


def errors(T, truth):
    E = np.linalg.inv(truth) @ T
    angle = np.degrees(np.arccos(np.clip((np.trace(E[:3, :3]) - 1) / 2, -1, 1)))
    return angle, float(np.linalg.norm(T[:3, 3] - truth[:3, 3]))


def run_align3d(cli, src, tgt, init_file, D, method, threads):
    p = subprocess.run([cli, "register", src, tgt, "--init", init_file, "--reject",
                        f"distance:{D!r}", "--method", method, "--kernel", "none",
                        "--max-iterations", "64", "--threads", str(threads), "--report", "-",
                        "--quiet"], capture_output=True, text=True)
    if p.returncode not in (0, 7):
        raise RuntimeError(p.stderr.strip())
    r = json.loads(p.stdout)
    return np.array(r["transformation"]), r["timing_ms"]["refine"], r["iterations"]


def run_small_gicp(driver, src_xyz, tgt_xyz, init_file, D, threads):
    p = subprocess.run([driver, src_xyz, tgt_xyz, "--method", "gicp", "--threads", str(threads),
                        "--neighbors", "20", "--max-distance", repr(D), "--max-iterations", "64",
                        "--init", init_file], capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(p.stderr.strip())
    r = json.loads(p.stdout)
    return np.array(r["transformation"]), r["time_ms"]["total"], r["iterations_small_gicp"] + 1


def run_open3d(src_pts, tgt_pts, init, D):
    import open3d as o3d
    reg = o3d.pipelines.registration
    s = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(src_pts))
    t = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(tgt_pts))
    start = time.perf_counter()
    r = reg.registration_generalized_icp(
        s, t, D, init, reg.TransformationEstimationForGeneralizedICP(),
        reg.ICPConvergenceCriteria(1e-6, 1e-6, 64))
    ms = 1000 * (time.perf_counter() - start)
    return np.asarray(r.transformation), ms, None


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="chapter,views,parts-1m")
    ap.add_argument("--small-gicp", help="the small_gicp driver binary")
    ap.add_argument("--cli", default=os.path.join(REPO, "build", "align3d"))
    ap.add_argument("--cache", default=os.path.join(REPO, "build", "compare-scenes"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", help="write every run here")
    args = ap.parse_args()
    os.makedirs(args.cache, exist_ok=True)
    if args.small_gicp and not os.access(args.small_gicp, os.X_OK):
        sys.exit(f"--small-gicp {args.small_gicp}: not an executable")
    if not args.small_gicp:
        print("note: no --small-gicp driver: its rows are skipped", file=sys.stderr)
    os.environ["OMP_NUM_THREADS"] = str(args.threads)

    rows, log = [], []
    with tempfile.TemporaryDirectory() as work:
        for name in args.scenes.split(","):
            src, tgt, truth_file = scene_paths(name, args.cache, args.cli)
            truth = np.loadtxt(truth_file, comments="#")
            src_xyz, src_pts = read_points(args.cli, src, work)
            tgt_xyz, tgt_pts = read_points(args.cli, tgt, work)
            diagonal = float(np.linalg.norm(tgt_pts.max(axis=0) - tgt_pts.min(axis=0)))
            D = 0.02 * diagonal
            init = start_pose(truth, src_pts, diagonal)
            init_file = os.path.join(work, name + "_init.txt")
            np.savetxt(init_file, init)
            systems = {
                "align3d gicp": lambda: run_align3d(args.cli, src, tgt, init_file, D, "gicp",
                                                    args.threads),
                "align3d symmetric": lambda: run_align3d(args.cli, src, tgt, init_file, D,
                                                         "symmetric", args.threads),
                "align3d point-to-plane": lambda: run_align3d(args.cli, src, tgt, init_file, D,
                                                              "point-to-plane", args.threads),
                "Open3D gicp": lambda: run_open3d(src_pts, tgt_pts, init, D),
            }
            if args.small_gicp:
                systems["small_gicp gicp"] = lambda: run_small_gicp(
                    args.small_gicp, src_xyz, tgt_xyz, init_file, D, args.threads)
            times = {k: [] for k in systems}
            last = {}
            for run in range(args.runs):  # interleaved: A B C A B C ...
                for key, fn in systems.items():
                    T, ms, iterations = fn()
                    times[key].append(ms)
                    last[key] = (T, iterations)
                    log.append({"scene": name, "system": key, "run": run, "ms": ms,
                                "transformation": T.tolist()})
            reference = statistics.median(times["small_gicp gicp"]) if args.small_gicp else None
            for key in systems:
                T, iterations = last[key]
                rot, trans = errors(T, truth)
                ms = statistics.median(times[key])
                rows.append((name, len(src_pts), len(tgt_pts), key, rot, trans / diagonal,
                             iterations, ms, ms / reference if reference else None))
                print(f"{name}: {key}: {rot:.4f} deg, {100 * trans / diagonal:.4f} % of L, "
                      f"{ms:.1f} ms", file=sys.stderr)
    print("| scene | points (source / target) | system | rotation error (°) | translation error "
          "(% of L) | iterations | time (ms) | ÷ small_gicp |")
    print("|---|---|---|--:|--:|--:|--:|--:|")
    for name, ns, nt, key, rot, trans, it, ms, ratio in rows:
        print(f"| {name} | {ns} / {nt} | {key} | {rot:.4f} | {100 * trans:.4f} | "
              f"{it if it is not None else ''} | {ms:.1f} | "
              f"{'' if ratio is None else f'{ratio:.2f}'} |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(log, f, indent=1)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""Registration of real range scans side by side (issue 55): align3d's defaults against Open3D's
tutorial pipeline on the Stanford dragon, in the same run, every pose against the reference.

Usage:
  bench/compare_real.py [--apart 24,48,72,96] [--min-overlap 0.3] [--starts given,scrambled]
      [--systems align3d,open3d] [--runs 3] [--threads 2] [--seed 1] [--cli build/align3d]
      [--data ../shared/data/real/stanford-dragon] [--no-inspect] [--calibrate] [--json OUT]

Data: the 15 range scans of ../shared/data/real/stanford-dragon (bench/real_data.py; read its
README), metres, no sensor position, the reference poses of truth.txt (good to ~0.3 mm and a few
hundredths of a degree, so "right" is within 0.5° and 1 mm).

Pairs: scan a onto scan b for every a and b = a ± `apart` (both directions), kept when at least
--min-overlap of a's points lie within 3 point spacings of b at the reference pose (the share the
table calls overlap). Starts:
  given      the files as they are: each scan in its own scanner frame, the turntable's 24° per
             scan between them
  scrambled  the source moved by a random rigid motion (uniform rotation, a translation up to the
             scan's size; seeded), written to a float32 PLY both systems read: an unknown pose

Systems, timed from the clouds in memory to the pose (file reading excluded):
  align3d  `align3d register SOURCE TARGET --report - --threads T` with its defaults; time = the
           report's timing_ms.total, which takes in the preparation (both clouds' kd-trees, scale
           and noise: timing_ms.prepare; until 2026-12-03 it did not, which flattered align3d by
           15-20 ms a pair); its warnings are listed (a right pose should have none)
  open3d   python3-open3d (0.16), its registration tutorial's pipeline: voxel v = 5 mm, normals
           (radius 2 v, 30 neighbours), FPFH (radius 5 v, 100), RANSAC on the mutual descriptor
           matches (3 points, distance 1.5 v, edge length 0.9, 100000 iterations, 0.999), then
           the target's normals at full resolution and point-to-plane ICP on every point
           (distance 0.4 v); OMP_NUM_THREADS = T
Runs are interleaved (align3d, Open3D, align3d, ...); the table gives medians.

Inspect (unless --no-inspect): `align3d inspect SCAN MESH --tolerance 0.5mm` of scan a against
the triangulated range grid of its neighbour a − 24° (bench/real_data.py: the scan's own
triangles, an open mesh of ~77 000 triangles), and, with Open3D, against a Poisson reconstruction
of the other 14 scans at the reference poses (depth 9, decimated to 70 000 triangles; cached in
--cache): the pose against the reference, the time of the report's timing_ms.inspect.

Calibration (--calibrate): ICP from the reference pose (`--init` the reference) on every pair,
and on the generated scenes of `align3d evaluate --scenes-only` and `align3d synth --scene views`:
the fit's ratio (RMS ÷ the residual a right pose leaves, icp/fit.hpp) and RMS ÷ σ₀ (the clouds'
own noise, the rule it replaced), as a distribution per kind of data.
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
import real_data as rd  # noqa: E402

RIGHT_DEG, RIGHT_M = 0.5, 0.001


def rotation_error_deg(T, truth):
    R = T[:3, :3].T @ truth[:3, :3]
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))


def translation_error(T, truth, at):
    """How far T puts the point `at` (the source's centroid: the object) from where truth does."""
    return float(np.linalg.norm(T[:3, :3] @ at + T[:3, 3] - truth[:3, :3] @ at - truth[:3, 3]))


def random_motion(rng, size):
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = rng.uniform(-size, size, 3)
    return T


def write_matrix(path, T):
    np.savetxt(path, T, fmt="%.17g")


class Pair:
    def __init__(self, source, target, start, source_file, target_file, truth, overlap, centroid):
        self.source, self.target, self.start = source, target, start
        self.source_file, self.target_file = source_file, target_file
        self.truth, self.overlap, self.centroid = truth, overlap, centroid
        self.runs = {}

    def name(self):
        return f"{self.source}° → {self.target}°"


def make_pairs(args, work):
    poses = rd.dragon_truth(args.data)
    scans = {a: rd.read_range_scan(rd.dragon_path(a, args.data))[0] for a in sorted(poses)}
    rng = np.random.default_rng(args.seed)
    pairs, left_out = [], 0
    for apart in args.apart:
        for a in sorted(poses):
            for b in ((a + apart) % 360, (a - apart) % 360):
                truth = rd.relative_pose(poses, a, b)
                overlap = rd.near_share(rd.transform(scans[a], truth), scans[b], 3 * 0.00055)
                if overlap < args.min_overlap:
                    left_out += 1
                    continue
                for start in args.starts:
                    source_file = rd.dragon_path(a, args.data)
                    pose, points = truth, scans[a]
                    if start == "scrambled":
                        P = random_motion(rng, 0.3)
                        source_file = os.path.join(work, f"scrambled_{a}_{b}.ply")
                        points = rd.transform(scans[a], P)
                        rd.write_ply(source_file, points)
                        pose = truth @ np.linalg.inv(P)
                    pairs.append(Pair(a, b, start, source_file, rd.dragon_path(b, args.data),
                                      pose, overlap, points.mean(axis=0)))
    return pairs, left_out


def run_align3d(args, pair, work):
    truth_file = os.path.join(work, "truth.txt")
    write_matrix(truth_file, pair.truth)
    out = subprocess.run([args.cli, "register", pair.source_file, pair.target_file, "--report", "-",
                          "--quiet", "--threads", str(args.threads), "--ground-truth", truth_file],
                         capture_output=True, text=True)
    if out.returncode not in (0, 7):
        return {"error": out.stderr.strip()}
    r = json.loads(out.stdout)
    T = np.array(r["transformation"])
    return {"rotation_deg": r["rotation_error_deg"],
            "translation": translation_error(T, pair.truth, pair.centroid),
            "ms": r["timing_ms"]["total"], "warnings": [w["code"] for w in r["warnings"]],
            "path": r["init"]["path"], "fit": r["fit"]["ratio"]}


def open3d_pipeline(o3d, source, target, voxel=0.005):
    reg = o3d.pipelines.registration
    start = time.perf_counter()
    features = []
    for cloud in (source, target):
        down = cloud.voxel_down_sample(voxel)
        down.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
        fpfh = reg.compute_fpfh_feature(
            down, o3d.geometry.KDTreeSearchParamHybrid(radius=5 * voxel, max_nn=100))
        features.append((down, fpfh))
    (sd, sf), (td, tf) = features
    distance = 1.5 * voxel
    coarse = reg.registration_ransac_based_on_feature_matching(
        sd, td, sf, tf, True, distance, reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9),
         reg.CorrespondenceCheckerBasedOnDistance(distance)],
        reg.RANSACConvergenceCriteria(100000, 0.999))
    target.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
    fine = reg.registration_icp(source, target, 0.4 * voxel, coarse.transformation,
                                reg.TransformationEstimationPointToPlane())
    return (time.perf_counter() - start) * 1000.0, np.asarray(fine.transformation)


def run_open3d(o3d, pair, seed):
    o3d.utility.random.seed(seed)
    source = o3d.io.read_point_cloud(pair.source_file)
    target = o3d.io.read_point_cloud(pair.target_file)
    ms, T = open3d_pipeline(o3d, source, target)
    return {"rotation_deg": rotation_error_deg(T, pair.truth),
            "translation": translation_error(T, pair.truth, pair.centroid), "ms": ms,
            "warnings": []}


def right(r):
    return "error" not in r and r["rotation_deg"] < RIGHT_DEG and r["translation"] < RIGHT_M


def median_run(runs):
    best = dict(runs[0])
    best["ms"] = statistics.median(r["ms"] for r in runs if "ms" in r) if "ms" in runs[0] else 0
    return best


def registration_table(pairs, systems):
    print("| pair | start | overlap | " + " | ".join(
        f"{s}: rotation (°), translation (mm), time (ms)" for s in systems) +
        (" | ÷ Open3D |" if "open3d" in systems and "align3d" in systems else " |"))
    print("|---|---|--:|" + "---|" * len(systems) + ("--:|" if len(systems) > 1 else ""))
    for p in pairs:
        cells = []
        for s in systems:
            r = median_run(p.runs[s])
            if "error" in r:
                cells.append("error: " + r["error"][:60])
                continue
            flag = "" if right(r) else " **wrong**"
            warn = (" ⚠ " + ",".join(r["warnings"])) if r["warnings"] else ""
            cells.append(f"{r['rotation_deg']:.3f}, {1e3 * r['translation']:.2f}, "
                         f"{r['ms']:.0f}{flag}{warn}")
        ratio = ""
        if "open3d" in systems and "align3d" in systems:
            a, o = median_run(p.runs["align3d"]), median_run(p.runs["open3d"])
            if "ms" in a and o["ms"] > 0:
                ratio = f" {a['ms'] / o['ms']:.2f} |"
        print(f"| {p.name()} | {p.start} | {p.overlap:.2f} | " + " | ".join(cells) + " |" + ratio)


def apart(p):
    """The turn between the pair's scans, degrees (24, 48, ...)."""
    d = abs(p.source - p.target) % 360
    return min(d, 360 - d)


def tally(rows):
    """How the runs of one system ended: right without a warning, right but warned, wrong and
    warned, no solution (an exit code: reported, not silent), wrong and silent."""
    return {"pairs": len(rows),
            "right_clean": sum(right(r) and not r["warnings"] for r in rows),
            "right_warned": sum(right(r) and bool(r["warnings"]) for r in rows),
            "wrong_warned": sum(not right(r) and bool(r.get("warnings")) for r in rows),
            "failed": sum("error" in r for r in rows),
            "wrong_silent": sum(not right(r) and "error" not in r and not r.get("warnings")
                                for r in rows),
            "median_ms": statistics.median([r["ms"] for r in rows if r.get("ms", 0) > 0]
                                           or [0])}


def summary(pairs, systems):
    """Per start and per turn between the scans (and over all turns): the tallies and the time
    ratio align3d ÷ Open3D, median and max over the pairs."""
    out = {}
    for start in sorted({p.start for p in pairs}):
        for turn in sorted({apart(p) for p in pairs}) + ["all"]:
            group = [p for p in pairs if p.start == start and turn in ("all", apart(p))]
            label = f"{start} {turn}" + ("°" if turn != "all" else "")
            for s in systems:
                t = out[(label, s)] = tally([median_run(p.runs[s]) for p in group])
                print(f"{label:13s} {s:8s}: {t['pairs']} pairs, right without warning "
                      f"{t['right_clean']}, right but warned {t['right_warned']}, wrong and warned "
                      f"{t['wrong_warned']}, no solution (exit code) {t['failed']}, wrong and "
                      f"silent {t['wrong_silent']}; median {t['median_ms']:.0f} ms")
            if "open3d" in systems and "align3d" in systems:
                runs = [(median_run(p.runs["align3d"]), median_run(p.runs["open3d"]), p)
                        for p in group]
                ratios = [(a["ms"] / o["ms"], p) for a, o, p in runs
                          if a.get("ms", 0) > 0 and o.get("ms", 0) > 0]
                values = [r for r, _ in ratios]
                out[(label, "ratio")] = {"median": statistics.median(values), "max": max(values),
                                         "above_1": sum(r > 1 for r in values)}
                print(f"{label:13s} align3d ÷ Open3D time: median "
                      f"{statistics.median(values):.2f}, max {max(values):.2f}, pairs above 1: "
                      f"{sum(r > 1 for r in values)}")
                if turn == "all":
                    worst = sorted(ratios, key=lambda x: -x[0])[:5]
                    print("          slowest: "
                          + ", ".join(f"{p.name()} {r:.2f}" for r, p in worst))
    return out


def inspect_cases(args, o3d, work):
    poses = rd.dragon_truth(args.data)
    cases = []
    for a in (24, 120, 216):
        b = a - 24
        points, grid = rd.read_range_scan(rd.dragon_path(b, args.data))
        mesh = os.path.join(work, f"range_mesh_{b}.ply")
        rd.write_ply(mesh, points, rd.range_grid_mesh(points, grid, 0.002))
        cases.append((f"scan {a}° onto the range-grid mesh of scan {b}°", a, mesh,
                      rd.relative_pose(poses, a, b)))
    if o3d is not None:
        mesh = os.path.join(args.cache or work, "poisson_without_0.ply")
        if not os.path.exists(mesh):
            merged = o3d.geometry.PointCloud()
            for angle, pose in poses.items():
                if angle == 0:
                    continue
                cloud = o3d.io.read_point_cloud(rd.dragon_path(angle, args.data))
                merged += cloud.transform(pose)
            merged = merged.voxel_down_sample(0.0005)
            merged.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=0.002, max_nn=30))
            merged.orient_normals_consistent_tangent_plane(20)
            surface, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(merged, depth=9)
            surface = surface.simplify_quadric_decimation(70000)
            o3d.io.write_triangle_mesh(mesh, surface)
        cases.append(("scan 0° onto a Poisson mesh of the other 14 scans", 0, mesh, poses[0]))
    print("\n| inspect | rotation (°) | translation (mm) | time (ms) | warnings |")
    print("|---|--:|--:|--:|---|")
    rows = []
    for label, a, mesh, truth in cases:
        truth_file = os.path.join(work, "truth.txt")
        write_matrix(truth_file, truth)
        times, r = [], None
        for _ in range(args.runs):
            out = subprocess.run([args.cli, "inspect", rd.dragon_path(a, args.data), mesh,
                                  "--tolerance", "0.0005", "--report", "-", "--quiet",
                                  "--threads", str(args.threads)], capture_output=True, text=True)
            r = json.loads(out.stdout)
            times.append(r["timing_ms"]["inspect"])
        T = np.array(r["transformation"])
        centroid = rd.read_range_scan(rd.dragon_path(a, args.data))[0].mean(axis=0)
        row = {"case": label, "rotation_deg": rotation_error_deg(T, truth),
               "translation": translation_error(T, truth, centroid), "ms": statistics.median(times),
               "warnings": [w["code"] for w in r["warnings"]]}
        rows.append(row)
        print(f"| {label} | {row['rotation_deg']:.3f} | {1e3 * row['translation']:.2f} | "
              f"{row['ms']:.0f} | {', '.join(row['warnings'])} |")
    return rows


def calibrate(args, pairs, work):
    """The fit at the reference pose: real pairs, then the generated scenes."""
    cases = [(f"dragon {p.name()}", p.source_file, p.target_file, p.truth)
             for p in pairs if p.start == "given"]
    scenes = os.path.join(work, "generated")
    subprocess.run([args.cli, "evaluate", "--scenes-only", scenes, "--quiet"], check=True,
                   capture_output=True)
    for name in ("chapter", "bracket", "bumpy-sphere", "animal"):
        d = os.path.join(scenes, "scenes", name)
        cases.append((name, os.path.join(d, "source.ply"), os.path.join(d, "target.ply"),
                      np.loadtxt(os.path.join(d, "truth.txt"))))
    views = os.path.join(work, "views")
    subprocess.run([args.cli, "synth", views, "--scene", "views", "--views", "8", "--angle", "45"],
                   check=True, capture_output=True)
    for k in range(1, 8):
        cases.append((f"views 0-{k}", os.path.join(views, f"view_{k}.pcd"),
                      os.path.join(views, "view_0.pcd"),
                      np.loadtxt(os.path.join(views, f"pair_0_{k}.txt"))))
    rows = []
    for label, source, target, truth in cases:
        init = os.path.join(work, "init.txt")
        write_matrix(init, truth)
        out = subprocess.run([args.cli, "register", source, target, "--init", init, "--report",
                              "-", "--quiet", "--threads", str(args.threads)],
                             capture_output=True, text=True)
        r = json.loads(out.stdout)
        noise = max(r["support"]["noise"], 0.05 * r["support"]["spacing"])
        rows.append({"case": label, "ratio": r["fit"]["ratio"],
                     "rms_over_noise": r["fit"]["rms"] / noise,
                     "right": rotation_error_deg(np.array(r["transformation"]), truth) < 1})
    for kind, pick in (("real", lambda c: c.startswith("dragon")),
                       ("generated", lambda c: not c.startswith("dragon"))):
        sel = [r for r in rows if pick(r["case"]) and r["right"]]
        if not sel:
            continue
        for key in ("ratio", "rms_over_noise"):
            v = np.array([r[key] for r in sel])
            q = np.quantile(v, [0, 0.1, 0.5, 0.9, 1])
            print(f"{kind:9s} {key:15s} n={len(v)}: min {q[0]:.2f}, 10 % {q[1]:.2f}, "
                  f"median {q[2]:.2f}, 90 % {q[3]:.2f}, max {q[4]:.2f}")
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cli", default=os.path.join(rd.REPO, "build", "align3d"))
    ap.add_argument("--data", default=rd.DRAGON)
    ap.add_argument("--apart", default="24,48,72,96")
    ap.add_argument("--min-overlap", type=float, default=0.3)
    ap.add_argument("--starts", default="given,scrambled")
    ap.add_argument("--systems", default="align3d,open3d")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cache")
    ap.add_argument("--no-inspect", action="store_true")
    ap.add_argument("--calibrate", action="store_true")
    ap.add_argument("--json")
    args = ap.parse_args()
    args.apart = [int(x) for x in args.apart.split(",")]
    args.starts = args.starts.split(",")
    systems = args.systems.split(",")
    if not os.path.isdir(args.data):
        sys.exit(f"compare_real.py: {args.data}: no such folder (the real scans of "
                 "../shared/data/real/stanford-dragon)")
    o3d = None
    if "open3d" in systems or not args.no_inspect:
        os.environ["OMP_NUM_THREADS"] = str(args.threads)
        try:
            import open3d as o3d  # noqa: F811
        except ImportError:
            if "open3d" in systems:
                sys.exit("compare_real.py: python3-open3d is not installed "
                         "(scripts/setup-peers.sh), or run with --systems align3d")
    with tempfile.TemporaryDirectory(prefix="align3d_real_") as work:
        pairs, left_out = make_pairs(args, work)
        print(f"{len(pairs)} registrations ({left_out} pairs below {args.min_overlap:.0%} overlap "
              f"left out), {args.runs} runs each, {args.threads} threads")
        for run in range(args.runs):
            for p in pairs:
                for s in systems:
                    r = (run_align3d(args, p, work) if s == "align3d"
                         else run_open3d(o3d, p, args.seed))
                    p.runs.setdefault(s, []).append(r)
        registration_table(pairs, systems)
        result = {"summary": {f"{k[0]}/{k[1]}": v for k, v in summary(pairs, systems).items()}}
        result["pairs"] = [{"source": p.source, "target": p.target, "start": p.start,
                            "overlap": p.overlap,
                            **{s: median_run(p.runs[s]) for s in systems}} for p in pairs]
        if not args.no_inspect:
            result["inspect"] = inspect_cases(args, o3d, work)
        if args.calibrate:
            result["calibration"] = calibrate(args, pairs, work)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()

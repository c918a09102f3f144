#!/usr/bin/python3
"""Coarse-stage (global registration) timing, align3d against Open3D's FPFH + RANSAC, side by side.

Usage: bench/compare_global.py [--align3d build/align3d] [--runs 7] [--scene DIR]
Needs scripts/setup-peers.sh (Debian's python3-open3d). Without --scene it writes the chapter scene
with `align3d synth`. Runs are interleaved (align3d, Open3D, align3d, Open3D, ...) after one warm-up
each; the table gives medians. Both pipelines get the same settings: voxel = target diagonal / 50,
normals from 20 nearest neighbours (Open3D: 2-voxel radius, at most 30), FPFH radius 5 voxels, RANSAC on 3 descriptor
correspondences with the edge-length (0.9) check, inliers within 1.5 voxels, no mutual filter,
at most 100000 hypotheses with confidence 0.9999. Times exclude file reading on both sides
(align3d: the report's global.time_ms; Open3D: downsampling + normals + FPFH + RANSAC).
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
import open3d as o3d


def rotation_error_deg(T, truth):
    R = T[:3, :3].T @ truth[:3, :3]
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))


def open3d_global(source, target, voxel):
    reg = o3d.pipelines.registration
    start = time.perf_counter()
    feats = []
    for cloud in (source, target):
        down = cloud.voxel_down_sample(voxel)
        down.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
        fpfh = reg.compute_fpfh_feature(down, o3d.geometry.KDTreeSearchParamHybrid(radius=5 * voxel, max_nn=100))
        feats.append((down, fpfh))
    (sd, sf), (td, tf) = feats
    result = reg.registration_ransac_based_on_feature_matching(
        sd, td, sf, tf, False, 1.5 * voxel, reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9)],
        reg.RANSACConvergenceCriteria(100000, 0.9999))
    return (time.perf_counter() - start) * 1000.0, np.asarray(result.transformation)


def align3d_global(exe, scan, model, seed):
    out = subprocess.run([exe, "register", scan, model, "--init", "global", "--report", "-",
                          "--seed", str(seed)], capture_output=True, text=True)
    if out.returncode != 0:
        return None, None, out.stderr.strip()
    report = json.loads(out.stdout)
    return report["global"]["time_ms"], np.array(report["global"]["transformation"]), None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--align3d", default="build/align3d")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--scene")
    args = ap.parse_args()
    scene = args.scene
    if scene is None:
        scene = tempfile.mkdtemp(prefix="align3d_compare_")
        subprocess.run([args.align3d, "synth", scene], check=True, capture_output=True)
    scan, model = os.path.join(scene, "scan.ply"), os.path.join(scene, "model.ply")
    truth = np.loadtxt(os.path.join(scene, "ground_truth.txt"))
    source, target = o3d.io.read_point_cloud(scan), o3d.io.read_point_cloud(model)
    extent = target.get_max_bound() - target.get_min_bound()
    voxel = float(np.linalg.norm(extent)) / 50.0
    try:
        o3d.utility.random.seed(1)
    except AttributeError:
        pass

    rows = {"align3d": [], "Open3D": []}
    errors = {"align3d": [], "Open3D": []}
    for run in range(args.runs + 1):  # run 0 is the warm-up
        t, T, err = align3d_global(args.align3d, scan, model, 1)
        if err:
            sys.exit(f"align3d failed: {err}")
        t2, T2 = open3d_global(source, target, voxel)
        if run == 0:
            continue
        rows["align3d"].append(t)
        rows["Open3D"].append(t2)
        errors["align3d"].append((rotation_error_deg(T, truth), float(np.linalg.norm(T[:3, 3] - truth[:3, 3]))))
        errors["Open3D"].append((rotation_error_deg(T2, truth), float(np.linalg.norm(T2[:3, 3] - truth[:3, 3]))))

    ours = statistics.median(rows["align3d"])
    print(f"scene: {scene} ({len(source.points)} scan points, {len(target.points)} model points), "
          f"voxel {voxel:.3f}, {os.cpu_count()} cores, {args.runs} interleaved runs after a warm-up")
    print("| system | coarse stage, median (ms) | min (ms) | worst rotation error (deg) | worst translation error | time ÷ align3d |")
    print("|---|---:|---:|---:|---:|---:|")
    for name in ("align3d", "Open3D"):
        med = statistics.median(rows[name])
        worst_r = max(e[0] for e in errors[name])
        worst_t = max(e[1] for e in errors[name])
        print(f"| {name} | {med:.1f} | {min(rows[name]):.1f} | {worst_r:.2f} | {worst_t:.2f} | {med / ours:.2f} |")


if __name__ == "__main__":
    main()

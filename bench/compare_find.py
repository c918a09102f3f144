#!/usr/bin/python3
"""Bin picking side by side (issue 16): every instance of a part in a depth-camera scene, found by
`align3d find`, by Open3D's FPFH + RANSAC and by PCL, on the same generated scenes in the same run,
scored the BOP way.

Usage:
  bench/compare_find.py [--scenes 24] [--first-seed 100] [--cache DIR] [--systems align3d,open3d,pcl]
      [--real]
      [--threads 2]
      [--json OUT] [--cli build/align3d] [--pcl-runner build-peers/pcl_find_run] [--peer-budget 20]
      [--open3d-args "--min-fitness F --max-tries N"] [--pcl-args "RUNNER OPTIONS"] (tuning)
  From another worktree: PYTHONPATH=MAIN/.venv/lib/python3.11/site-packages bench/compare_find.py
      --cli MAIN/build/align3d ...

The align3d Python package scores the detections (align3d.match_instances); the script finds it on
sys.path or in the repository's .venv (scripts/build.sh installs it there). The peers need
scripts/setup-peers.sh (python3-open3d; libpcl-dev for the PCL runner, built with
`cmake -S bench/peers -B build-peers -G Ninja && cmake --build build-peers -j 1 --target
pcl_find_run`). A system whose program is missing is skipped with a note.

Real scenes (--real): the teach-in cases of PCL's Kinect frames (../shared/data/real/pcl-kinect,
bench/real_data.py kinect_teach_in; Open3D needed to cut them): each of the two boxes of the first
frame cut out of it (a pixel window, above the table), moved by a known pose, no normals, and found
in each of the three frames (frame 0: the truth is the move; frames 1 and 2, where the scene
moves: Open3D's ICP of the cut from frame 0's pose). The table then also gives false positives
per scene. PCL's runner takes a mesh model and is skipped on them.

Scenes (fixed seeds, generated once into --cache and reused; without --cache into a temporary
folder removed at the end): scene i of N is
  `align3d synth --scene bin --seed S+i --part P --instances K --distractors D DIR`
with P the i-th of --parts in turn (default bracket for even i, flange for odd i; bracket: no
symmetry, diameter 154 mm; flange: turned, continuous symmetry about its z axis, 137 mm; plate:
mostly flat, 110 × 70 × 10 with small features, 131 mm), K = 1 + 7·(i // #parts) mod 12 (with
two parts each gets every count 1..12 over 24 scenes), D = 3·i mod 7 (0 to 6 boxes, cylinders
and spheres) and S =
--first-seed (100: the bench; the development sets of issue 16 were --first-seed 500 and 700 with
--scenes 36, so that what is tuned on them is only confirmed here). A scene is
a 640x480 organized PCD in the camera frame (NaN where there is no return, mm), the part's STL and
scene.json with the true poses (scene ≈ T·model) and each instance's visible fraction.

Scoring (BOP, Hodaň et al. 2018; align3d's instance_match.hpp through align3d.match_instances):
ADD-S over 3000 points sampled evenly by area on the STL (align3d.read_mesh(...).sample, seed 1);
a found pose is correct when its ADD-S to a true instance is below 10 % of the model's diameter
(scene.json's, the bounding-box diagonal of the part, as align3d's find defines it). Per scene, the
found poses in descending score each take the not yet matched true instance of lowest ADD-S below
the threshold. Instances at least 50 % visible count for recall; a pose matched to a less visible
one is excused (neither true nor false positive). recall = Σ true positives ÷ Σ counted instances,
precision = Σ true positives ÷ Σ (true + false positives), over all scenes of the row (micro
averages: every instance weighs the same). Targets (issue 16): recall ≥ 0.95, precision ≥ 0.95,
< 1 s a scene on 2 cores.

Time, measured the same way for every system: each program's own wall clock from the files read to
the poses found ("detect"): the scene's preparation (the floor, downsampling, normals, features)
and the search and refinement, WITHOUT reading the files and WITHOUT the model's preparation (done
once per part; given apart as "model prep": align3d's PPF table, Open3D's model FPFH, PCL's model
descriptors). The table gives the median and the maximum of detect per scene, and the median wall
time of the whole process (reading, the model and, for Open3D, Python's start and import: ~0.5 s).
Each system runs once a scene; systems take turns scene by scene. --threads (default 2) is passed
to every system (OMP_NUM_THREADS for Open3D, whose RANSAC alone runs on one thread: below).
Deterministic: the scenes by their seeds; align3d by its contract; PCL's runner (seeded sampling,
PCL's fixed-seed RANSAC) gives the same bytes; Open3D the same poses up to ~1e-13 (its OpenMP
sums in normals and ICP).

Systems and their settings (for the peers v = the voxel = 4 % of the model's diameter, 6.2 mm for
the bracket: finer than align3d's default 5 %, which gives them more points and time):
  align3d  `align3d find MODEL.stl SCENE.pcd --report R.json --threads T` (align3d_find_command,
           the one place that knows the command line): its defaults (find.hpp and `align3d find
           --help`: voxel 5 % of the diameter, min score 0.6, symmetry detected, the dominant
           plane removed when it holds 20 %). detect = the report's timing_ms.total (find()'s
           clock; the model's preparation is outside it and not reported apart).
  open3d   Open3D 0.16 (Debian's python3-open3d), in a process of its own (this script with
           --open3d-runner). Model: the STL sampled evenly (sample_points_uniformly, 20000 points,
           the triangles' normals), VoxelDownSample(v), FPFH (radius 5 v, ≤ 100 neighbours).
           Scene: NaN dropped; planes removed (below); VoxelDownSample(v); normals (radius 2 v,
           ≤ 30 neighbours) turned toward the camera at the origin (the model's outward normals
           face it on the visible side); FPFH as the model's, computed once. Then up to 14 runs
           (12 instances at most, and 2 more) of RegistrationRANSACBasedOnFeatureMatching, model
           → the scene's remaining points and their features (no mutual filter, 3 points,
           edge-length check 0.9 and distance check 1.5 v, inliers within 1.5 v, ≤ 100000
           iterations, confidence 0.999, seed 1; on ONE thread: with two, Open3D 0.16's RANSAC
           gives other poses from run to run), refined by point-to-plane ICP (max distance v,
           30 iterations); fitness = share of the model's downsampled points within v of the
           remaining scene, the better of RANSAC's and ICP's pose kept (ICP slides off along a
           plane at times). A run whose fitness is below OPEN3D_MIN_FITNESS (0.1) ends the
           search; otherwise the pose is kept (score = fitness) and the scene points within 1.5 v
           of the posed model are removed before the next run. A fully visible part covers about
           a fifth of the model's points, so the fitness of right poses ranges over 0.1–0.45 and
           wrong ones on the clutter reach 0.3: no threshold separates them (tried: 0.05, 0.1,
           0.25; judging only the model points facing the camera did no better).
  pcl      PCL 1.13 (Debian's libpcl-dev), bench/peers/run_pcl_find.cpp (build-peers/pcl_find_run,
           its header lists every setting): correspondence grouping as PCL's tutorial (SHOT,
           radius 6 v, on uniform keypoints, GeometricConsistencyGrouping) with ICP refinement
           and PCL's global hypothesis verification, one pass for all instances; poses kept with
           fitness ≥ 0.1. Its settings are the best of five tried on 6 scenes of other seeds (the
           runner's header). PCL's PPF (PPFRegistration, the runner's --method ppf) was tried and
           left out: on the bracket its model table took 135 s and each run (one pose) ~10 s on
           one core (PCL's PPF has no threads), which no per-scene budget here allows.
  oracle   not in the default: a check of the scoring (run_oracle).
  Planes, the same for both peers (align3d removes its own floor, find.hpp): RANSAC (0.5 v,
  1000 iterations) on a v / 2 sample; a plane holding ≥ 2 % of the first sample is cut from the
  full cloud in a band of max(0.5 v, 3 × the RMS distance of the points within v); at most 6
  planes. The camera sees the ground around the bin (about half the image), the bin's floor
  (12 mm higher, 20–30 %) and its walls (3–6 % each): the peers get all of them removed, which
  helps them (the walls drew most of their wrong poses when only the ground and floor went);
  the parts' largest faces hold under 1.5 %.
Budget: each peer is given --peer-budget seconds (default 20) a scene: a runner starts no new
search after it ("capped": its poses so far count), and a process still running at 2 × budget +
10 s is killed ("timeout": no poses). Both are counted in the table.

--json OUT writes every scene's result per system: the poses, scores, ADD-S errors, matches, times
and the command line.
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from compare import fmt  # noqa: E402  (the bench's number format)

SYSTEMS = {"align3d": "align3d find", "open3d": "Open3D FPFH + RANSAC", "pcl": "PCL SHOT + GC + GO",
           "oracle": "oracle (truth + noise)"}
VOXEL_FRACTION = 0.04  # the peers' voxel / model diameter (align3d find: 5 %, its own default)
OPEN3D_MIN_FITNESS = 0.1
MODEL_POINTS = 3000  # ADD-S samples on the model's surface
MAX_ERROR = 0.1  # ADD-S threshold / model diameter
MIN_VISIBLE = 0.5

# ---------------------------------------------------------------------------------------------
# align3d's command line and report: the one place that knows them.


def align3d_find_command(cli, model, scene, report, threads):
    return [cli, "find", model, scene, "--report", report, "--threads", str(threads)]


def read_align3d_report(path):
    """(instances [{transformation, score, ...}] best first, detect ms, model-prep ms or None).
    detect = timing_ms.total, find()'s own clock (find.hpp: FindResult::total_ms): the scene's
    preparation, voting, refinement and verification; the model's preparation is not in it, and
    the report does not give it apart."""
    with open(path) as f:
        r = json.load(f)
    t = r.get("timing_ms", {})
    return r["instances"], t.get("total"), t.get("model")


# ---------------------------------------------------------------------------------------------
# Scenes.


def scene_plan(i, first_seed=100, parts=("bracket", "flange")):
    part = parts[i % len(parts)]
    k = i // len(parts)
    return {"part": part, "instances": 1 + (7 * k) % 12, "distractors": (3 * i) % 7,
            "seed": first_seed + i}


def make_scenes(cli, cache, n, first_seed=100, parts=("bracket", "flange")):
    scenes = []
    for i in range(n):
        p = scene_plan(i, first_seed, parts)
        name = f"{i:02d}-{p['part']}-{p['instances']}-{p['distractors']}-s{p['seed']}"
        folder = os.path.join(cache, name)
        if not os.path.isfile(os.path.join(folder, "scene.json")):
            cmd = [cli, "synth", "--scene", "bin", "--seed", str(p["seed"]), "--part", p["part"],
                   "--instances", str(p["instances"]), "--distractors", str(p["distractors"]), folder]
            subprocess.run(cmd, check=True, capture_output=True)
        scenes.append(dict(p, name=name, dir=folder))
    return scenes


# ---------------------------------------------------------------------------------------------
# Scoring.


def import_align3d():
    try:
        import align3d
        return align3d
    except ImportError:
        pass
    lib = os.path.join(REPO, ".venv", "lib")
    for v in sorted(os.listdir(lib)) if os.path.isdir(lib) else []:
        sys.path.insert(0, os.path.join(lib, v, "site-packages"))
    try:
        import align3d
        return align3d
    except ImportError:
        sys.exit("the align3d Python package is needed to score (scripts/build.sh installs it into "
                 ".venv; or set PYTHONPATH to the site-packages that hold it)")


def model_path(scene):
    return os.path.join(scene["dir"], scene.get("model", "model.stl"))


def model_points(align3d, path):
    """ADD-S samples: MODEL_POINTS on a mesh's surface, or every k-th point of a cloud (a scan)."""
    if path.endswith(".stl"):
        return np.asarray(align3d.read_mesh(path).sample(MODEL_POINTS, seed=1).points,
                          dtype=np.float64)
    points = np.asarray(align3d.read_point_cloud(path).points, dtype=np.float64)
    return points[::max(1, len(points) // MODEL_POINTS)]


def nearest_rigid(T):
    """T with its rotation block replaced by the nearest rotation (SVD). PCL's runner writes float
    poses (Eigen::Matrix4f), orthonormal only to ~1e-6, which the binding rejects as not rigid; the
    projection moves no entry by more than that, for every system alike."""
    u, _, vt = np.linalg.svd(T[:3, :3])
    out = T.copy()
    out[:3, :3] = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
    return out


def score_scene(match_instances, points, scene, instances):
    """BOP matching of one system's poses (best score first) against the scene's truth."""
    truth = json.load(open(os.path.join(scene["dir"], "scene.json")))
    true_T = [np.array(t["transformation"], dtype=np.float64) for t in truth["instances"]]
    visible = [float(t["visible_fraction"]) for t in truth["instances"]]
    ordered = sorted(instances, key=lambda x: -x["score"])  # stable: ties keep the system's order
    found = [nearest_rigid(np.array(x["transformation"], dtype=np.float64)) for x in ordered]
    max_error = MAX_ERROR * truth["model"]["diameter"]
    m = match_instances(points, found, true_T, visible, max_error, min_visible=MIN_VISIBLE)
    m = {k: (list(m[k]) if k in ("match", "error") else m[k]) for k in
         ("recall", "precision", "true_positives", "false_positives", "counted", "excused", "match",
          "error")}
    m["error"] = [float(e) if np.isfinite(e) else None for e in m["error"]]
    m["match"] = [int(k) for k in m["match"]]
    m["max_error"] = max_error
    return m, ordered


# ---------------------------------------------------------------------------------------------
# Systems: each returns {"instances", "detect_ms", "model_ms", "process_ms", "status", "command"}.


def run_process(cmd, timeout, env=None):
    start = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return None, (time.perf_counter() - start) * 1e3, f"timeout after {timeout:.0f} s"
    wall = (time.perf_counter() - start) * 1e3
    if p.returncode != 0:
        return None, wall, (p.stderr.strip() or f"exit code {p.returncode}")[-600:]
    return p, wall, None


def run_align3d(args, scene, work):
    report = os.path.join(work, f"{scene['name']}-align3d.json")
    cmd = align3d_find_command(args.cli, model_path(scene),
                               os.path.join(scene["dir"], "scene.pcd"), report, args.threads)
    cmd += args.align3d_args.split()
    p, wall, err = run_process(cmd, args.align3d_timeout)
    if err:
        return {"status": "error", "error": err, "instances": [], "process_ms": wall, "command": cmd}
    instances, detect, model = read_align3d_report(report)
    return {"status": "ok", "instances": instances, "detect_ms": detect, "model_ms": model,
            "process_ms": wall, "command": cmd}


def run_peer(cmd, args, env=None):
    p, wall, err = run_process(cmd, 2 * args.peer_budget + 10, env)
    if err:
        return {"status": "timeout" if err.startswith("timeout") else "error", "error": err,
                "instances": [], "process_ms": wall, "command": cmd}
    r = json.loads(p.stdout.strip().splitlines()[-1])
    r.update({"status": "capped" if r.get("capped") else "ok", "detect_ms": r.pop("time_ms"),
              "process_ms": wall, "command": cmd})
    return r


def run_open3d(args, scene, work):
    cmd = [sys.executable, os.path.abspath(__file__), "--open3d-runner",
           model_path(scene), os.path.join(scene["dir"], "scene.pcd"),
           "--threads", str(args.threads), "--budget", str(args.peer_budget)] + args.open3d_args.split()
    return run_peer(cmd, args, dict(os.environ, OMP_NUM_THREADS=str(args.threads)))


def run_pcl(args, scene, work):
    if not model_path(scene).endswith(".stl"):
        return {"status": "error", "error": "the PCL runner takes a mesh model (STL), not a scan",
                "instances": [], "process_ms": 0.0, "command": []}
    cmd = [args.pcl_runner, model_path(scene),
           os.path.join(scene["dir"], "scene.pcd"), "--method", "cg", "--threads",
           str(args.threads), "--budget", str(args.peer_budget)] + args.pcl_args.split()
    return run_peer(cmd, args)


def run_oracle(args, scene, work):
    """A check of the scoring, not a detector: the true poses turned by 1° and moved by 1 mm, the
    counted ones only, plus one false pose (the first truth moved by half the diameter), written
    as align3d's report and read back by read_align3d_report."""
    truth = json.load(open(os.path.join(scene["dir"], "scene.json")))
    rng = np.random.default_rng(scene["seed"])
    out = []
    for t in truth["instances"]:
        if t["visible_fraction"] < MIN_VISIBLE:
            continue
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        a = np.radians(1.0)
        K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        R = np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K
        T = np.array(t["transformation"])
        T[:3, :3] = R @ T[:3, :3]
        T[:3, 3] += rng.normal(size=3) / np.sqrt(3)
        out.append({"transformation": T.tolist(), "score": float(t["visible_fraction"])})
    if truth["instances"]:
        T = np.array(truth["instances"][0]["transformation"])
        T[:3, 3] += [0.5 * truth["model"]["diameter"], 0, 0]
        out.append({"transformation": T.tolist(), "score": 0.01})
    report = os.path.join(work, f"{scene['name']}-oracle.json")
    with open(report, "w") as f:
        json.dump({"instances": out, "timing_ms": {"total": 0.0}}, f)
    instances, detect, model = read_align3d_report(report)
    return {"status": "ok", "instances": instances, "detect_ms": detect, "model_ms": model,
            "process_ms": 0.0, "command": ["(oracle)"]}


RUNNERS = {"align3d": run_align3d, "open3d": run_open3d, "pcl": run_pcl, "oracle": run_oracle}

# ---------------------------------------------------------------------------------------------
# The Open3D peer (runner mode: a process of its own, one JSON line on stdout).


def remove_planes(o3d, points, v, min_share=0.02, max_planes=6):
    """The peers' floor removal (module docstring); returns (kept mask, points removed per plane)."""
    keep = np.ones(len(points), dtype=bool)
    first, removed = None, []
    for _ in range(max_planes):
        idx = np.flatnonzero(keep)
        sample = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points[idx])).voxel_down_sample(v / 2)
        first = first or len(sample.points)
        if len(sample.points) < 10:
            break
        plane, inliers = sample.segment_plane(0.5 * v, 3, 1000)
        if len(inliers) < min_share * first:
            break
        n = np.asarray(plane[:3])
        d = (points[idx] @ n + plane[3]) / np.linalg.norm(n)
        near = np.abs(d) <= v
        band = max(0.5 * v, 3 * float(np.sqrt(np.mean(d[near] ** 2))))
        on = np.abs(d) <= band
        keep[idx[on]] = False
        removed.append(int(on.sum()))
    return keep, removed


def open3d_runner(model_path, scene_path, threads, budget, max_tries, min_fitness):
    import ctypes
    import open3d as o3d
    omp = ctypes.CDLL("libgomp.so.1")  # the OpenMP runtime Debian's Open3D is linked with
    omp.omp_set_num_threads(threads)
    reg = o3d.pipelines.registration
    cloud = o3d.io.read_point_cloud(scene_path, remove_nan_points=True, remove_infinite_points=True)
    o3d.utility.random.seed(1)

    t0 = time.perf_counter()
    if model_path.endswith(".stl"):
        mesh = o3d.io.read_triangle_mesh(model_path)
        v = VOXEL_FRACTION * float(np.linalg.norm(mesh.get_max_bound() - mesh.get_min_bound()))
        mesh.compute_triangle_normals()
        model = mesh.sample_points_uniformly(20000, use_triangle_normal=True)
        model_down = model.voxel_down_sample(v)
    else:  # a teach-in scan: its points, normals estimated and oriented consistently
        model = o3d.io.read_point_cloud(model_path)
        v = VOXEL_FRACTION * float(np.linalg.norm(model.get_max_bound() - model.get_min_bound()))
        model_down = model.voxel_down_sample(v)
        model_down.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * v, max_nn=30))
        model_down.orient_normals_consistent_tangent_plane(10)
    model_fpfh = reg.compute_fpfh_feature(model_down, o3d.geometry.KDTreeSearchParamHybrid(radius=5 * v, max_nn=100))
    model_ms = (time.perf_counter() - t0) * 1e3

    start = time.perf_counter()
    cpu0 = time.process_time()
    points = np.asarray(cloud.points)
    keep, planes = remove_planes(o3d, points, v)
    scene = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points[keep])).voxel_down_sample(v)
    scene.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * v, max_nn=30))
    scene.orient_normals_towards_camera_location(np.zeros(3))
    features = np.asarray(reg.compute_fpfh_feature(
        scene, o3d.geometry.KDTreeSearchParamHybrid(radius=5 * v, max_nn=100)).data)
    alive = np.ones(len(scene.points), dtype=bool)
    found, tries, capped = [], [], False
    for _ in range(max_tries):
        if time.perf_counter() - start > budget:
            capped = True
            break
        idx = np.flatnonzero(alive)
        if len(idx) < 10:
            break
        rest = scene.select_by_index(idx)
        rest_fpfh = reg.Feature()
        rest_fpfh.data = features[:, idx]
        # Open3D 0.16's RANSAC draws from one generator in all its OpenMP threads, so with 2 it
        # gives other poses from run to run; on one thread the seed fixes them.
        omp.omp_set_num_threads(1)
        ransac = reg.registration_ransac_based_on_feature_matching(
            model_down, rest, model_fpfh, rest_fpfh, False, 1.5 * v,
            reg.TransformationEstimationPointToPoint(False), 3,
            [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9), reg.CorrespondenceCheckerBasedOnDistance(1.5 * v)],
            reg.RANSACConvergenceCriteria(100000, 0.999))
        omp.omp_set_num_threads(threads)
        icp = reg.registration_icp(model_down, rest, v, ransac.transformation,
                                   reg.TransformationEstimationPointToPlane(),
                                   reg.ICPConvergenceCriteria(1e-6, 1e-6, 30))
        before = reg.evaluate_registration(model_down, rest, v, ransac.transformation)
        # ICP can slide off along a plane: the better of the two poses, by the same fitness.
        best = icp if icp.fitness >= before.fitness else before
        tries.append([ransac.fitness, before.fitness, icp.fitness])
        if best.fitness < min_fitness:
            break
        T = np.asarray(best.transformation)
        found.append({"transformation": T.tolist(), "score": best.fitness,
                      "ransac_fitness": ransac.fitness})
        posed = o3d.geometry.PointCloud(model_down).transform(T)
        near = np.asarray(rest.compute_point_cloud_distance(posed)) < 1.5 * v
        alive[idx[near]] = False
    detect_ms = (time.perf_counter() - start) * 1e3
    import resource
    print(json.dumps({"system": "Open3D", "instances": found, "model_ms": model_ms,
                      "time_ms": detect_ms, "cpu_ms": (time.process_time() - cpu0) * 1e3,
                      "capped": capped, "voxel": v, "plane_points": planes,
                      "scene_points": len(scene.points), "tries": tries,
                      "peak_rss_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}))


# ---------------------------------------------------------------------------------------------
# The table.


def summarize(rows):
    tp = sum(r["score"]["true_positives"] for r in rows)
    fp = sum(r["score"]["false_positives"] for r in rows)
    counted = sum(r["score"]["counted"] for r in rows)
    detect = [r["detect_ms"] for r in rows if r.get("detect_ms") is not None]
    model = [r["model_ms"] for r in rows if r.get("model_ms") is not None]
    return {"scenes": len(rows), "counted": counted, "true_positives": tp, "false_positives": fp,
            "excused": sum(r["score"]["excused"] for r in rows),
            "recall": tp / counted if counted else 1.0,
            "precision": tp / (tp + fp) if tp + fp else 1.0,
            "detect_median_ms": statistics.median(detect) if detect else None,
            "detect_max_ms": max(detect) if detect else None,
            "model_median_ms": statistics.median(model) if model else None,
            "process_median_ms": statistics.median(r["process_ms"] for r in rows),
            "capped": sum(r["status"] == "capped" for r in rows),
            "timeouts": sum(r["status"] == "timeout" for r in rows),
            "errors": sum(r["status"] == "error" for r in rows)}


def print_table(results, systems, scenes):
    print("| system | part | scenes | instances counted | recall | precision | TP / FP / excused "
          "| FP per scene | detect median (ms) | detect max (ms) | model prep (ms) "
          "| process wall median (ms) | capped / timeouts / errors |")
    print("|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|")
    summary = {}
    for s in systems:
        rows = [results[sc["name"]][s] for sc in scenes]
        for part in ["all"] + sorted({sc["part"] for sc in scenes}):
            sel = [r for r, sc in zip(rows, scenes) if part == "all" or sc["part"] == part]
            if not sel:
                continue
            m = summarize(sel)
            summary[f"{s}/{part}"] = m
            print(f"| {SYSTEMS[s] if part == 'all' else ''} | {part} | {m['scenes']} | {m['counted']} "
                  f"| {m['recall']:.3f} | {m['precision']:.3f} | {m['true_positives']} / "
                  f"{m['false_positives']} / {m['excused']} "
                  f"| {m['false_positives'] / m['scenes']:.2f} | {fmt(m['detect_median_ms'])} "
                  f"| {fmt(m['detect_max_ms'])} | {fmt(m['model_median_ms'])} "
                  f"| {fmt(m['process_median_ms'])} | {m['capped']} / {m['timeouts']} / {m['errors']} |")
    return summary


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=24)
    ap.add_argument("--first-seed", type=int, default=100,
                    help="seed of scene 0 (100: the bench's scenes; others: development sets)")
    ap.add_argument("--cache", help="keep the generated scenes here (reused when present)")
    ap.add_argument("--real", action="store_true",
                    help="the real teach-in cases of PCL's Kinect frames (bench/real_data.py, "
                         "kinect_teach_in; needs python3-open3d) instead of generated scenes")
    ap.add_argument("--parts", default="bracket,flange",
                    help="the parts scene i takes in turn (bracket, flange, plate: mostly flat)")
    ap.add_argument("--systems", default="align3d,open3d,pcl",
                    help=f"comma-separated, of {', '.join(SYSTEMS)} (oracle: a check of the scoring)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", help="write every scene's results here")
    ap.add_argument("--cli", default=os.path.join(REPO, "build", "align3d"))
    ap.add_argument("--pcl-runner", default=os.path.join(REPO, "build-peers", "pcl_find_run"))
    ap.add_argument("--pcl-args", default="", help="extra options for pcl_find_run (tuning)")
    ap.add_argument("--open3d-args", default="",
                    help="extra options for the Open3D runner: --max-tries N, --min-fitness F (tuning)")
    ap.add_argument("--peer-budget", type=float, default=20.0, help="seconds a scene for each peer")
    ap.add_argument("--align3d-timeout", type=float, default=120.0)
    ap.add_argument("--align3d-args", default="",
                    help="extra options for `align3d find`, e.g. \"--voxel-fraction 0.04\" (tuning)")
    args = ap.parse_args()
    systems = [s for s in args.systems.split(",") if s]
    for s in systems:
        if s not in SYSTEMS:
            sys.exit(f"unknown system {s}; known: {', '.join(SYSTEMS)}")
    if not os.access(args.cli, os.X_OK):
        sys.exit(f"{args.cli}: not built (scripts/build.sh); it also generates the scenes")
    notes = []
    if "pcl" in systems and not os.access(args.pcl_runner, os.X_OK):
        notes.append(f"PCL: {args.pcl_runner} is not built (bench/peers); skipped")
        systems.remove("pcl")
    if "open3d" in systems:
        try:
            import open3d  # noqa: F401
        except ImportError:
            notes.append("Open3D: python3-open3d is not installed (scripts/setup-peers.sh); skipped")
            systems.remove("open3d")
    if "align3d" in systems and subprocess.run([args.cli, "find", "--help"],
                                               capture_output=True).returncode != 0:
        notes.append(f"align3d: {args.cli} has no `find` command yet; skipped")
        systems.remove("align3d")
    align3d = import_align3d()
    match_instances = align3d.match_instances

    cache = args.cache or tempfile.mkdtemp(prefix="align3d_find_")
    os.makedirs(cache, exist_ok=True)
    work = tempfile.mkdtemp(prefix="align3d_find_reports_")
    try:
        if args.real:
            import real_data
            scenes = real_data.kinect_teach_in(cache)
        else:
            scenes = make_scenes(args.cli, cache, args.scenes, args.first_seed,
                                 args.parts.split(","))
        points = {}
        results = {}
        for k, scene in enumerate(scenes):
            if scene["part"] not in points:
                points[scene["part"]] = model_points(align3d, model_path(scene))
            results[scene["name"]] = {}
            for s in systems:
                r = RUNNERS[s](args, scene, work)
                r["score"], r["instances"] = score_scene(match_instances, points[scene["part"]], scene,
                                                         r["instances"])
                results[scene["name"]][s] = r
                m = r["score"]
                print(f"[{k + 1}/{len(scenes)}] {scene['name']} {s}: {r['status']}, "
                      f"{len(r['instances'])} found, TP {m['true_positives']}/{m['counted']}, "
                      f"FP {m['false_positives']}, detect {fmt(r.get('detect_ms'))} ms, "
                      f"process {fmt(r['process_ms'])} ms"
                      + (f" ({r['error'][:200]})" if r.get("error") else ""), file=sys.stderr)
        print(f"\n{len(scenes)} scenes, {args.threads} threads, {os.cpu_count()} cores; "
              f"load average after: {os.getloadavg()[0]:.2f}\n")
        summary = print_table(results, systems, scenes)
        for n in notes:
            print(f"- {n}")
        if args.json:
            with open(args.json, "w") as f:
                json.dump({"settings": vars(args), "systems": systems, "notes": notes,
                           "scenes": scenes, "summary": summary, "results": results}, f, indent=1)
    finally:
        shutil.rmtree(work, ignore_errors=True)
        if not args.cache:
            shutil.rmtree(cache, ignore_errors=True)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--open3d-runner":
        ap = argparse.ArgumentParser(prog="compare_find.py --open3d-runner")
        ap.add_argument("model")
        ap.add_argument("scene")
        ap.add_argument("--threads", type=int, default=2)
        ap.add_argument("--budget", type=float, default=20.0)
        ap.add_argument("--max-tries", type=int, default=14)
        ap.add_argument("--min-fitness", type=float, default=OPEN3D_MIN_FITNESS)
        a = ap.parse_args(sys.argv[2:])
        open3d_runner(a.model, a.scene, a.threads, a.budget, a.max_tries, a.min_fitness)
    else:
        main()

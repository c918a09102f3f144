#!/usr/bin/python3
"""Convergence basins side by side (issue 18): ICP alone from the identity, align3d's methods and
Open3D 0.16's ICP, on the same scenes from the same starting poses in the same run.

Usage:
  bench/compare_basin.py [--trials 8] [--seed 1] [--threads 2] [--cache DIR] [--json FILE]
                         [--figures DIR] [--quick] [--scenes a,b] [--align3d-only | --peers-only]

Scenes: those of `align3d evaluate` (`--scenes-only` writes them): the chapter scene and partial
views of a bracket, a bumpy sphere and an animal (~60 % overlap, 5 % outliers), each a source, a
target and the truth (target ≈ T·source).

Protocol (Rusinkiewicz 2019's, as `align3d evaluate`'s basin): for each cell (rotation angle a ×
translation magnitude s, a fraction of the target's bounding-box diagonal L) and each trial, a
uniform random axis and direction (numpy, seeded per scene, cell and trial); the source is placed
on the target by the truth, turned by a about the axis through the target's centroid and shifted
by s·L, so the identity is exactly that far from the truth. Every system registers it back from
the identity. Success: rotation error < 1° and translation error < 0.5 % of L (as `evaluate`).

Systems:
  align3d <method>       align3d.register(init="identity", method=...): the default `auto`
                         schedule (coarse-to-fine reach and resolution), nothing tuned per scene.
  Open3D point-to-plane  registration_icp with TransformationEstimationPointToPlane at a maximum
                         correspondence distance D of 5 %, 10 % and 20 % of L (a user must pick
                         one; Open3D has no schedule of its own in its legacy API), at most 100
                         iterations; target normals from the file, else 20 nearest neighbours.
  Open3D point-to-point, Open3D GICP   the same, D = 10 % of L.

Output: the success rate per cell and system (markdown on stdout, --json), one SVG heat map per
scene (--figures), and per system the widest angle up to which every trial of every shift up to
10 % of L succeeded.
"""

import argparse
import json
import os
import sys
import tempfile
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from compare_find import import_align3d  # noqa: E402

ANGLES = [0, 10, 20, 30, 45, 60, 90]
SHIFTS = [0, 0.05, 0.1, 0.2]
ALIGN3D_METHODS = ["point-to-point", "point-to-plane", "gicp", "symmetric"]
OPEN3D_RUNS = [("point-to-plane", 0.05), ("point-to-plane", 0.10), ("point-to-plane", 0.20),
               ("point-to-point", 0.10), ("gicp", 0.10)]


def rotation(axis, deg):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    a = np.radians(deg)
    return np.eye(3) + np.sin(a) * k + (1 - np.cos(a)) * k @ k


def homogeneous(R, t):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def start_pose(centroid, angle, shift, rng):
    """P: turn by `angle` about a random axis through the centroid, then shift by `shift` in a
    random direction; the moved source is P·truth·source, so the truth is P⁻¹."""
    R = rotation(unit(rng), angle)
    return homogeneous(R, centroid + shift * unit(rng) - R @ centroid)


def pose_errors(T, truth):
    dR = T[:3, :3] @ truth[:3, :3].T
    angle = np.degrees(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1)))
    return angle, np.linalg.norm(T[:3, 3] - truth[:3, 3])


def open3d_register(o3d, src_points, src_normals, target, kind, D):
    reg = o3d.pipelines.registration
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(src_points))
    if src_normals is not None:
        src.normals = o3d.utility.Vector3dVector(src_normals)
    estimation = {"point-to-plane": reg.TransformationEstimationPointToPlane,
                  "point-to-point": reg.TransformationEstimationPointToPoint,
                  "gicp": reg.TransformationEstimationForGeneralizedICP}[kind]()
    criteria = reg.ICPConvergenceCriteria(max_iteration=100)
    run = reg.registration_generalized_icp if kind == "gicp" else reg.registration_icp
    return np.asarray(run(src, target, D, np.eye(4), estimation, criteria).transformation)


def load_scenes(align3d, cache):
    report = align3d.evaluate(cache, scenes_only=True)
    scenes = []
    for s in report["scenes"]:
        src = align3d.read_point_cloud(os.path.join(cache, s["source"]))
        tgt = align3d.read_point_cloud(os.path.join(cache, s["target"]))
        scenes.append(dict(name=s["name"], source=src, target=tgt, diagonal=s["diagonal"],
                           truth=align3d.read_matrix(os.path.join(cache, s["truth"]))))
    return scenes


def open3d_target(o3d, cloud):
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(cloud.points))
    if cloud.has_normals:
        pcd.normals = o3d.utility.Vector3dVector(cloud.normals)
    else:
        pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(20))
    return pcd


def systems(peers=True, ours=True):
    names = [f"align3d {m}" for m in ALIGN3D_METHODS] if ours else []
    return names + ([f"Open3D {k} D={int(round(100 * D))}%" for k, D in OPEN3D_RUNS] if peers
                    else [])


def run_scene(align3d, o3d, scene, angles, shifts, trials, seed, threads, index, peers, ours):
    """Success counts [system][shift][angle] and total seconds per system."""
    L, truth = scene["diagonal"], scene["truth"]
    centroid = np.mean(scene["target"].points, axis=0)
    target_o3d = open3d_target(o3d, scene["target"])
    names = systems(peers, ours)
    success = {n: np.zeros((len(shifts), len(angles)), dtype=int) for n in names}
    seconds = {n: 0.0 for n in names}
    for i, shift in enumerate(shifts):
        for j, angle in enumerate(angles):
            for k in range(trials):
                rng = np.random.default_rng([seed, index, i, j, k])
                P = start_pose(centroid, angle, shift * L, rng)
                moved = scene["source"].transformed(P @ truth)
                expected = np.linalg.inv(P)
                results = {}
                for m in ALIGN3D_METHODS if ours else []:
                    t0 = time.perf_counter()
                    try:
                        T = align3d.register(moved, scene["target"], init="identity", method=m,
                                             threads=threads, seed=seed).transformation
                    except align3d.Error as e:  # no solution: a failure of this trial
                        print(f"{scene['name']} {m} {angle} deg {shift:.2f} L trial {k}: {e}",
                              file=sys.stderr)
                        T = np.eye(4)
                    results[f"align3d {m}"] = (T, time.perf_counter() - t0)
                for (kind, D), name in zip(OPEN3D_RUNS if peers else [],
                                           names[len(ALIGN3D_METHODS) if ours else 0:]):
                    t0 = time.perf_counter()
                    T = open3d_register(o3d, moved.points, moved.normals, target_o3d, kind, D * L)
                    results[name] = (T, time.perf_counter() - t0)
                for name, (T, dt) in results.items():
                    rot, trans = pose_errors(T, expected)
                    success[name][i, j] += rot < 1.0 and trans < 0.005 * L
                    seconds[name] += dt
    return success, seconds


def widest_angle(success, angles, shifts, trials, max_shift=0.1):
    """The widest angle up to which every trial at every shift ≤ max_shift succeeded."""
    rows = [i for i, s in enumerate(shifts) if s <= max_shift + 1e-12]
    widest = None
    for j, a in enumerate(angles):
        if all(success[i, j] == trials for i in rows):
            widest = a
        else:
            break
    return widest


def svg_heatmaps(title, panels, angles, shifts, trials):
    """One SVG: a heat map per system (success rate, white 0 → dark green 1), its count per cell."""
    cw, ch, left, top = 34, 26, 40, 26
    pw = max(left + cw * len(angles) + 30, 250)
    ph = top + ch * len(shifts) + 36
    cols = 3
    rows = (len(panels) + cols - 1) // cols
    height = 34 + rows * ph + 24
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{cols * pw + 10}" height="{height}"'
           ' font-family="sans-serif" font-size="11">',
           '<rect width="100%" height="100%" fill="white"/>',
           f'<text x="8" y="20" font-size="15">{title}</text>']
    for p, (name, grid) in enumerate(panels):
        x0, y0 = 10 + (p % cols) * pw, 34 + (p // cols) * ph
        out.append(f'<text x="{x0}" y="{y0 + 14}" font-size="12">{name}</text>')
        for i, s in enumerate(shifts):
            y = y0 + top + ch * (len(shifts) - 1 - i)
            out.append(f'<text x="{x0 + left - 4}" y="{y + 17}" text-anchor="end">{s:g}</text>')
            for j in range(len(angles)):
                rate = grid[i, j] / trials
                shade = (int(255 - 235 * rate), int(255 - 155 * rate), int(255 - 225 * rate))
                x = x0 + left + cw * j
                out.append(f'<rect x="{x}" y="{y}" width="{cw}" height="{ch}" '
                           f'fill="rgb{shade}" stroke="#999"/>')
                out.append(f'<text x="{x + cw / 2}" y="{y + 17}" text-anchor="middle" '
                           f'fill="{"white" if rate > 0.6 else "black"}">{grid[i, j]}</text>')
        yb = y0 + top + ch * len(shifts)
        for j, a in enumerate(angles):
            out.append(f'<text x="{x0 + left + cw * j + cw / 2}" y="{yb + 14}" '
                       f'text-anchor="middle">{a}°</text>')
    out.append(f'<text x="10" y="{height - 10}" fill="#444">columns: initial rotation; rows: '
               f'initial shift (× the target\'s diagonal); each cell: successes of {trials} '
               'trials (rotation error &lt; 1°, translation error &lt; 0.5 % of the diagonal)'
               '</text>')
    out.append("</svg>")
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=8, help="trials per cell")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--cache", help="where the scenes are written (default: a temporary folder)")
    ap.add_argument("--json", help="write every grid and time here")
    ap.add_argument("--figures", help="write basin_peers_<scene>.svg here")
    ap.add_argument("--quick", action="store_true", help="1 trial, a 2×2 grid: the machinery only")
    ap.add_argument("--scenes", help="comma-separated scene names (default: all; the starts of a "
                    "scene do not depend on which others run)")
    only = ap.add_mutually_exclusive_group()
    only.add_argument("--align3d-only", action="store_true", help="leave the peers out")
    only.add_argument("--peers-only", action="store_true", help="leave align3d out")
    a = ap.parse_args()
    peers, ours = not a.align3d_only, not a.peers_only
    try:
        import open3d as o3d
    except ImportError:
        sys.exit("Open3D for Python is needed (scripts/setup-peers.sh installs python3-open3d)")
    align3d = import_align3d()
    # A wrong minimum warns (AlignWarning); the count of successes is what this measures.
    warnings.simplefilter("ignore", align3d.AlignWarning)
    angles, shifts, trials = (([0, 30], [0, 0.1], 1) if a.quick else (ANGLES, SHIFTS, a.trials))
    cache = a.cache or tempfile.mkdtemp(prefix="align3d-basin-")
    scenes = load_scenes(align3d, cache)
    wanted = a.scenes.split(",") if a.scenes else [s["name"] for s in scenes]
    unknown = set(wanted) - {s["name"] for s in scenes}
    if unknown:
        sys.exit(f"--scenes: no scene {', '.join(sorted(unknown))} (there are "
                 f"{', '.join(s['name'] for s in scenes)})")
    out = {"angles_deg": angles, "shift_fractions": shifts, "trials_per_cell": trials,
           "seed": a.seed, "threads": a.threads, "scenes": []}
    for index, scene in enumerate(scenes):
        if scene["name"] not in wanted:
            continue
        print(f"{scene['name']}: {len(scene['source'])} / {len(scene['target'])} points",
              file=sys.stderr, flush=True)
        success, seconds = run_scene(align3d, o3d, scene, angles, shifts, trials, a.seed,
                                     a.threads, index, peers, ours)
        runs = trials * len(angles) * len(shifts)
        entry = {"name": scene["name"], "systems": []}
        print(f"\n### {scene['name']}\n\n| system | widest angle, all shifts ≤ 10 % | "
              f"successes | mean time (ms) |\n|---|--:|--:|--:|")
        for name in systems(peers, ours):
            w = widest_angle(success[name], angles, shifts, trials)
            total = int(success[name].sum())
            ms = 1000 * seconds[name] / runs
            print(f"| {name} | {'–' if w is None else f'{w}°'} | {total}/{runs} | {ms:.0f} |")
            entry["systems"].append({"system": name, "success": success[name].tolist(),
                                     "widest_angle_deg": w, "mean_time_ms": ms})
        out["scenes"].append(entry)
        if a.figures:
            os.makedirs(a.figures, exist_ok=True)
            svg = svg_heatmaps(f"Convergence basin from the identity: {scene['name']}",
                               [(n, success[n]) for n in systems(peers, ours)], angles,
                               shifts, trials)
            with open(os.path.join(a.figures, f"basin_peers_{scene['name']}.svg"), "w",
                      encoding="utf-8") as f:
                f.write(svg + "\n")
    if a.json:
        with open(a.json, "w", encoding="utf-8") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()

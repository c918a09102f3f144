"""The real scans of ../shared/data/real/ as the benchmarks read them (bench/compare_real.py).

The Stanford dragon (stanford-dragon/): 15 ASCII PLY range scans from a Cyberware 3030MS, the
statuette turned by 24° between scans, metres, no sensor position; each file holds `x y z`
vertices and a `range_grid` element (rows × cols cells, each listing 0 or 1 vertex index);
truth.txt gives each scan's world-from-scan pose (world = T · scan), derived from the repository's
own .conf: neighbouring scans overlap at 0.1-0.3 mm median distance under it, but it is not a
consistent fit of the scans at that level: refined from it by Open3D alone (refined_dragon_truth:
point-to-plane ICP of every pair 24° and 48° apart, a pose graph), the scans move by up to 0.65°
and 2.7 mm, and the neighbours' median point-to-plane residual falls from 98-312 µm to 52-120 µm
(2026-12-02). Benchmarks give both.

PCL's Kinect frames (pcl-kinect/): teach-in cases for `find` (kinect_teach_in): a box cut out of
the first frame (a pixel window, above the table's plane), moved by a known pose, to be found in
each of the three frames.
"""
import json
import os

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REAL = os.path.normpath(os.path.join(REPO, "..", "shared", "data", "real"))
DRAGON = os.path.join(REAL, "stanford-dragon")
KINECT = os.path.join(REAL, "pcl-kinect")
KINECT_FRAMES = ["frame_20121214T142255.814212.pcd", "frame_20121214T142256.068683.pcd",
                 "frame_20121214T142256.332395.pcd"]
# The boxes of the first frame: pixel windows (u0, u1, v0, v1) of the 640 x 480 image, the points
# more than 15 mm above the table kept (tests/real_data_test.cpp cuts the same).
KINECT_BOXES = {"small-box": (382, 520, 160, 330), "large-box": (120, 380, 130, 330)}
# The known pose the taught model is moved by (the model's frame is not the camera's).
TEACH_MOVE_AXIS, TEACH_MOVE_ANGLE, TEACH_MOVE_T = (0.3, 1.0, 0.2), 0.7, (0.5, -0.2, 0.3)


def dragon_path(angle, data=DRAGON):
    return os.path.join(data, f"dragonStandRight_{angle}.ply")


def dragon_truth(data=DRAGON):
    """{angle: 4x4 world-from-scan pose} from truth.txt."""
    poses = {}
    with open(os.path.join(data, "truth.txt")) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            name, *numbers = line.split()
            angle = int(name.split("_")[1].split(".")[0])
            poses[angle] = np.array([float(x) for x in numbers]).reshape(4, 4)
    return poses


def relative_pose(poses, source, target):
    """T with target ≈ T · source (scan `source` into scan `target`'s frame)."""
    return np.linalg.inv(poses[target]) @ poses[source]


def read_range_scan(path):
    """(vertices (N, 3), grid (rows, cols) of vertex indices, -1 where nothing was seen)."""
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline().decode("ascii").strip()
            header.append(line)
            if line == "end_header":
                break
        body = f.read().decode("ascii").split("\n")

    def value(prefix, field):
        return int(next(h for h in header if h.startswith(prefix)).split()[field])

    vertices, cells = value("element vertex", 2), value("element range_grid", 2)
    rows, cols = value("obj_info num_rows", 2), value("obj_info num_cols", 2)
    points = np.array([[float(x) for x in body[i].split()[:3]] for i in range(vertices)])
    grid = -np.ones(cells, dtype=np.int64)
    for i in range(cells):
        entry = body[vertices + i].split()
        if entry and entry[0] != "0":
            grid[i] = int(entry[1])
    return points, grid.reshape(rows, cols)


def range_grid_mesh(points, grid, max_edge):
    """The scan's own triangulation: two triangles per grid cell whose four corners were seen, one
    where three were, none with an edge longer than `max_edge` (the depth jumps at silhouettes)."""
    a, b, c, d = grid[:-1, :-1], grid[:-1, 1:], grid[1:, :-1], grid[1:, 1:]
    full = (a >= 0) & (b >= 0) & (c >= 0) & (d >= 0)
    triangles = [np.stack([a[full], c[full], b[full]], 1), np.stack([b[full], c[full], d[full]], 1)]
    for (x, y, z), missing in (((b, c, d), a), ((a, c, d), b), ((a, d, b), c), ((a, c, b), d)):
        three = (x >= 0) & (y >= 0) & (z >= 0) & (missing < 0)
        triangles.append(np.stack([x[three], y[three], z[three]], 1))
    tri = np.concatenate(triangles)

    def edge(i, j):
        return np.linalg.norm(points[tri[:, i]] - points[tri[:, j]], axis=1)

    short = (edge(0, 1) < max_edge) & (edge(1, 2) < max_edge) & (edge(0, 2) < max_edge)
    return tri[short]


def write_ply(path, points, triangles=None):
    """Binary little-endian PLY: float32 vertices, and faces when given."""
    points = np.asarray(points, dtype="<f4")
    header = f"ply\nformat binary_little_endian 1.0\nelement vertex {len(points)}\n"
    header += "property float x\nproperty float y\nproperty float z\n"
    if triangles is not None:
        header += f"element face {len(triangles)}\nproperty list uchar int vertex_indices\n"
    header += "end_header\n"
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(points.tobytes())
        if triangles is not None:
            faces = np.zeros(len(triangles), dtype=[("n", "u1"), ("i", "<i4", (3,))])
            faces["n"] = 3
            faces["i"] = triangles
            f.write(faces.tobytes())


def transform(points, T):
    return points @ T[:3, :3].T + T[:3, 3]


def near_share(points, other, distance, samples=4000):
    """The share of `points` (at most `samples` of them, evenly spaced) with a point of `other`
    within `distance`: a hash of `other` in cells of that size, each sample tested against the 27
    cells about it."""
    points = points[:: max(1, len(points) // samples)]
    cells = {}
    for i, key in enumerate(map(tuple, np.floor(other / distance).astype(np.int64))):
        cells.setdefault(key, []).append(i)
    near = 0
    for p, key in zip(points, np.floor(points / distance).astype(np.int64)):
        found = False
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    idx = cells.get((key[0] + dx, key[1] + dy, key[2] + dz))
                    if idx and np.min(np.sum((other[idx] - p) ** 2, axis=1)) <= distance**2:
                        found = True
                        break
                if found:
                    break
            if found:
                break
        near += found
    return near / len(points)


def refined_dragon_truth(cache, data=DRAGON):
    """{angle: world-from-scan pose}: truth.txt refined by Open3D alone (python3-open3d; no align3d
    code), cached as CACHE/dragon_refined.npy: per scan, normals (20 neighbours); for every pair 24°
    and 48° apart, point-to-plane ICP from the truth.txt pose at 2, 1 and 0.5 mm (50 iterations
    each), its information matrix at 0.5 mm; a pose graph of those 30 edges, Levenberg-Marquardt
    (0.5 mm, prune 0.25), scan 0 fixed at its truth.txt pose."""
    path = os.path.join(cache, "dragon_refined.npy")
    truth = dragon_truth(data)
    angles = sorted(truth)
    if os.path.exists(path):
        return dict(zip(angles, np.load(path)))
    import open3d as o3d
    reg = o3d.pipelines.registration
    clouds = {}
    for a in angles:
        pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(read_range_scan(dragon_path(a, data))[0]))
        pc.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(20))
        clouds[a] = pc
    graph = reg.PoseGraph()
    for a in angles:
        graph.nodes.append(reg.PoseGraphNode(truth[a]))
    for k, a in enumerate(angles):
        for step in (24, 48):
            b = (a + step) % 360
            T = relative_pose(truth, a, b)
            for distance in (2e-3, 1e-3, 0.5e-3):
                T = reg.registration_icp(clouds[a], clouds[b], distance, T,
                                         reg.TransformationEstimationPointToPlane(),
                                         reg.ICPConvergenceCriteria(max_iteration=50)).transformation
            info = reg.get_information_matrix_from_point_clouds(clouds[a], clouds[b], 0.5e-3, T)
            graph.edges.append(reg.PoseGraphEdge(k, angles.index(b), T, info, uncertain=False))
    reg.global_optimization(graph, reg.GlobalOptimizationLevenbergMarquardt(),
                            reg.GlobalOptimizationConvergenceCriteria(),
                            reg.GlobalOptimizationOption(max_correspondence_distance=0.5e-3,
                                                         edge_prune_threshold=0.25,
                                                         reference_node=0))
    poses = np.array([graph.nodes[k].pose for k in range(len(angles))])
    os.makedirs(cache, exist_ok=True)
    np.save(path, poses)
    return dict(zip(angles, poses))


def rotation(axis, angle):
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def kinect_teach_in(cache, data=KINECT):
    """The teach-in cases of PCL's Kinect frames, written once into `cache`: per box of
    KINECT_BOXES and per frame, a folder with model.ply (the box cut from frame 0, moved by the
    known pose, no normals), scene.pcd (a link to the frame) and scene.json (the model's diameter
    and the true pose, scene ≈ T · model). In frame 0 the truth is the inverse of the move. The
    scene moves between frames (no truth comes with them): in frames 1 and 2 it is Open3D's
    point-to-plane ICP of the model onto the frame from frame 0's truth (Open3D alone, so that no
    align3d code makes its own reference); `truth` in scene.json says which. Needs python3-open3d.
    Returns the scene dicts of bench/compare_find.py."""
    import open3d as o3d
    frames = [o3d.io.read_point_cloud(os.path.join(data, f), remove_nan_points=False,
                                      remove_infinite_points=False) for f in KINECT_FRAMES]
    first = np.asarray(frames[0].points)
    finite = np.isfinite(first).all(axis=1)
    o3d.utility.random.seed(1)
    plane, _ = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(first[finite])).segment_plane(
        0.01, 3, 1000)
    height = first @ np.asarray(plane[:3]) + plane[3]
    height *= 1 if plane[3] > 0 else -1  # positive on the camera's side (it sits at the origin)
    move = np.eye(4)
    move[:3, :3] = rotation(TEACH_MOVE_AXIS, TEACH_MOVE_ANGLE)
    move[:3, 3] = TEACH_MOVE_T
    u, v = np.arange(len(first)) % 640, np.arange(len(first)) // 640
    scenes = []
    for box, (u0, u1, v0, v1) in KINECT_BOXES.items():
        cut = first[finite & (u >= u0) & (u < u1) & (v >= v0) & (v < v1) & (height > 0.015)]
        model = transform(cut, move)
        diameter = float(np.linalg.norm(model.max(axis=0) - model.min(axis=0)))
        for k, frame in enumerate(KINECT_FRAMES):
            name = f"kinect-{box}-frame{k}"
            folder = os.path.join(cache, name)
            os.makedirs(folder, exist_ok=True)
            truth = np.linalg.inv(move)
            if k > 0:
                pts = np.asarray(frames[k].points)
                target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(
                    pts[np.isfinite(pts).all(axis=1)]))
                target.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(20))
                source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(model))
                reg = o3d.pipelines.registration
                for reach in (0.03, 0.01):
                    truth = reg.registration_icp(
                        source, target, reach, truth, reg.TransformationEstimationPointToPlane(),
                        reg.ICPConvergenceCriteria(1e-9, 1e-9, 100)).transformation
            write_ply(os.path.join(folder, "model.ply"), model)
            link = os.path.join(folder, "scene.pcd")
            if not os.path.lexists(link):
                os.symlink(os.path.join(os.path.abspath(data), frame), link)
            with open(os.path.join(folder, "scene.json"), "w") as f:
                json.dump({"model": {"diameter": diameter},
                           "truth": "cut" if k == 0 else "Open3D ICP from frame 0's",
                           "instances": [{"transformation": np.asarray(truth).tolist(),
                                          "visible_fraction": 1.0}]}, f, indent=1)
            scenes.append({"part": box, "name": name, "dir": folder, "model": "model.ply"})
    return scenes

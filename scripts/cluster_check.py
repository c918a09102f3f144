"""The checks of scripts/cluster_test.sh, run with the Python of a venv that has the align3d wheel
installed, against a running Dask scheduler whose workers are separate processes.

Writes PAIRS scans of two generated models (each scan a subset of its model moved by a known
transform) and one pair whose scan is missing, then registers them
  1. through the command line: ``align3d batch pairs.csv --report-dir R --scheduler ADDR``
     (the wheel's ``align3d``, which runs the batch engine with this venv's Python),
  2. through Python: ``register_pairs(pairs, client=Client(ADDR))``,
  3. in this process: ``register_pairs(pairs, client=Client(LocalCluster(processes=False)))``,
and checks that every report recovers its truth, the missing scan fails alone (exit code 8, its
``.failed.json`` naming the file, code 3), the workers that ran the pairs are the cluster's
separate processes, and the three runs give the same reports bit for bit (timings aside).
Exits non-zero on the first failed check.
"""

import argparse
import importlib.metadata
import json
import os
import subprocess
import sys
import time

import numpy as np

import align3d
import align3d.batch
from dask.distributed import Client, LocalCluster

# The Python tests' generated surface (python/tests/conftest.py): the data, not the package, comes
# from the repository.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python", "tests"))
from conftest import surface  # noqa: E402


def rotation(axis, angle_deg):
    """Rodrigues' formula: an oracle independent of the library."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    a = np.radians(angle_deg)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def make_pairs(directory, count, points):
    """count (scan, model) file pairs and each scan's truth (model ≈ T·scan); the pair at
    count // 2 names a scan that does not exist."""
    os.makedirs(directory, exist_ok=True)
    models = []
    for m in range(2):
        name = os.path.join(directory, f"model{m}.ply")
        cloud = surface(points, seed=10 + m)
        align3d.write_point_cloud(name, cloud)
        models.append((name, cloud))
    rng = np.random.default_rng(59)
    pairs, truths = [], []
    for k in range(count):
        model_name, model = models[k % 2]
        scan_name = os.path.join(directory, f"scan{k:02d}.ply")
        if k == count // 2:
            pairs.append((os.path.join(directory, "missing.ply"), model_name))
            truths.append(None)
            continue
        T = np.eye(4)  # scan = T_scan_model · model; the registration returns its inverse
        T[:3, :3] = rotation(rng.normal(size=3), rng.uniform(2, 12))
        T[:3, 3] = rng.uniform(-0.2, 0.2, size=3)
        subset = model[rng.permutation(len(model))[: points * 3 // 4]]
        align3d.write_point_cloud(scan_name, subset @ T[:3, :3].T + T[:3, 3])
        pairs.append((scan_name, model_name))
        truths.append(np.linalg.inv(T))
    return pairs, truths


def without_timings(value):
    """The report without its wall-clock times (timing_ms, time_ms), which differ run to run."""
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if k not in ("timing_ms", "time_ms")}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def check(condition, message):
    if not condition:
        sys.exit(f"cluster_check: FAILED: {message}")


def check_reports(name, reports, pairs, truths):
    """Every good pair's pose within 0.05 deg and 0.005 of its truth; the missing scan the only
    failure, named, code 3."""
    for (source, _), report, truth in zip(pairs, reports, truths):
        if truth is None:
            check("error" in report and "missing.ply" in report["error"] and report["code"] == 3,
                  f"{name}: the missing scan's report is {report}")
            continue
        check("error" not in report, f"{name}: {source} failed: {report.get('error')}")
        T = np.array(report["transformation"])
        R = T[:3, :3].T @ truth[:3, :3]
        angle = np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)))
        shift = np.linalg.norm(T[:3, 3] - truth[:3, 3])
        check(angle < 0.05 and shift < 5e-3,
              f"{name}: {source}: {angle:.4f} deg, {shift:.5f} off the truth")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scheduler", required=True, help="tcp://host:port of the running scheduler")
    p.add_argument("--workers", type=int, default=2, help="worker processes to wait for")
    p.add_argument("--data", required=True, help="folder for the generated pairs and reports")
    p.add_argument("--cli", default="align3d", help="the wheel's align3d command")
    p.add_argument("--pairs", type=int, default=30)
    p.add_argument("--points", type=int, default=2000)
    args = p.parse_args()
    start = time.monotonic()

    # The package is the wheel's, not the checkout's, and one version is reported everywhere.
    version = importlib.metadata.version("align3d")
    cli_version = subprocess.run([args.cli, "--version"], capture_output=True, text=True,
                                 check=True).stdout.strip()
    check(cli_version == f"align3d {version}" and align3d.__version__ == version,
          f"versions: metadata {version}, CLI {cli_version!r}, module {align3d.__version__}")
    check("site-packages" in align3d.__file__, f"align3d imported from {align3d.__file__}")

    pairs, truths = make_pairs(args.data, args.pairs, args.points)
    csv = os.path.join(args.data, "pairs.csv")
    with open(csv, "w", encoding="utf-8") as f:
        f.write("source,target\n" + "".join(f"{s},{t}\n" for s, t in pairs))

    with Client(args.scheduler, timeout=60) as client:
        client.wait_for_workers(args.workers, timeout=60)
        pids = client.run(os.getpid)
        check(len(set(pids.values())) == args.workers and os.getpid() not in pids.values(),
              f"expected {args.workers} worker processes besides this one, got {pids}")

        # 1. The command line against the cluster: exit code 8 (one pair failed), a report per pair.
        reports_dir = os.path.join(args.data, "reports")
        run = subprocess.run([args.cli, "batch", csv, "--report-dir", reports_dir, "--scheduler",
                              args.scheduler, "--quiet"], capture_output=True, text=True)
        check(run.returncode == 8, f"align3d batch exited {run.returncode}: {run.stderr}")
        check(run.stderr.count("align3d: ") == 1 and "missing.ply" in run.stderr,
              f"align3d batch's stderr: {run.stderr!r}")
        from_cli = []
        for source, target in pairs:
            stem = f"{os.path.splitext(os.path.basename(source))[0]}--" \
                   f"{os.path.splitext(os.path.basename(target))[0]}"
            name = os.path.join(reports_dir, stem + ".json")
            failed = os.path.join(reports_dir, stem + ".failed.json")
            check(os.path.exists(name) != os.path.exists(failed), f"{stem}: one report expected")
            with open(name if os.path.exists(name) else failed, encoding="utf-8") as f:
                from_cli.append(json.load(f))
        check_reports("align3d batch --scheduler", from_cli, pairs, truths)

        # 2. Python against the same cluster; each worker has prepared targets, so both ran pairs.
        from_python = align3d.batch.register_pairs(pairs, client=client)
        check_reports("register_pairs(client=Client(ADDR))", from_python, pairs, truths)
        used = client.run(lambda: len(__import__("align3d.batch").batch._TARGETS))
        check(all(n > 0 for n in used.values()), f"prepared targets per worker: {used}")
        cluster_seconds = time.monotonic() - start

    # 3. The same pairs in this process: the reference, bit for bit.
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=":0") as cluster, Client(cluster) as local:
        in_process = align3d.batch.register_pairs(pairs, client=local)
    reference = [without_timings(r) for r in in_process]
    for name, reports in (("align3d batch --scheduler", from_cli),
                          ("register_pairs(client=Client(ADDR))", from_python)):
        for (source, _), got, want in zip(pairs, reports, reference):
            check(json.dumps(without_timings(got)) == json.dumps(want),
                  f"{name}: {source}: the report differs from the in-process run's")
    print(f"cluster_check: {len(pairs)} pairs ({len(pairs) - 1} registered within 0.05 deg of "
          f"their truth, the missing scan failed alone) through align3d batch --scheduler and "
          f"register_pairs on {args.workers} worker processes {sorted(pids.values())}, the same "
          f"as in-process bit for bit; {cluster_seconds:.1f} s on the cluster, "
          f"{time.monotonic() - start:.1f} s in all")


if __name__ == "__main__":
    main()

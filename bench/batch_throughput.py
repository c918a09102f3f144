#!/usr/bin/python3
"""Pairs per minute of align3d.batch on 1 and 2 workers, with and without a prepared target, and
the batch layer's own overhead against the registration time measured in one process.

Data: the benchmark work cell (`align3d synth --scene parts --points N`, default 40 000 points per
cloud) and PAIRS scans of it, each the scan moved by a further known rotation of up to 8 degrees
(the auto path: ICP from the identity, the global stage where that is not well supported); all
against the one model, as a line registers its scans.

The workers are a LocalCluster's by default; with --separate, a `dask scheduler` and N `dask
worker` processes started as separate programs (this Python's `-m dask`, one thread each: a
cluster of hosts, on one), the way docs/cluster.md starts them. The Dask overhead per pair is the
1-worker batch time less the same pairs registered one after another in this process, per pair.

Run with the package's Python, from the repository: .venv/bin/python bench/batch_throughput.py
(a venv with the wheel installed works as well; --cli names an `align3d` for the data).
"""

import argparse
import contextlib
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np

import align3d
import align3d.batch as batch
from dask.distributed import Client, LocalCluster


def rotation(axis, deg):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    a = np.radians(deg)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def make_pairs(directory, points, count, cli):
    subprocess.run([cli, "synth", directory, "--scene", "parts", "--points", str(points)],
                   check=True, stdout=subprocess.DEVNULL)
    scan = align3d.read_point_cloud(os.path.join(directory, "scan.ply")).points
    rng = np.random.default_rng(1)
    pairs = []
    for k in range(count):
        R = rotation(rng.normal(size=3), rng.uniform(0, 8))
        name = os.path.join(directory, f"scan_{k:03d}.ply")
        align3d.write_point_cloud(name, scan @ R.T)
        pairs.append((name, os.path.join(directory, "model.ply")))
    return pairs


def in_process(pairs, prepared):
    """Seconds to register every pair one after another in this process, one thread each (the
    registration time the batch layer adds its overhead to)."""
    warnings.simplefilter("ignore")
    start = time.perf_counter()
    target = align3d.Target(pairs[0][1], threads=1) if prepared else None
    for source, model in pairs:
        align3d.register(source, target if prepared else model, threads=1)
    return time.perf_counter() - start


def two_processes(pairs, prepared):
    """Seconds for two plain processes (no Dask) registering half the pairs each at once: what
    this machine's two cores give two independent jobs, the ceiling for 2 workers."""
    import multiprocessing

    with multiprocessing.get_context("spawn").Pool(2) as pool:
        pool.map(abs, [0, 0])
        start = time.perf_counter()
        pool.starmap(in_process, [(pairs[0::2], prepared), (pairs[1::2], prepared)])
        return time.perf_counter() - start


def _register_files(pair):
    warnings.simplefilter("ignore")
    return align3d.register(pair[0], pair[1], threads=1).to_dict()


@contextlib.contextmanager
def separate_cluster(workers):
    """A client of a scheduler and `workers` worker processes on this host, each started as its
    own program (`python -m dask scheduler|worker`, one thread per worker), stopped at the end."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
                 start_new_session=True)  # its own process group: the nanny and its worker
    procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1",
                               "--port", str(port), "--no-dashboard"], **quiet)]
    try:
        for k in range(workers):
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "dask", "worker", address, "--name", f"worker-{k + 1}",
                 "--nthreads", "1", "--nworkers", "1", "--no-dashboard"], **quiet))
        with Client(address, timeout=60) as client:
            client.wait_for_workers(workers, timeout=60)
            yield client
    finally:
        for proc in procs:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGTERM)
        for proc in procs:
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()


@contextlib.contextmanager
def local_cluster(workers):
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        yield client


def on_cluster(pairs, workers, prepared, separate=False):
    with (separate_cluster if separate else local_cluster)(workers) as client:
        client.run(lambda: (__import__("align3d.batch"), batch._TARGETS.clear()) and None)
        start = time.perf_counter()
        if prepared:
            reports = batch.register_pairs(pairs, client)
        else:  # arrays for the target: nothing to keep between pairs
            reports = client.gather(client.map(_register_files, pairs, pure=False))
        seconds = time.perf_counter() - start
    assert not any("error" in r for r in reports)
    return seconds


def main():
    warnings.simplefilter("ignore")  # results' AlignWarnings: the reports hold them
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=40000)
    p.add_argument("--pairs", type=int, default=24)
    p.add_argument("--cli", default="build/align3d")
    p.add_argument("--repeat", type=int, default=3, help="the best of this many runs each")
    p.add_argument("--separate", action="store_true",
                   help="workers started as separate `dask worker` processes (default: a "
                   "LocalCluster's)")
    p.add_argument("--prepared-only", action="store_true",
                   help="only the batch's own path (register_pairs: targets prepared once per "
                   "worker), not the read-per-pair row")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as d:
        pairs = make_pairs(d, args.points, args.pairs, args.cli)
        rows = []
        for prepared in (True,) if args.prepared_only else (False, True):
            best = lambda f, *a: min(f(*a) for _ in range(args.repeat))  # noqa: E731
            alone = best(in_process, pairs, prepared)
            one = best(on_cluster, pairs, 1, prepared, args.separate)
            two = best(on_cluster, pairs, 2, prepared, args.separate)
            control = best(two_processes, pairs, prepared)
            rows.append((prepared, alone, one, two, control))
    n = args.pairs
    kind = "separate `dask worker` processes" if args.separate else "a LocalCluster's workers"
    print(f"{n} pairs of {args.points} points (parts scene, auto), {os.cpu_count()} cores, "
          f"{kind}, best of {args.repeat} runs each\n")
    print("| target | in one process, 1 thread (s/pair) | 1 worker (pairs/min) | 2 workers "
          "(pairs/min) | 2 ÷ 1 workers | two plain processes ÷ one | batch overhead, 1 worker "
          "| per pair (ms) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for prepared, alone, one, two, control in rows:
        print(f"| {'prepared once per worker' if prepared else 'read per pair'} | "
              f"{alone / n:.3f} | {60 * n / one:.1f} | {60 * n / two:.1f} | {one / two:.2f} | "
              f"{alone / control:.2f} | {100 * (one - alone) / alone:+.1f} % | "
              f"{1000 * (one - alone) / n:+.1f} |")
    print("\nTwo plain processes: the same pairs split over two processes without Dask, the "
          "ceiling this machine's two cores give two independent jobs.")
    print("The overhead columns are (1-worker batch time − the same pairs in one process) ÷ the "
          "latter, and the same difference per pair; they include the Dask tasks, the transfer "
          "of the reports and the worker's first target preparation.")


if __name__ == "__main__":
    sys.exit(main())

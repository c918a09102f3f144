"""Batches of registrations on a Dask cluster (Debian's ``python3-distributed``).

:func:`register_pairs` registers many (source, target) pairs on the workers of a cluster and
returns one report dict per pair, in input order; ``python -m align3d.batch`` (also ``align3d
batch``) does the same from a CSV file and writes one report file per pair. docs/cluster.md says
how to run it on many hosts.

Each worker keeps the targets it has prepared (:class:`align3d.Target`: kd-tree, normals,
descriptors) for the files it has seen, so a batch of scans against a few models prepares each
model once per worker. A result does not depend on the number of workers or on which worker ran
it (the same inputs and seed give the same pose).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import time
import warnings
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple

from . import _core
from ._errors import Error, FileError
from ._register import register

Pair = Tuple[Any, Any]

# Prepared targets of this process (a worker), by file and its modification: a line registers
# thousands of scans against a few models. Bounded: the oldest goes first.
_TARGETS: Dict[Tuple[str, int, int, int], Any] = {}
_MAX_TARGETS = 8


def _target_for(target: Any, settings: Dict[str, Any]) -> Any:
    """A prepared :class:`align3d.Target` for a target file (kept for the next pairs), or the
    target as given (an array, a cloud, a Target)."""
    from ._target import Target

    if not isinstance(target, (str, os.PathLike)):
        return target
    path = os.fspath(target)
    st = os.stat(path)  # a missing file raises here, and register() names it
    k = int(settings.get("normal_k", 20))
    key = (os.path.abspath(path), st.st_mtime_ns, st.st_size, k)
    if key not in _TARGETS:
        if len(_TARGETS) >= _MAX_TARGETS:
            del _TARGETS[next(iter(_TARGETS))]
        _TARGETS[key] = Target(path, normal_k=k, threads=int(settings.get("threads", 0)))
    return _TARGETS[key]


def _name(value: Any) -> Optional[str]:
    return os.fspath(value) if isinstance(value, (str, os.PathLike)) else None


def register_one(source: Any, target: Any, settings: Dict[str, Any]) -> Dict[str, Any]:
    """One pair's report (``Result.to_dict()``), or ``{"source", "target", "error",
    "error_type", "code"}`` when it fails; never raises for a bad pair."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the report's "warnings" holds them
            prepared = _target_for(target, settings)
            return register(source, prepared, **settings).to_dict()
    except (Error, OSError, ValueError, TypeError, MemoryError) as e:
        message = str(e)
        if isinstance(e, OSError) and e.filename and str(e.filename) not in message:
            message = f"{e.filename}: {e.strerror or message}"
        return {
            "source": _name(source),
            "target": _name(target),
            "error": message,
            "error_type": type(e).__name__,
            "code": getattr(e, "code", 3 if isinstance(e, OSError) else 1),
        }


def _run_chunk(chunk: Sequence[Pair], settings: Dict[str, Any]) -> List[Dict[str, Any]]:
    return [register_one(s, t, settings) for s, t in chunk]


def _connect(client: Any, workers: Optional[int]) -> Tuple[Any, List[Any]]:
    """The client to use and what to close afterwards, in order (nothing the caller owns)."""
    from dask.distributed import Client, LocalCluster

    if client is None:
        cluster = LocalCluster(
            n_workers=workers or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # any free port: no clash with a running cluster
            env={"OMP_NUM_THREADS": "1"},
        )
        own = Client(cluster)
        return own, [own, cluster]
    if isinstance(client, str):
        own = Client(client)
        return own, [own]
    return client, []


class _Progress:
    """``\\r12/400 pairs, 3.1/s, ETA 2 min`` on stderr when it is a terminal."""

    def __init__(self, total: int, enabled: bool) -> None:
        self.total, self.done, self.start = total, 0, time.monotonic()
        self.enabled = enabled and sys.stderr.isatty() and total > 0

    def advance(self, n: int) -> None:
        self.done += n
        if not self.enabled:
            return
        elapsed = max(time.monotonic() - self.start, 1e-9)
        rate = self.done / elapsed
        eta = (self.total - self.done) / rate if rate > 0 else 0
        width = 30
        bar = "=" * int(width * self.done / self.total)
        sys.stderr.write(
            f"\r[{bar:<{width}}] {self.done}/{self.total} pairs, {rate:.2f}/s, "
            f"ETA {eta / 60:.1f} min "
        )
        if self.done == self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def register_pairs(
    pairs: Iterable[Pair],
    client: Any = None,
    *,
    workers: Optional[int] = None,
    group: int = 1,
    progress: bool = False,
    on_result: Any = None,
    **settings: Any,
) -> List[Dict[str, Any]]:
    """Registers every (source, target) pair on a Dask cluster; returns their reports in input
    order.

    pairs: (source, target) tuples; each a file name (read on the worker, so on storage every
    worker sees) or an (N,3) array / PointCloud (sent to the worker). A target file is prepared
    once per worker and reused (:class:`align3d.Target`).
    client: None starts a ``LocalCluster`` of ``workers`` processes (default: the cores), one
    thread each, and closes it at the end; a scheduler address (``"tcp://host:8786"``) or a
    ``dask.distributed.Client`` uses an existing cluster.
    group: pairs per Dask task (Dask costs 0.2-1 ms per task: group small pairs).
    progress: a progress line on stderr (when it is a terminal).
    on_result: called as ``on_result(index, report)`` in the calling process as each pair
    finishes (``python -m align3d.batch`` writes the report files there).
    settings: keywords of :func:`align3d.register` (same names as ``align3d register``'s flags);
    ``threads`` defaults to 1 inside workers (one worker per core).

    A pair that fails gives ``{"source", "target", "error", "error_type", "code"}``: ``error`` is
    the message, naming the file at fault; the other pairs finish. A result does not depend on
    the number of workers.
    """
    pairs = [tuple(p) for p in pairs]
    for i, p in enumerate(pairs):
        if len(p) != 2:
            raise ValueError(f"pairs[{i}]: expected (source, target), got {len(p)} items")
    if not isinstance(group, int) or group < 1:
        raise ValueError(f"group: expected an integer >= 1, got {group!r}")
    settings.setdefault("threads", 1)
    chunks = [pairs[i : i + group] for i in range(0, len(pairs), group)]
    out: List[Optional[Dict[str, Any]]] = [None] * len(pairs)
    if not chunks:
        return []
    from dask.distributed import as_completed

    dask_client, to_close = _connect(client, workers)
    try:
        futures = dask_client.map(_run_chunk, chunks, settings=settings, pure=False)
        index = {f.key: k for k, f in enumerate(futures)}
        bar = _Progress(len(pairs), progress)
        for future in as_completed(futures):
            k = index[future.key]
            for j, report in enumerate(future.result()):
                out[k * group + j] = report
                if on_result is not None:
                    on_result(k * group + j, report)
            bar.advance(len(chunks[k]))
            future.release()
    finally:
        for c in to_close:
            c.close()
    return out  # type: ignore[return-value]


# ---- the command: python -m align3d.batch PAIRS.csv --report-dir DIR ----

EXIT_FAILED_PAIRS = 8  # some pairs failed: their DIR/NAME.failed.json say why


def read_pairs(path: str) -> List[Tuple[str, str, str]]:
    """(source, target, report name) per row of a CSV file: ``source,target[,report]``; a first
    row ``source,target,...`` is a header; relative paths are relative to the CSV file; the
    report name defaults to ``SOURCESTEM--TARGETSTEM.json`` (made unique by the row number)."""
    base = os.path.dirname(os.path.abspath(path))
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = [r for r in csv.reader(f) if r and any(c.strip() for c in r)]
    except OSError as e:
        raise _file_error(path, e.strerror or str(e)) from None
    except (UnicodeDecodeError, csv.Error) as e:
        raise _file_error(path, f"not a CSV text file ({e})") from None
    if rows and [c.strip().lower() for c in rows[0][:2]] == ["source", "target"]:
        rows = rows[1:]
    out, seen = [], set()
    for n, row in enumerate(rows, start=1):
        cells = [c.strip() for c in row]
        if len(cells) < 2 or not cells[0] or not cells[1] or len(cells) > 3:
            raise _file_error(path, f"row {n}: expected source,target[,report], got {row}")
        src, tgt = (c if os.path.isabs(c) else os.path.join(base, c) for c in cells[:2])
        name = cells[2] if len(cells) == 3 and cells[2] else None
        if name is None:
            stem = lambda p: os.path.splitext(os.path.basename(p))[0]  # noqa: E731
            name = f"{stem(src)}--{stem(tgt)}.json"
            if name in seen:
                name = f"{stem(src)}--{stem(tgt)}-{n}.json"
        if name in seen or os.path.basename(name) != name:
            raise _file_error(path, f"row {n}: report name {name!r} repeats or has a folder")
        seen.add(name)
        out.append((src, tgt, name))
    return out


def _file_error(path: str, problem: str) -> FileError:
    return FileError(f"{path}: {problem}", path)


def _write_atomically(path: str, data: Dict[str, Any]) -> None:
    _core.write_text(path, json.dumps(data, indent=2) + "\n")


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="align3d batch",
        description="Register every pair of a CSV file (source,target[,report]) on a Dask "
        "cluster, writing one JSON report per pair into --report-dir (atomically; the "
        "register command's report, docs/report.md). Pairs whose report exists are skipped, so "
        "a run that stopped resumes where it was. A pair that fails writes NAME.failed.json "
        "with the error instead (retried on the next run). Exit codes: 0 all pairs done, 2 "
        "usage, 3 the CSV file cannot be read, 8 some pairs failed.",
    )
    p.add_argument("pairs", metavar="PAIRS.csv", help="source,target[,report] per row")
    p.add_argument("--report-dir", required=True, help="folder for the reports (created)")
    p.add_argument("--scheduler", help="address of a running Dask scheduler (tcp://host:8786); "
                   "default: a local cluster")
    p.add_argument("--workers", type=int, help="local cluster: worker processes (default: cores)")
    p.add_argument("--group", type=int, default=1, help="pairs per Dask task (default 1)")
    p.add_argument("--init", default="auto", help="as align3d register (auto|identity|global)")
    p.add_argument("--method", default="point-to-plane", help="as align3d register")
    p.add_argument("--kernel", default="auto", help="as align3d register")
    p.add_argument("--kernel-scale", type=float, default=0.0, help="as align3d register")
    p.add_argument("--global", dest="global_method", default="fpfh", help="fpfh or ppf")
    p.add_argument("--voxel", type=float, default=0.0, help="as align3d register")
    p.add_argument("--seed", type=int, default=1, help="as align3d register")
    p.add_argument("--max-iterations", type=int, default=60, help="as align3d register")
    p.add_argument("--quiet", action="store_true", help="no progress line and no summary")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = _parser().parse_args(argv)
    if args.workers is not None and args.workers < 1:
        _parser().error("--workers: expected at least 1")
    if args.group < 1:
        _parser().error("--group: expected at least 1")
    try:
        rows = read_pairs(args.pairs)
    except Error as e:
        print(f"align3d: {e}", file=sys.stderr)
        return e.code
    os.makedirs(args.report_dir, exist_ok=True)
    todo = [r for r in rows if not os.path.exists(os.path.join(args.report_dir, r[2]))]
    if not args.quiet and len(todo) < len(rows):
        print(f"{len(rows) - len(todo)} of {len(rows)} pairs have reports already: skipped")
    failed = 0

    def write(i: int, report: Dict[str, Any]) -> None:
        nonlocal failed
        name = os.path.join(args.report_dir, todo[i][2])
        stale = name[: -len(".json")] + ".failed.json" if name.endswith(".json") else name + ".failed"
        if "error" in report:
            failed += 1
            _write_atomically(stale, report)
            print(f"align3d: {report['error']}", file=sys.stderr)
        else:
            _write_atomically(name, report)
            if os.path.exists(stale):
                os.remove(stale)

    settings = dict(init=args.init, method=args.method, kernel=args.kernel,
                    kernel_scale=args.kernel_scale, global_method=args.global_method,
                    voxel=args.voxel, seed=args.seed, max_iterations=args.max_iterations)
    start = time.monotonic()
    register_pairs([(s, t) for s, t, _ in todo], args.scheduler, workers=args.workers,
                   group=args.group, progress=not args.quiet, on_result=write, **settings)
    if not args.quiet:
        print(f"{len(todo) - failed} pairs registered, {failed} failed, in "
              f"{time.monotonic() - start:.1f} s; reports in {args.report_dir}")
    return EXIT_FAILED_PAIRS if failed else 0


if __name__ == "__main__":
    sys.exit(main())

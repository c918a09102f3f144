#!/usr/bin/env python3
"""Two registrations run one after the other, then in two Python threads at once.

The package releases the GIL while the C++ library works, so on two free cores the threaded run
takes about as long as one registration: a ratio threaded / serial near 0.5 (1.0 would mean the
GIL serialises them). Each registration uses one library thread (threads=1), so the parallelism
measured is Python's own. The scene is the parts work cell of `align3d synth --scene parts`
(POINTS points a cloud, generated into a temporary directory). Best of ROUNDS rounds.

On a shared machine other jobs may leave fewer than two free cores, and the ratio then stays near
1.0 whatever Python does. The script says so: it prints the CPU time the process used per second
of the threaded run (2.0: two cores busy; the GIL would hold it to 1.0), and a control, one
registration with the library's own two threads (threads=2), whose CPU/wall is the most this
machine gives the process at the moment.

Usage: .venv/bin/python bench/python_threads.py [--points N] [--rounds R]
"""

import argparse
import tempfile
import threading
import time
import warnings

import align3d


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=int, default=50000)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    warnings.simplefilter("ignore", align3d.AlignWarning)
    with tempfile.TemporaryDirectory() as directory:
        align3d.synth(directory, scene="parts", points=args.points)
        scan = align3d.read_point_cloud(f"{directory}/scan.ply")
        model = align3d.read_point_cloud(f"{directory}/model.ply")

    def one():
        align3d.register(scan, model, threads=1)

    one()  # warm-up: page in the code, start the library's pool
    serial, threaded, threaded_cpu, control_cpu = [], [], [], []
    for _ in range(args.rounds):
        start = time.perf_counter()
        one()
        one()
        serial.append(time.perf_counter() - start)
        workers = [threading.Thread(target=one) for _ in range(2)]
        start, cpu = time.perf_counter(), time.process_time()
        for w in workers:
            w.start()
        for w in workers:
            w.join()
        threaded.append(time.perf_counter() - start)
        threaded_cpu.append((time.process_time() - cpu) / threaded[-1])
        start, cpu = time.perf_counter(), time.process_time()
        align3d.register(scan, model, threads=2)
        control_cpu.append((time.process_time() - cpu) / (time.perf_counter() - start))
    s, t = min(serial), min(threaded)
    print(f"two registrations of {len(scan)} onto {len(model)} points, threads=1 each, "
          f"best of {args.rounds}:")
    print(f"  one after the other: {s * 1e3:8.1f} ms")
    print(f"  two Python threads:  {t * 1e3:8.1f} ms")
    print(f"  ratio (2 threads / 1 thread): {t / s:.2f}  (0.5: fully parallel, 1.0: serialised)")
    print(f"  CPU/wall of the threaded run: {max(threaded_cpu):.2f}  (2.0: two cores busy)")
    print(f"  control, one registration with threads=2: CPU/wall {max(control_cpu):.2f}  "
          "(the cores this machine gives now; below ~1.8 the ratio cannot reach 0.5)")


if __name__ == "__main__":
    main()

"""The GIL is released while the library works: two Python threads are inside the C++ registration
at the same time.

How it is seen, without a timing threshold: each thread passes a progress callback. The library
calls it between stages, from inside align(); the callback records that its thread is back in
Python, and every thread's first callback waits (bounded) until the other thread has reached its
own, so both are inside align() before either goes on. Each thread then looks, whenever it runs
Python (in a later callback, or once register() has returned), at what the other is doing. It
records an overlap when the other has entered register(), is not in a callback and has not
returned: the other is computing in C++ at that moment.

Python switches threads every few milliseconds by itself, even in the middle of register()'s
Python code after the C++ call; that would let a thread look at the other "between" its flags
although the GIL was never released. So the test sets the switch interval far beyond its
duration: the GIL then changes hands only where a thread blocks or releases it explicitly (the
barrier, the end of a thread, the extension around its C++ work). Were the GIL held during the
computation, no overlap could be seen (checked by building the extension without the release);
with it released, the first thread to return finds the other still computing (unless the other is
inside a callback at that instant: microseconds of a registration that lasts a few hundred
milliseconds).
"""

import sys
import threading

import align3d
from conftest import rigid, surface

TIMEOUT_S = 120


class Thread:
    def __init__(self):
        self.entered = False  # inside align3d.register() (set just before the call)
        self.in_callback = False
        self.returned = False
        self.callbacks = 0


def test_two_threads_register_at_the_same_time():
    pairs = []
    for k in range(2):
        T = rigid([1, 2, 3], 8.0 + k, [0.1, -0.1, 0.05])
        target = surface(20000, seed=10 + k)
        source = (surface(20000, seed=20 + k) - T[:3, 3]) @ T[:3, :3]
        pairs.append((source, target))
    threads = [Thread(), Thread()]
    both_inside = threading.Barrier(2, timeout=TIMEOUT_S)
    overlaps = []
    errors = []

    def look_at(me):
        other = threads[1 - me]
        if other.entered and not other.in_callback and not other.returned:
            overlaps.append(me)

    def run(me):
        state = threads[me]

        def progress(task, done, total):
            state.in_callback = True
            if state.callbacks == 0:
                both_inside.wait()
            state.callbacks += 1
            look_at(me)
            state.in_callback = False

        try:
            state.entered = True
            align3d.register(*pairs[me], threads=1, progress=progress)
        except BaseException as e:  # noqa: BLE001 (reported below)
            errors.append(e)
        finally:
            state.returned = True
            look_at(me)

    workers = [threading.Thread(target=run, args=(me,)) for me in range(2)]
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1000.0)
    try:
        for w in workers:
            w.start()
        for w in workers:
            w.join(TIMEOUT_S)
    finally:
        sys.setswitchinterval(interval)
    assert not errors, errors
    assert all(t.callbacks > 0 for t in threads)
    assert overlaps, "no thread ever saw the other computing in C++: the GIL was held"


"""The ``align3d`` command of an installed package (the wheel's console script): the same tool as
the C++ executable, run inside the extension module (``_core.cli_main``), so the package brings
its command line without a compiler.

``align3d batch`` runs the batch engine with the Python that runs this command (the environment's
``ALIGN3D_PYTHON`` still overrides it): the interpreter of the environment the wheel is in.
"""

from __future__ import annotations

import os
import signal
import sys
from typing import Optional, Sequence


def main(args: Optional[Sequence[str]] = None) -> int:
    """Runs ``align3d ARGS...`` (default: the process's arguments); the exit code."""
    from . import _core

    os.environ.setdefault("ALIGN3D_PYTHON", sys.executable)
    # Ctrl-C stops the command as it stops the executable (Python's handler would wait for the
    # C++ to return), and a closed pipe ends it quietly.
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    sys.stdout.flush()
    sys.stderr.flush()
    return _core.cli_main(["align3d", *(sys.argv[1:] if args is None else args)])


if __name__ == "__main__":
    sys.exit(main())

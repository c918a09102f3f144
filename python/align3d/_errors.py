"""align3d's exceptions and warnings.

One class per error class of the C++ library (``align3d/error.hpp``); the extension module raises
them (``python/src/errors.cpp``). Each error has ``code``, the exit code the ``align3d`` tool gives
for the same error, so a script can mirror the command line.
"""

from __future__ import annotations

from typing import Any, Optional


class Error(Exception):
    """Base of every align3d error. ``code``: the command line's exit code for it (1: a bug)."""

    code: int = 1


class FileError(Error, OSError):
    """A file cannot be read (missing, unreadable, malformed, truncated, unknown format: code 3)
    or written (code 5). The message starts with the file name and, for a parse error, names the
    line (text) or byte offset (binary); ``path`` (also ``filename``) is the file."""

    code = 3

    def __init__(self, message: str, path: Optional[str] = None) -> None:
        super().__init__(message)
        self.filename = path

    @property
    def path(self) -> Optional[str]:
        """The file at fault (OSError's ``filename``)."""
        return self.filename

    @path.setter
    def path(self, value: Optional[str]) -> None:
        self.filename = value

    def __str__(self) -> str:  # OSError would print "[Errno None] None: 'path'"
        return str(self.args[0]) if self.args else ""


class DataError(Error, ValueError):
    """The data cannot be used (code 4): too few points, all on a line or at one spot, no plane,
    a NaN or Inf coordinate, out of memory for a file's points. ``subject`` names what is at
    fault (``"source"``, ``"target"``, ``"cloud"``, a file; may be empty) and ``problem`` the
    message without it."""

    code = 4
    subject: str = ""
    problem: str = ""


class SettingsError(Error, ValueError):
    """A keyword argument no run can use (code 2, the command line's usage error): an unknown
    choice, a value out of range, a matrix that is not rigid, options that exclude each other."""

    code = 2


class NoSolutionError(Error):
    """Registration found no usable solution (code 6): too few correspondences. ``result`` holds
    the full :class:`Result` (its report says what was tried)."""

    code = 6

    def __init__(self, message: str, result: Any = None) -> None:
        super().__init__(message)
        self.result = result


class StrictError(Error):
    """``strict=True`` and the result came with warnings (code 7, ``--strict``). Outputs were
    written; ``result`` holds the full result, ``warnings`` its warnings."""

    code = 7

    def __init__(self, message: str, result: Any = None) -> None:
        super().__init__(message)
        self.result = result
        self.warnings = list(getattr(result, "warnings", []))


class AlignWarning(UserWarning):
    """A result that may be wrong (docs/report.md, "Warning codes"): ``code`` is the stable
    identifier (``weak_overlap``, ``high_rms``, ``degenerate``, ``not_converged``,
    ``stopped_short``, ``ambiguous``, ``global_failed``, ``not_flat``; ``file`` for a file-level
    note such as dropped NaN points), ``message`` the sentence for people. Results list them in
    ``warnings``; the functions also issue them through Python's :mod:`warnings` (as the command
    line prints them on stderr)."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message

    def __repr__(self) -> str:
        return f"AlignWarning({self.code!r}, {self.message!r})"

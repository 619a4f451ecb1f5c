"""What a design may read: the folders of a compilation and how files in them are opened.

A design is untrusted input: knitc compiles designs from anyone on CI and build servers, so
the two constructs that name files, `import "file.knit"` and `img("file.png")`, may read only
below the folders the user gave (the design's own folder and `--include DIR` folders). A
path is judged by where it really leads (`..` and symlinks resolved), before anything about
the file is looked at, so a refused path tells the design nothing, not even whether the file
exists. A file that may be read is opened only if it is a regular file of a bounded size: a
FIFO would block the compiler forever, a device could be read without end. See
docs/security.md for the whole model.

The folders are set for the duration of a compilation by the driver (`reading_below`), so
the passes that open files (imports in `frontend/definitions.py`, images in
`patterning/raster.py`) need no extra parameter threaded through every stage.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from knitc.records import record

MAX_IMPORT_BYTES = 8 * 1024 * 1024
"""Largest file an `import` reads: the biggest module knitc ships is a few KB, and the
parser needs seconds per MB."""

MAX_IMAGE_BYTES = 64 * 1024 * 1024
"""Largest file `img()` reads (its pixels are limited separately, `raster.MAX_PIXELS`)."""


class AccessProblem(Exception):
    """A file a design may not read (`refused`: outside the folders, E226) or cannot read
    (missing, not a regular file, too large: the caller's own code)."""

    def __init__(self, message: str, *, refused: bool, hint: str | None = None):
        super().__init__(message)
        self.message, self.refused, self.hint = message, refused, hint


@record(frozen=True)
class ReadRoots:
    """The folders a compilation may read below, as given (`shown`, for messages that
    must not depend on the machine) and with symlinks resolved (`real`, for the check)."""

    shown: tuple[str, ...]
    real: tuple[str, ...]

    @staticmethod
    def for_design(path: str, include: Iterable[str] = ()) -> ReadRoots:
        """The design's own folder (the working directory for text without a file, such
        as `<input>`) and the `include` folders."""
        own = "." if path.startswith("<") else (os.path.dirname(path) or ".")
        shown = (own, *include)
        return ReadRoots(shown, tuple(os.path.realpath(d) for d in shown))

    def contains(self, real_path: str) -> bool:
        """Is `real_path` (symlinks resolved) below one of the folders?"""
        return any(os.path.commonpath((root, real_path)) == root for root in self.real)

    def describe(self) -> str:
        *rest, last = [f"`{d}`" for d in self.shown]
        return f"{', '.join(rest)} and {last}" if rest else last


_ACTIVE: ContextVar[ReadRoots | None] = ContextVar("knitc_read_roots", default=None)


@contextmanager
def reading_below(roots: ReadRoots) -> Iterator[None]:
    """Make `roots` the folders files may be read from while the block runs."""
    token = _ACTIVE.set(roots)
    try:
        yield
    finally:
        _ACTIVE.reset(token)


def active_roots() -> ReadRoots | None:
    """The folders of the running compilation (None outside the driver)."""
    return _ACTIVE.get()


def check_within(path: str, name: str, roots: ReadRoots, what: str) -> str:
    """The real path of `path` (which the design wrote as `name`) if it lies below `roots`;
    else an AccessProblem (E226) that names neither what is there nor whether it exists."""
    if "\0" in path:  # no file has such a name, and the OS refuses it with a ValueError
        shown = name.replace("\0", "\\0")
        raise AccessProblem(
            f"`{shown}` is not a file name: it holds a NUL character",
            refused=True,
            hint="remove the NUL (`\\0`) characters from the path",
        )
    real = os.path.realpath(path)
    if roots.contains(real):
        return real
    raise AccessProblem(
        f"`{name}` is outside the folders this design may read ({_how(name, path, real)})",
        refused=True,
        hint=f"a design reads {what} only below {roots.describe()}; "
        "give another folder with `--include DIR`",
    )


def _how(name: str, path: str, real: str) -> str:
    """How a path left the folders, for the message: an absolute path, `..`, a symlink."""
    if ".." in name.replace("\\", "/").split("/"):
        return "`..` leads out of them"
    if os.path.normpath(os.path.abspath(path)) != real:
        return "a symlink leads out of them"
    if os.path.isabs(name):
        return "an absolute path"
    return "the file that names it is outside them"


_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)


def read_regular(real: str, name: str, limit: int) -> bytes:
    """The bytes of the regular file at `real` (at most `limit` of them), or AccessProblem.

    The kind of file is checked before it is opened and again on the open descriptor (a
    file swapped in between); the open never blocks (O_NONBLOCK: a FIFO's open would wait
    for a writer forever)."""
    try:
        if not stat.S_ISREG(os.stat(real).st_mode):
            raise AccessProblem(_not_regular(name, real), refused=False)
        # `real` has no symlink left in it: O_NOFOLLOW refuses one swapped in since
        fd = os.open(real, os.O_RDONLY | os.O_NONBLOCK | _NOFOLLOW | _CLOEXEC)
    except OSError as exc:
        raise AccessProblem(f"cannot read `{name}`: {exc.strerror or exc}", refused=False) from None
    with os.fdopen(fd, "rb") as f:
        info = os.fstat(f.fileno())
        if not stat.S_ISREG(info.st_mode):
            raise AccessProblem(_not_regular(name, real), refused=False)
        if info.st_size > limit:
            raise AccessProblem(_too_large(name, info.st_size, limit), refused=False)
        data = f.read(limit + 1)
    if len(data) > limit:  # it grew while we read
        raise AccessProblem(_too_large(name, len(data), limit), refused=False)
    return data


def _not_regular(name: str, real: str) -> str:
    kind = "a directory" if os.path.isdir(real) else "not a regular file (a device or FIFO)"
    return f"`{name}` is {kind}"


def _too_large(name: str, size: int, limit: int) -> str:
    return f"`{name}` is {size:,} bytes; knitc reads at most {limit:,}"

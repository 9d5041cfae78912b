"""Writing files without following links: the one place that creates an output file.

A run directory can come from someone else (a tar keeps symbolic links), so a planted
``report.html -> ~/.bashrc`` or ``figures -> /somewhere`` must not redirect a write. Every
output is written to a fresh temporary name in its own folder, created by
:func:`tempfile.mkstemp` (``O_CREAT | O_EXCL | O_NOFOLLOW``: never an existing file, never
through a link), flushed to disk and then renamed over the final name with
:func:`os.replace` (a rename replaces a link itself, it does not write through it). A link
found where the file or its folder belongs is refused (:class:`LinkRefused`) before
anything is written, so a reader of the directory sees either the old file or the new one,
whole, and never a file outside it.

This guards against links planted before a command starts, not against a process that
swaps a folder for a link while hypate writes into it (that needs a directory file
descriptor for every path component; the threat here is a received directory).

Only the standard library: the simulator (``Response.save``), the engine and the
workflow all write through it.
"""
from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO

__all__ = ["LinkRefused", "TEMP_SUFFIX", "atomic_file", "ensure_directory", "refuse_link",
           "remove_stale_temporaries", "same_content", "write_bytes", "write_text"]

#: Suffix of the temporary files of :func:`atomic_file` (``.<name>.<random>.tmp``).
TEMP_SUFFIX = ".tmp"


def _umask() -> int:
    """The process's umask (read once, at import, before any thread could create a file
    while it is briefly 0)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: Mode of a new output: what ``open(path, "w")`` gives (``mkstemp`` makes files 0600).
FILE_MODE = 0o666 & ~_umask()


class LinkRefused(Exception):
    """A symbolic link where a file or folder that hypate writes belongs (not a
    ``ValueError`` or ``OSError``: no handler of a bad value or a failed write may take it
    for one and carry on).

    Attributes
    ----------
    path : Path
        The link.
    target : str
        What it points to (as stored in the link).
    """

    def __init__(self, path: Path, target: str) -> None:
        self.path, self.target = Path(path), target
        super().__init__(f"{path} is a symbolic link (to {target}); hypate does not write "
                         "through links: remove it, or use another directory")


def refuse_link(path: str | Path) -> None:
    """Raise :class:`LinkRefused` when ``path`` is a symbolic link (also a dangling one).

    Parameters
    ----------
    path : str or Path

    Raises
    ------
    LinkRefused
    """
    path = Path(path)
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return
    if stat.S_ISLNK(info.st_mode):
        raise LinkRefused(path, os.readlink(path))


def ensure_directory(path: str | Path) -> Path:
    """``path`` as an existing directory, made (with its parents) if missing.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Path

    Raises
    ------
    LinkRefused
        ``path`` is a symbolic link (``os.mkdir`` does not follow one; the check says why).
    NotADirectoryError
        ``path`` exists and is not a directory.
    """
    path = Path(path)
    refuse_link(path)
    path.mkdir(parents=True, exist_ok=True)
    refuse_link(path)  # made by someone else between the check and mkdir
    if not path.is_dir():
        raise NotADirectoryError(f"{path} is not a directory")
    return path


def remove_stale_temporaries(path: str | Path) -> None:
    """Delete the temporary files a killed writer of ``path`` left (``.<name>.*.tmp``);
    ``os.unlink`` removes a link itself, never its target."""
    path = Path(path)
    if not path.parent.is_dir():
        return
    for old in path.parent.glob(f".{path.name}.*{TEMP_SUFFIX}"):
        with contextlib.suppress(OSError):
            old.unlink()


@contextlib.contextmanager
def atomic_file(path: str | Path, mode: str = "wb", *, encoding: str | None = None,
                newline: str | None = None) -> Iterator[IO]:
    """A new file object that becomes ``path`` when the block ends without an exception.

    The data goes to a fresh temporary file beside ``path`` (``O_EXCL | O_NOFOLLOW``), is
    flushed and synced (a full disk is reported here, not after the rename), and replaces
    ``path`` by :func:`os.replace`. On an exception (a full disk, Ctrl-C) the temporary
    file is removed and ``path`` keeps its old content.

    Parameters
    ----------
    path : str or Path
        The file to write; its folder must exist and neither may be a link.
    mode : {"wb", "w"}
        Binary or text.
    encoding, newline : str, optional
        Of a text file (``encoding`` default UTF-8).

    Yields
    ------
    file object

    Raises
    ------
    LinkRefused
        ``path`` or its folder is a symbolic link (nothing is written).
    OSError
        From the writes (``ENOSPC``, ``EFBIG``, ``EACCES`` ...), naming ``path`` (not the
        temporary file); ``path`` is unchanged.
    """
    if mode not in ("wb", "w"):
        raise ValueError(f"mode must be 'wb' or 'w', not {mode!r}")
    path = Path(path)
    refuse_link(path.parent)
    refuse_link(path)
    remove_stale_temporaries(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=TEMP_SUFFIX,
                                   dir=path.parent)
    except OSError as exc:
        raise _naming(exc, path) from None
    try:
        os.fchmod(fd, FILE_MODE)  # readable as any other file the user writes
        if mode == "w":
            handle: IO = os.fdopen(fd, "w", encoding=encoding or "utf-8", newline=newline)
        else:
            handle = os.fdopen(fd, "wb")
        with handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        refuse_link(path)  # planted while the data was written
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise _naming(exc, path) from None
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _naming(exc: OSError, path: Path) -> OSError:
    """``exc`` naming the file the caller writes (a write to a descriptor names none, the
    temporary file's name says nothing to a user)."""
    if exc.errno is None:
        return exc
    return OSError(exc.errno, exc.strerror or str(exc), str(path))


def same_content(path: str | Path, data: bytes) -> bool:
    """Whether ``path`` is a regular file (not a link) holding exactly ``data``."""
    try:
        info = os.lstat(path)
        if not stat.S_ISREG(info.st_mode) or info.st_size != len(data):
            return False
        with open(path, "rb") as handle:
            return handle.read() == data
    except OSError:
        return False


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through :func:`atomic_file`; returns ``path``.

    A file that already holds ``data`` is left alone (no temporary file, its mtime kept):
    a command that recomputes an output without changing it leaves the directory as it
    was. A link at ``path`` is refused all the same.
    """
    refuse_link(Path(path).parent)
    refuse_link(path)
    if same_content(path, data):
        return Path(path)
    with atomic_file(path, "wb") as handle:
        handle.write(data)
    return Path(path)


def write_text(path: str | Path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` through :func:`atomic_file`; returns ``path``."""
    return write_bytes(path, text.encode(encoding))

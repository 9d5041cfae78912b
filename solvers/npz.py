"""Reading ``.npz`` archives that come from outside (ROM files, snapshots, responses).

:func:`read_npz` checks an archive before numpy allocates anything: the file must be a zip
archive whose members are all ``.npy`` arrays; each member's header (read with
:mod:`numpy.lib.format`, which reads no data) must declare a plain dtype (no pickled
objects) and a size within the caps below; the members the caller needs must be present.
:func:`require_finite` rejects NaN and infinity in numeric members. Every problem is an
:class:`~hypate.solvers.errors.InputError` whose field names the file and whose message
names the member.
"""
from __future__ import annotations

import math
import zipfile
import zlib
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
from hypate.solvers.errors import InputError

__all__ = ["MAX_MEMBER_BYTES", "MAX_MEMBER_ELEMENTS", "float_member", "read_npz",
           "require_finite"]

#: Largest member an archive may declare, in elements (2**28, about 2.7e8) and in bytes
#: (2 GiB). The arrays hypate writes -- a ROM's POD bases (grid points x modes), a response's
#: nodal fields (steps x degrees of freedom) -- stay far below (the shipped studies' largest
#: hold a few 1e5 elements); a corrupted or hostile header (say 2**40 elements) is refused
#: before anything is allocated.
MAX_MEMBER_ELEMENTS = 2**28
MAX_MEMBER_BYTES = 2**31


def _header(archive: zipfile.ZipFile, info: zipfile.ZipInfo
            ) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype declared by one ``.npy`` member (reads only its header)."""
    with archive.open(info) as fh:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
        else:
            raise ValueError(f"unsupported .npy format version {version}")
    return shape, dtype


def _check_member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, field: str) -> None:
    member = info.filename.removesuffix(".npy")
    if not info.filename.endswith(".npy") or info.is_dir():
        raise InputError(field, f"member {info.filename!r} is not an .npy array")
    if info.file_size > MAX_MEMBER_BYTES + 4096:  # + the .npy header
        raise InputError(field, f"member {member!r}: {info.file_size} bytes exceed the cap of "
                         f"{MAX_MEMBER_BYTES} bytes")
    try:
        shape, dtype = _header(archive, info)
    except (ValueError, EOFError, zlib.error, zipfile.BadZipFile) as exc:
        raise InputError(field, f"member {member!r}: not a readable .npy header ({exc})") \
            from None
    if dtype.hasobject:
        raise InputError(field, f"member {member!r}: object arrays (pickles) are not read")
    n = math.prod(shape)
    if n > MAX_MEMBER_ELEMENTS or n * dtype.itemsize > MAX_MEMBER_BYTES:
        raise InputError(field, f"member {member!r}: declared shape {shape} of {dtype} exceeds "
                         f"the cap of {MAX_MEMBER_ELEMENTS} elements / {MAX_MEMBER_BYTES} bytes")


def read_npz(path: str | Path, field: str, required: Iterable[str] = ()
             ) -> dict[str, np.ndarray]:
    """All members of the ``.npz`` archive at ``path``, checked before they are read.

    Parameters
    ----------
    path : str or Path
    field : str
        Key path naming the file in errors, e.g. ``"rom:model.npz"``.
    required : iterable of str
        Members that must be present.

    Returns
    -------
    dict of str to ndarray

    Raises
    ------
    InputError
        Missing file, a directory, not a zip archive, a member that is not a plain ``.npy``
        array or declares more than :data:`MAX_MEMBER_ELEMENTS` elements or
        :data:`MAX_MEMBER_BYTES` bytes, unreadable data, missing required members.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(field, f"{path} is a directory, not an .npz file")
    if not path.is_file():
        raise InputError(field, f"{path} not found")
    if not zipfile.is_zipfile(path):
        raise InputError(field, f"{path} is not an .npz archive (not a zip file)")
    try:
        with zipfile.ZipFile(path) as archive:
            for info in archive.infolist():
                _check_member(archive, info, field)
        with np.load(path, allow_pickle=False) as npz:
            data = {name: npz[name] for name in npz.files}
    except InputError:
        raise  # a member's check (an InputError is a ValueError too)
    except (zipfile.BadZipFile, zlib.error, EOFError) as exc:
        raise InputError(field, f"corrupted .npz archive ({exc})") from None
    except (OSError, ValueError) as exc:
        raise InputError(field, f"unreadable .npz archive ({type(exc).__name__}: {exc})") \
            from None
    except MemoryError:
        raise InputError(field, "the archive's arrays do not fit into memory") from None
    missing = [name for name in required if name not in data]
    if missing:
        raise InputError(field, f"missing member{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(map(repr, missing))}")
    return data


def require_finite(data: Mapping[str, np.ndarray], field: str,
                   names: Iterable[str] | None = None) -> None:
    """Raise :class:`InputError` naming the first numeric member of ``names`` (default: all
    members) that holds NaN or infinity."""
    for name in data if names is None else names:
        values = np.asarray(data[name])
        if values.dtype.kind in "fc" and not np.all(np.isfinite(values)):
            raise InputError(field, f"member {name!r}: non-finite values (NaN or infinity)")


def float_member(data: Mapping[str, np.ndarray], name: str, field: str) -> np.ndarray:
    """Member ``name`` as a float array; :class:`InputError` if it is not numeric (a string
    or boolean array)."""
    values = np.asarray(data[name])
    if values.dtype.kind not in "iuf":
        raise InputError(field, f"member {name!r}: expected numbers, got {values.dtype} data")
    return values.astype(float)

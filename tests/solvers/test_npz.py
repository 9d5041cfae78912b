"""Reading outside .npz archives (solvers/npz.py): sizes capped before allocation, plain
arrays only, required members, finiteness."""
from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypate.solvers.errors import InputError
from hypate.solvers.npz import (
    MAX_MEMBER_ELEMENTS,
    float_member,
    read_npz,
    require_finite,
)


def _declaring(path: Path, shape: tuple[int, ...], descr: str = "<f8") -> Path:
    """An archive whose one member declares ``shape`` but holds a few bytes only."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": descr, "fortran_order": False, "shape": shape})
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("big.npy", header.getvalue() + b"\0" * 16)
    return path


def test_reads_what_numpy_writes(tmp_path: Path) -> None:
    arrays = {"a": np.arange(6.0).reshape(2, 3), "s": np.array("text"), "i": np.arange(3)}
    np.savez_compressed(tmp_path / "ok.npz", **arrays)
    data = read_npz(tmp_path / "ok.npz", "f", required=("a", "s"))
    assert set(data) == set(arrays)
    for key, value in arrays.items():
        np.testing.assert_array_equal(data[key], value)


@pytest.mark.parametrize("shape", [(2**40,), (2**14, 2**14, 2), (MAX_MEMBER_ELEMENTS + 1,)])
def test_declared_size_above_the_cap_is_refused_before_allocation(tmp_path: Path,
                                                                   shape: tuple) -> None:
    # numpy would try to allocate the declared array (MemoryError for 2**40 doubles)
    with pytest.raises(InputError, match="^f: member 'big': declared shape .* exceeds the cap"):
        read_npz(_declaring(tmp_path / "big.npz", shape), "f")


def test_wide_strings_count_their_bytes(tmp_path: Path) -> None:
    # two elements of 2e9 bytes each: under the element cap, over the byte cap
    with pytest.raises(InputError, match="^f: member 'big': declared shape .* exceeds the cap"):
        read_npz(_declaring(tmp_path / "wide.npz", (2,), "|S2000000000"), "f")


def _archive(path: Path, members: dict[str, bytes]) -> Path:
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return path


def _npy(value: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, value, allow_pickle=True)
    return buf.getvalue()


@pytest.mark.parametrize("make, message", [
    (lambda d: d / "none.npz", "not found"),
    (lambda d: (d / "dir.npz").mkdir() or d / "dir.npz", "is a directory"),
    (lambda d: (d / "t.npz").write_text("hello") and d / "t.npz", "not a zip file"),
    (lambda d: _archive(d / "x.npz", {"notes.txt": b"hi"}), "'notes.txt' is not an .npy"),
    (lambda d: _archive(d / "o.npz", {"o.npy": _npy(np.array([{}], dtype=object))}),
     "member 'o': object arrays"),
    (lambda d: _archive(d / "h.npz", {"h.npy": b"\x93NUMPY garbage"}),
     "member 'h': not a readable .npy header"),
    (lambda d: _archive(d / "m.npz", {"a.npy": _npy(np.zeros(2))}), "missing member 'b'"),
])
def test_refused_archives_name_the_member(tmp_path: Path, make, message: str) -> None:
    path = make(tmp_path)
    with pytest.raises(InputError) as info:
        read_npz(path, f"file {path.name}", required=("a", "b"))
    assert info.value.field == f"file {path.name}" and message in info.value.message
    assert "InputError" not in info.value.message  # a member's own error, not re-wrapped


def test_truncated_archive_is_an_input_error(tmp_path: Path) -> None:
    np.savez(tmp_path / "ok.npz", a=np.arange(10_000.0))
    raw = (tmp_path / "ok.npz").read_bytes()
    (tmp_path / "cut.npz").write_bytes(raw[: len(raw) // 2])
    with pytest.raises(InputError):
        read_npz(tmp_path / "cut.npz", "f")


def test_require_finite_and_float_member_name_the_member() -> None:
    data = {"ok": np.ones(3), "n": np.array([1.0, np.nan]), "z": np.array([1j, np.inf]),
            "s": np.array(["a"]), "i": np.arange(2)}
    require_finite(data, "f", ["ok", "s", "i"])  # strings and integers have no NaN
    with pytest.raises(InputError, match="member 'n': non-finite"):
        require_finite(data, "f")
    with pytest.raises(InputError, match="member 'z': non-finite"):
        require_finite(data, "f", ["z"])
    assert float_member(data, "i", "f").dtype == float
    with pytest.raises(InputError, match="member 's': expected numbers"):
        float_member(data, "s", "f")

"""Fault injection: malformed inputs of every command end in ONE line
``hypate: error: KEY: message`` on stderr, exit code 2, no traceback, and nothing written.

Each row of :data:`ROWS` writes its input files into a fresh working directory, runs the
command line there in-process (``hypate.scaling.cli.main.main``; an uncaught exception fails
the row) and checks the promise; :data:`CONSOLE_ROWS` run a few of them through the
installed console script. The valid base files the rows start from are checked to be valid
(``test_base_files_are_valid``), so each row fails for the one defect it injects. Rows about
``hypate run``'s own options (--out, --seed, --scheduler, --resume) live with the run tests.
"""
from __future__ import annotations

import dataclasses
import io
import math
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest
from conftest import PROTOTYPE_CASE, tiny_study_text
from hypate.scaling.cli.main import main
from hypate.solvers.aero.rom.build import build_rom_from_config
from hypate.solvers.aero.rom.config import parse_rom_config
from hypate.solvers.aero.rom.io import save_rom
from hypate.solvers.aero.rom.model import RomFluid

# -- valid base files -------------------------------------------------------------------------
CASE = """\
[panel]
kind = "3d"
length = 0.5
width = 0.5
mesh = [2, 2]
emissivity = 0.85

[[panel.layers]]
material = "ti6242"
thickness = 0.002

[materials.my_alloy]
density = 2700.0
youngs_modulus = 70.0e9
poisson_ratio = 0.33
thermal_expansion = 2.3e-5
conductivity = [[300.0, 130.0], [600.0, 150.0]]
specific_heat = 900.0

[flow]
mach = 6.0
altitude = 25000.0

[simulation]
scheme = "tc"
aero = "pt-bl"
time_step = 1.0
duration = 2.0
"""
STUDY = tiny_study_text()
ROM_BUILD = """\
[panel]
kind = "2d"
length = 1.0
leading_edge_length = 1.0
thickness = 0.0025

[grid]
n_x = 9

[reference]
mach = 6.0
altitude = 25000.0

[[modes]]
m = 1
range = [-6.0, 6.0]

[wall_temperature]
range = [200.0, 900.0]

[training]
samples = 12
seed = 1
restarts = 0
optimized_modes = 1
"""


def edit(text: str, old: str, new: str) -> str:
    """``text`` with ``old`` replaced by ``new``; ``old`` must occur (a row that injects
    nothing would pass for the wrong reason)."""
    if old not in text:
        raise ValueError(f"{old!r} is not in the base file")
    return text.replace(old, new, 1)


def study(old: str, new: str) -> dict[str, str]:
    return {"s.toml": edit(STUDY, old, new)}


def case(old: str, new: str) -> dict[str, str]:
    return {"c.toml": edit(CASE, old, new)}


def rom_build(old: str, new: str) -> dict[str, str]:
    return {"r.toml": edit(ROM_BUILD, old, new)}


@dataclasses.dataclass(frozen=True)
class Asset:
    """A file built once per module (a ROM archive and its malformed variants)."""

    name: str


#: A directory instead of a file.
DIR = object()


@dataclasses.dataclass(frozen=True)
class Row:
    id: str
    argv: tuple[str, ...]
    key: str
    files: dict[str, object] = dataclasses.field(default_factory=dict)
    says: tuple[str, ...] = ()  # further text the message must contain


def row(id: str, argv: str, key: str, files: dict[str, object] | None = None,
        says: tuple[str, ...] = ()) -> Row:
    return Row(id, tuple(argv.split()), key, dict(files or {}), says)


ROWS = [
    # -- study files: strict types, finite floats, ranges -------------------------------------
    row("study-string-int", "validate s.toml", "optimizer.initial_samples",
        study("initial_samples = 4", 'initial_samples = "16"'),
        says=("integer", "[1, 10000]", "'16'")),
    row("study-inf-weight", "validate s.toml", "optimizer.weights[0]",
        study("seed = 3", "seed = 3\nweights = [inf, 1]"), says=("finite", ">= 0")),
    row("study-nan-law", "validate s.toml", "laws.analytical.h",
        study("[optimizer]", "[laws]\nanalytical.h = nan\n\n[optimizer]"), says=("finite",)),
    row("study-bool-int", "validate s.toml", "optimizer.seed",
        study("seed = 3", "seed = true"), says=("integer", "boolean")),
    row("study-float-int", "validate s.toml", "optimizer.iterations",
        study("iterations = 2", "iterations = 2.5"), says=("integer",)),
    row("study-string-float", "validate s.toml", "study.xi",
        study("xi = 4.0", 'xi = "4"'), says=("number", "[1, 100]")),
    row("study-number-string", "validate s.toml", "model.material",
        study('material = "ti6242"', "material = 6"), says=("string",)),
    row("study-bool-string", "validate s.toml", "simulation.aero",
        study('aero = "pt-bl"', "aero = true"), says=("string",)),
    row("study-xi-range", "validate s.toml", "study.xi",
        study("xi = 4.0", "xi = 0.5"), says=("[1, 100]",)),
    row("study-steps-zero", "validate s.toml", "simulation.steps",
        study("steps = 4", "steps = 0")),
    row("study-negative-time-step", "validate s.toml", "simulation.time_step",
        study("time_step = 40.0", "time_step = -40.0"), says=("> 0",)),
    row("study-mesh-too-small", "validate s.toml", "simulation.mesh[0]",
        study("mesh = [2, 2]", "mesh = [0, 2]")),
    row("study-mesh-strings", "validate s.toml", "simulation.mesh[0]",
        study("mesh = [2, 2]", 'mesh = ["2", "2"]')),
    row("study-delta-T-inf", "validate s.toml", "prototype.delta_T",
        study('case = "', 'delta_T = inf\ncase = "')),
    row("study-fixed-string", "validate s.toml", "fixed.L",
        study("[optimizer]", '[fixed]\nL = "0.125"\n\n[optimizer]')),
    row("study-bounds-string", "validate s.toml", "variables.h",
        study("h = [0.001, 0.01]", 'h = [0.001, "0.01"]')),
    row("study-bounds-reversed", "validate s.toml", "variables.h",
        study("h = [0.001, 0.01]", "h = [0.01, 0.001]")),
    row("study-unknown-variable", "validate s.toml", "variables.q",
        study("h = [0.001, 0.01]", "h = [0.001, 0.01]\nq = [0.0, 1.0]")),
    row("study-unknown-key", "validate s.toml", "optimizer.iteratons",
        study("iterations = 2", "iteratons = 2"), says=("did you mean 'iterations'",)),
    row("study-unknown-table", "validate s.toml", "optimiser",
        study("[optimizer]", "[optimiser]")),
    row("study-unknown-tunnel", "validate s.toml", "tunnel",
        study('name = "ideal"', 'name = "WT9"'), says=("WT9",)),
    row("study-unknown-material", "validate s.toml", "model.material",
        study('material = "ti6242"', 'material = "unobtainium"'), says=("unobtainium",)),
    row("study-unknown-aero", "validate s.toml", "simulation.aero",
        study('aero = "pt-bl"', 'aero = "pt9"')),
    row("study-missing-rom", "validate s.toml", "simulation.aero",
        study('aero = "pt-bl"', 'aero = "rom:missing.npz"'), says=("missing.npz not found",)),
    row("study-missing-case", "validate s.toml", "prototype.case",
        study(PROTOTYPE_CASE.as_posix(), "nope.toml"), says=("not found",)),
    row("study-sweep-repeated", "validate s.toml", "sweep.xi",
        study("[optimizer]", "[sweep]\nxi = [2.0, 2.0]\n\n[optimizer]")),
    row("study-unknown-equality", "validate s.toml", "constraints.equality",
        study("[optimizer]", '[constraints]\nequality = ["T_w"]\n\n[optimizer]')),
    row("run-string-int", "run s.toml", "optimizer.initial_samples",
        study("initial_samples = 4", 'initial_samples = "16"')),
    row("run-empty-study", "run s.toml", "prototype", {"s.toml": ""}),
    row("whatif-inf-weight", "whatif s.toml", "optimizer.weights[1]",
        study("seed = 3", "seed = 3\nweights = [1, inf]")),
    # -- file-level problems --------------------------------------------------------------------
    row("toml-syntax", "validate bad.toml", "bad.toml", {"bad.toml": "[panel\nkind = 3d\n"},
        says=("TOML syntax error",)),
    row("toml-empty", "validate empty.toml", "panel", {"empty.toml": ""}),
    row("toml-directory", "validate folder.toml", "folder.toml", {"folder.toml": DIR},
        says=("directory",)),
    row("toml-binary", "validate junk.toml", "junk.toml",
        {"junk.toml": bytes(range(256)) * 4}),
    row("toml-missing", "simulate nothing.toml", "nothing.toml"),
    row("validate-json-error", "validate c.toml --json", "panel.layers[0].thickness",
        case("thickness = 0.002", "thickness = -0.002")),
    # -- case files ------------------------------------------------------------------------------
    row("case-negative-thickness", "validate c.toml", "panel.layers[0].thickness",
        case("thickness = 0.002", "thickness = -0.002"), says=("(0, 1]",)),
    row("case-mach-zero", "validate c.toml", "flow.mach",
        case("mach = 6.0", "mach = 0.0"), says=("> 1",)),
    row("case-mach-string", "simulate c.toml", "flow.mach",
        case("mach = 6.0", 'mach = "6"'), says=("number",)),
    row("case-mesh-too-small", "modes c.toml", "panel.mesh[0]",
        case("mesh = [2, 2]", "mesh = [0, 2]"), says=("[1, 200]",)),
    row("case-mesh-string", "validate c.toml", "panel.mesh",
        case("mesh = [2, 2]", 'mesh = "2x2"')),
    row("case-emissivity-range", "validate c.toml", "panel.emissivity",
        case("emissivity = 0.85", "emissivity = 1.5"), says=("[0, 1]",)),
    row("case-radius-inf", "validate c.toml", "panel.radius_x",
        case("emissivity = 0.85", "emissivity = 0.85\nradius_x = inf"), says=("finite",)),
    row("case-unknown-key", "validate c.toml", "panel.layers[0].thicknes",
        case("thickness = 0.002", "thicknes = 0.002"), says=("did you mean 'thickness'",)),
    row("case-unknown-material", "flutter c.toml", "panel.layers[0].material",
        case('material = "ti6242"', 'material = "unobtainium"')),
    row("case-material-string", "validate c.toml", "materials.my_alloy.density",
        case("density = 2700.0", 'density = "2700"')),
    row("case-property-table-string", "validate c.toml", "materials.my_alloy.conductivity[0][1]",
        case("[[300.0, 130.0]", '[[300.0, "130"]')),
    row("case-two-flow-states", "validate c.toml", "flow",
        case("altitude = 25000.0", "altitude = 25000.0\np0 = 1e6\nT0 = 1000.0")),
    row("case-duration-short", "validate c.toml", "simulation.duration",
        case("duration = 2.0", "duration = 0.5")),
    row("case-unknown-aero", "simulate c.toml", "simulation.aero",
        case('aero = "pt-bl"', 'aero = "piston"')),
    row("case-missing-rom", "validate c.toml", "simulation.aero",
        case('aero = "pt-bl"', 'aero = "rom:missing.npz"'), says=("missing.npz not found",)),
    row("case-no-flow", "simulate c.toml", "flow",
        {"c.toml": CASE.split("[flow]")[0]}),
    row("case-broken-rom", "simulate c.toml", "rom:huge.npz",
        {**case('aero = "pt-bl"', 'aero = "rom:huge.npz"'), "huge.npz": Asset("huge")}),
    # -- ROM build files -----------------------------------------------------------------------
    row("rombuild-string-samples", "validate r.toml", "training.samples",
        rom_build("samples = 12", 'samples = "12"'), says=("integer", "[5, 20000]")),
    row("rombuild-grid-too-small", "rom plan r.toml --out plan.csv", "grid.n_x",
        rom_build("n_x = 9", "n_x = 2"), says=("[3, 1000]",)),
    row("rombuild-unknown-key", "validate r.toml", "grid.nx",
        rom_build("n_x = 9", "nx = 9"), says=("did you mean 'n_x'",)),
    row("rombuild-reversed-range", "validate r.toml", "modes[0].range",
        rom_build("range = [-6.0, 6.0]", "range = [6.0, -6.0]")),
    row("rombuild-mach-subsonic", "rom build r.toml --out rom.npz", "reference.mach",
        rom_build("mach = 6.0", "mach = 0.5")),
    row("rombuild-nan-range", "validate r.toml", "wall_temperature.range[1]",
        rom_build("range = [200.0, 900.0]", "range = [200.0, nan]")),
    row("rombuild-missing-snapshots", "validate r.toml", "source.path",
        rom_build("[training]", '[source]\nkind = "snapshots"\npath = "snaps.npz"\n\n[training]'),
        says=("not found",)),
    row("rombuild-nan-snapshots", "validate r.toml", "source.path",
        {**rom_build("[training]",
                     '[source]\nkind = "snapshots"\npath = "snaps.npz"\n\n[training]'),
         "snaps.npz": Asset("nan_snapshots")}, says=("non-finite",)),
    row("rombuild-huge-snapshots", "rom build r.toml --out rom.npz", "source.path",
        {**rom_build("[training]",
                     '[source]\nkind = "snapshots"\npath = "snaps.npz"\n\n[training]'),
         "snaps.npz": Asset("huge")}, says=("exceeds the cap",)),
    # -- ROM archives --------------------------------------------------------------------------
    row("rom-huge-header", "rom check huge.npz --samples 2", "rom:huge.npz",
        {"huge.npz": Asset("huge")}, says=("'geometry'", "exceeds the cap")),
    row("rom-nan-geometry", "rom check nan.npz --samples 2 --json", "rom:nan.npz",
        {"nan.npz": Asset("nan")}, says=("'geometry'", "non-finite")),
    row("rom-not-zip", "rom check text.npz --samples 2", "rom:text.npz",
        {"text.npz": "not a rom"}, says=("not a zip",)),
    row("rom-missing-members", "rom check few.npz --samples 2", "rom:few.npz",
        {"few.npz": Asset("few")}, says=("missing member",)),
    row("rom-foreign-member", "rom check extra.npz --samples 2", "rom:extra.npz",
        {"extra.npz": Asset("extra")}, says=("'notes.txt'",)),
    row("rom-object-member", "rom check pickle.npz --samples 2", "rom:pickle.npz",
        {"pickle.npz": Asset("pickle")}, says=("'kind'", "object")),
    row("rom-directory", "rom check d.npz --samples 2", "rom:d.npz", {"d.npz": DIR},
        says=("directory",)),
    # -- command-line numbers ----------------------------------------------------------------------
    row("condition-mach-subsonic", "condition --mach 0.5 --altitude 1000", "--mach"),
    row("condition-altitude-nan", "condition --mach 6 --altitude nan", "--altitude"),
    row("condition-T0-negative", "condition --mach 6 --p0 1e6 --T0 -5", "--T0"),
    row("condition-mach-text", "condition --mach six --altitude 1000", "--mach"),
    row("modes-count-zero", "modes c.toml --count 0", "--count", {"c.toml": CASE}),
    row("modes-delta-T-nan", "modes c.toml --delta-T nan", "--delta-T", {"c.toml": CASE}),
    row("static-pressure-inf", "static c.toml --pressure inf", "--pressure", {"c.toml": CASE}),
    row("heat-duration-negative", "heat c.toml --flux 1e5 --duration -1 --time-step 1",
        "--duration", {"c.toml": CASE}),
    row("heat-time-step-nan", "heat c.toml --flux 1e5 --duration 10 --time-step nan",
        "--time-step", {"c.toml": CASE}),
    row("heat-too-many-steps", "heat c.toml --flux 1e5 --duration 1e4 --time-step 1e-9",
        "--time-step", {"c.toml": CASE}),
    row("flutter-mach-nan", "flutter c.toml --mach nan", "--mach", {"c.toml": CASE}),
    row("flutter-ratio-inf", "flutter c.toml --delta-T-ratio inf", "--delta-T-ratio",
        {"c.toml": CASE}),
    row("flutter-step-zero", "flutter c.toml --step 0", "--step", {"c.toml": CASE}),
    row("flutter-aero-unknown", "flutter c.toml --aero pt3", "--aero", {"c.toml": CASE}),
    row("flutter-rom-missing", "flutter c.toml --aero rom:none.npz", "--aero",
        {"c.toml": CASE}),
    row("flutter-step-tiny", "flutter c.toml --step 1e-12", "--step", {"c.toml": CASE}),
    row("flutter-lco-periods-inf", "flutter c.toml --time-domain --lco-periods inf",
        "--lco-periods", {"c.toml": CASE}),
    row("whatif-set-text", "whatif s.toml --set p0=high", "--set", {"s.toml": STUDY}),
    row("whatif-set-unknown", "whatif s.toml --set q=1", "--set", {"s.toml": STUDY}),
    row("whatif-sweep-one-point", "whatif s.toml --sweep h=0.002:0.01:1", "--sweep",
        {"s.toml": STUDY}),
    row("whatif-sweep-nan", "whatif s.toml --sweep h=nan:0.01:3", "--sweep", {"s.toml": STUDY}),
    row("laws-predict-small", "laws runs --predict 0.5", "--predict"),
    row("laws-missing-run", "laws runs", "runs"),
    row("rom-check-samples-zero", "rom check rom.npz --samples 0", "--samples",
        {"rom.npz": Asset("rom")}),
    row("rom-check-scale-nan", "rom check rom.npz --samples 2 --scale nan", "--scale",
        {"rom.npz": Asset("rom")}),
    row("rom-check-mach-nan", "rom check rom.npz --samples 2 --mach nan", "--mach",
        {"rom.npz": Asset("rom")}),
    row("rom-check-altitude-high", "rom check rom.npz --samples 2 --altitude 1e9",
        "--altitude", {"rom.npz": Asset("rom")}),
    row("rom-check-seed-negative", "rom check rom.npz --samples 2 --seed -1", "--seed",
        {"rom.npz": Asset("rom")}),
    row("rom-build-samples-zero", "rom build r.toml --out rom.npz --samples 0", "--samples",
        {"r.toml": ROM_BUILD}),
    row("rom-build-samples-few", "rom build r.toml --out rom.npz --samples 2", "--samples",
        {"r.toml": ROM_BUILD}),
    # a missing folder of --out is made (as for `hypate run --out runs/...`); a file is not
    row("rom-build-out-under-a-file", "rom build r.toml --out notes/rom.npz", "--out",
        {"r.toml": ROM_BUILD, "notes": "mine"}, says=("is not a directory",)),
    row("rom-plan-groups-zero", "rom plan r.toml --out plan.csv --groups 0", "--groups",
        {"r.toml": ROM_BUILD}),
    row("bench-rom-counts-zero", "bench rom --counts 0", "--counts"),
    row("bench-ate-duration-nan", "bench ate --duration nan", "--duration"),
    row("bench-ate-repeat-zero", "bench ate --repeat 0", "--repeat"),
    # -- output options that cannot be written: refused before the work starts -----------------
    row("simulate-out-is-file", "simulate c.toml --out afile", "--out",
        {"c.toml": CASE, "afile": ""}),
    row("rom-build-out-is-dir", "rom build r.toml --out outdir", "--out",
        {"r.toml": ROM_BUILD, "outdir": DIR}),
    row("rom-plan-out-is-dir", "rom plan r.toml --out outdir", "--out",
        {"r.toml": ROM_BUILD, "outdir": DIR}),
    row("rom-plan-out-missing-dir", "rom plan r.toml --out no/plan.csv", "--out",
        {"r.toml": ROM_BUILD}),
    row("whatif-sweep-out-is-file", "whatif s.toml --sweep h=0.002:0.01:2 --out afile", "--out",
        {"s.toml": STUDY, "afile": ""}),
    row("init-exists", "init e.toml", "PATH", {"e.toml": ""}),
    row("report-missing-dir", "report nothing", "DIR"),
]

#: Rows run again through the installed console script.
CONSOLE_ROWS = ["study-string-int", "rom-huge-header", "rom-nan-geometry",
                "condition-altitude-nan"]


# -- archives -----------------------------------------------------------------------------------
def _npz_bytes(arrays: dict[str, np.ndarray], extra: dict[str, bytes] | None = None) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    if extra:
        with zipfile.ZipFile(buf, "a") as archive:
            for name, data in extra.items():
                archive.writestr(name, data)
    return buf.getvalue()


def _huge_header(arrays: dict[str, np.ndarray]) -> bytes:
    """The archive with its ``geometry`` member declaring 2**40 float64 elements."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (2**40,)})
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as archive:
        for name, value in arrays.items():
            member = io.BytesIO()
            np.save(member, value)
            archive.writestr(f"{name}.npy", member.getvalue())
        archive.writestr("geometry.npy", header.getvalue() + b"\0" * 64)
    return buf.getvalue()


@pytest.fixture(scope="module")
def assets(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """A small valid ROM file and its malformed variants, as bytes."""
    folder = tmp_path_factory.mktemp("archives")
    rom = build_rom_from_config(parse_rom_config(tomllib.loads(ROM_BUILD)))
    save_rom(rom, folder / "rom.npz")
    # NaN geometry with a matching digest: what a buggy writer (not a bit flip) produces
    nan_rom = RomFluid(dataclasses.replace(rom.geometry, leading_edge_length=math.nan),
                       rom.reference, rom.pressure_model, rom.heat_model, rom.kind,
                       source=rom.source)
    save_rom(nan_rom, folder / "nan.npz")
    with np.load(folder / "rom.npz", allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    rest = {k: v for k, v in arrays.items() if k != "geometry"}
    return {"rom": (folder / "rom.npz").read_bytes(), "nan": (folder / "nan.npz").read_bytes(),
            "huge": _huge_header(rest),
            "few": _npz_bytes({"format_version": arrays["format_version"]}),
            "extra": _npz_bytes(arrays, {"notes.txt": b"hello"}),
            "pickle": _npz_bytes(dict(arrays, kind=np.array(["scaled"], dtype=object))),
            "nan_snapshots": _npz_bytes({"inputs": np.array([[0.0, np.nan]]),
                                         "pressure": np.zeros((1, 9)),
                                         "heat_flux": np.zeros((1, 9))})}


# -- the checks ---------------------------------------------------------------------------------
def _write(folder: Path, files: dict[str, object], assets: dict[str, bytes]) -> None:
    for name, content in files.items():
        path = folder / name
        if content is DIR:
            path.mkdir()
        elif isinstance(content, Asset):
            path.write_bytes(assets[content.name])
        elif isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(str(content))


def _listing(folder: Path) -> dict[str, tuple[int, int]]:
    """Every file and directory below ``folder`` with its mtime and size."""
    return {str(p.relative_to(folder)): (p.stat().st_mtime_ns, p.stat().st_size)
            for p in folder.rglob("*")}


def _assert_one_error_line(code: int | str | None, out: str, err: str, r: Row) -> None:
    assert code == 2, f"exit code {code}; stderr: {err}"
    assert "Traceback" not in out + err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].strip(), f"stderr is not one line: {err!r}"
    assert lines[0].startswith("hypate: error: "), lines[0]
    assert r.key in lines[0], f"{r.key!r} not named in {lines[0]!r}"
    assert "InputError" not in lines[0], "an input error wrapped in another"
    for text in r.says:
        assert text in lines[0], f"{text!r} not in {lines[0]!r}"


BY_ID = {r.id: r for r in ROWS}


def test_table_is_large_and_unique() -> None:
    assert len(ROWS) >= 40 and len(BY_ID) == len(ROWS)
    assert set(CONSOLE_ROWS) <= set(BY_ID)


def test_base_files_are_valid(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                              capsys: pytest.CaptureFixture) -> None:
    """The rows' starting points validate, so each row fails for its own injected fault."""
    monkeypatch.chdir(tmp_path)
    for name, text in (("c.toml", CASE), ("s.toml", STUDY), ("r.toml", ROM_BUILD)):
        (tmp_path / name).write_text(text)
        assert main(["validate", name]) == 0, capsys.readouterr().err


def test_valid_rom_archive_checks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                  capsys: pytest.CaptureFixture,
                                  assets: dict[str, bytes]) -> None:
    """The archive the ROM rows start from is accepted by the commands they run."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rom.npz").write_bytes(assets["rom"])
    assert main(["rom", "check", "rom.npz", "--samples", "2", "--json"]) == 0, \
        capsys.readouterr().err


@pytest.mark.parametrize("r", ROWS, ids=[r.id for r in ROWS])
def test_malformed_input(r: Row, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                         capsys: pytest.CaptureFixture, assets: dict[str, bytes]) -> None:
    _write(tmp_path, r.files, assets)
    monkeypatch.chdir(tmp_path)
    before = _listing(tmp_path)
    capsys.readouterr()
    try:
        code: int | str | None = main(list(r.argv))
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    out, err = capsys.readouterr()
    _assert_one_error_line(code, out, err, r)
    assert _listing(tmp_path) == before, "the command wrote into its working directory"


@pytest.mark.parametrize("name", CONSOLE_ROWS)
def test_console_script(name: str, tmp_path: Path, assets: dict[str, bytes]) -> None:
    r = BY_ID[name]
    _write(tmp_path, r.files, assets)
    before = _listing(tmp_path)
    exe = shutil.which("hypate")
    cmd = [exe] if exe else [sys.executable, "-m", "hypate.scaling.cli.main"]
    res = subprocess.run([*cmd, *r.argv], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120)
    _assert_one_error_line(res.returncode, res.stdout, res.stderr, r)
    assert _listing(tmp_path) == before

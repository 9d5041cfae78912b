"""Panel/case configuration files: valid files build, malformed files name their key."""
from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypate.scaling.cli.main import main
from hypate.solvers.config import load_case, load_panel, settings_from_config

VALID = """
[panel]
kind = "3d"
length = 1.0
width = 0.5
boundary = "clamped"
leading_edge_length = 0.5
flow_angle = 15.0
mesh = [6, 4]
initial_temperature = 300.0
emissivity = 0.85
damping = [0.01, 0.0]

[[panel.layers]]
material = "my_alloy"
thickness = 0.001
angle = 0.0
sublayers = 2

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
heating = "eckert"
time_step = 0.2
duration = 160.0
"""


def _write(tmp_path: Path, text: str, name: str = "case.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_valid_case_builds(tmp_path: Path) -> None:
    case = load_case(_write(tmp_path, VALID))
    p = case.panel
    assert p.thickness == pytest.approx(0.003)
    assert p.flow_angle == pytest.approx(math.radians(15.0))
    assert p.mesh == (6, 4) and p.boundary == "clamped"
    assert p.layers[0].material.k1(450.0) == pytest.approx(140.0)  # user table, interpolated
    # areal mass = sum rho_i h_i
    assert p.mass_per_area() == pytest.approx(2700.0 * 0.001 + 4540.0 * 0.002)
    assert case.flow is not None and case.flow.pressure == pytest.approx(2549.2, rel=1e-3)
    assert case.simulation is not None and case.simulation.aero == "pt-bl"


def test_shipped_cases_validate(repo_root: Path) -> None:
    for path in sorted([*(repo_root / "studies" / "cases").glob("*.toml"),
                        *(repo_root / "scaling" / "data" / "cases").glob("*.toml")]):
        panel = load_panel(path)
        assert panel.thickness > 0


def test_two_d_strip_has_one_element_across(tmp_path: Path) -> None:
    text = VALID.replace('kind = "3d"', 'kind = "2d"').replace("mesh = [6, 4]", "mesh = [10]")
    assert load_panel(_write(tmp_path, text)).mesh == (10, 1)


# Each malformed variant and the key its error must name (acceptance: >= 10 kinds).
MALFORMED = [
    ("unknown key", VALID.replace("emissivity = 0.85", "emissivity = 0.85\ncolour = 'red'"),
     "panel.colour"),
    ("negative thickness", VALID.replace("thickness = 0.002", "thickness = -0.002"),
     "panel.layers[1].thickness"),
    ("emissivity 1.5", VALID.replace("emissivity = 0.85", "emissivity = 1.5"), "panel.emissivity"),
    ("mesh 0", VALID.replace("mesh = [6, 4]", "mesh = [0, 4]"), "panel.mesh[0]"),
    ("altitude and p0", VALID.replace("altitude = 25000.0", "altitude = 25000.0\np0 = 1e6\nT0 = 1500.0"),
     "flow"),
    ("Mach 0.5", VALID.replace("mach = 6.0", "mach = 0.5"), "flow.mach"),
    ("missing layers", VALID.split("[[panel.layers]]")[0] + "[flow]\nmach = 6.0\naltitude = 25000.0\n",
     "panel.layers"),
    ("unknown material", VALID.replace('material = "ti6242"', 'material = "unobtainium"'),
     "panel.layers[1].material"),
    ("bad boundary", VALID.replace('boundary = "clamped"', 'boundary = "glued"'), "panel.boundary"),
    ("bad scheme", VALID.replace('scheme = "tc"', 'scheme = "rk4"'), "simulation.scheme"),
    ("bad aero", VALID.replace('aero = "pt-bl"', 'aero = "cfd"'), "simulation.aero"),
    ("duration < step", VALID.replace("duration = 160.0", "duration = 0.1"), "simulation.duration"),
    ("heat flux 1e9", VALID.replace("duration = 160.0", "duration = 160.0\nexternal_heat_flux = 1e9"),
     "simulation.external_heat_flux"),
    ("negative modulus", VALID.replace("youngs_modulus = 70.0e9", "youngs_modulus = -70.0e9"),
     "materials.my_alloy.youngs_modulus"),
    ("reversed table", VALID.replace("[[300.0, 130.0], [600.0, 150.0]]", "[[600.0, 130.0], [300.0, 150.0]]"),
     "materials.my_alloy.conductivity"),
    ("incomplete material", VALID.replace("specific_heat = 900.0\n", ""), "materials.my_alloy"),
    ("altitude out of table", VALID.replace("altitude = 25000.0", "altitude = -7000.0"),
     "flow.altitude"),
    ("p0 without T0", VALID.replace("altitude = 25000.0", "p0 = 2.0e6"), "flow"),
    ("string thickness", VALID.replace("thickness = 0.001", 'thickness = "thin"'),
     "panel.layers[0].thickness"),
    ("toml syntax", VALID.replace("[flow]", "[flow"), "case.toml"),
    ("2d strip wide mesh", VALID.replace('kind = "3d"', 'kind = "2d"'), "panel.mesh"),
    ("flow angle 120", VALID.replace("flow_angle = 15.0", "flow_angle = 120.0"), "panel.flow_angle"),
    ("sublayers 0", VALID.replace("sublayers = 2", "sublayers = 0"), "panel.layers[0].sublayers"),
]


@pytest.mark.parametrize("label, text, key", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_validate_malformed_exits_2_naming_key(tmp_path: Path, capsys: pytest.CaptureFixture,
                                               label: str, text: str, key: str) -> None:
    path = _write(tmp_path, text)
    code = main(["validate", str(path)])
    err = capsys.readouterr().err
    assert code == 2, label
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("hypate: error: "), err
    assert key in lines[0], (label, lines[0])
    assert "Traceback" not in err


def test_validate_prints_summary(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["validate", str(_write(tmp_path, VALID))]) == 0
    out = capsys.readouterr().out
    assert "total thickness: 3 mm" in out and "mass per area" in out and "M = 6" in out


def test_missing_file(capsys: pytest.CaptureFixture, tmp_path: Path) -> None:
    assert main(["validate", str(tmp_path / "nope.toml")]) == 2
    assert "file not found" in capsys.readouterr().err


def _schemas() -> list[type]:
    """Every pydantic model of the input-file schemas (case, study, ROM build)."""
    from hypate.scaling.workflow.vocabulary import study_file
    from hypate.solvers import config
    from hypate.solvers.aero.rom import config as rom_config
    from pydantic import BaseModel

    return [obj for module in (config, study_file, rom_config) for obj in vars(module).values()
            if isinstance(obj, type) and issubclass(obj, BaseModel)
            and obj.__module__ == module.__name__]


def test_every_schema_is_strict_and_takes_toml_lists() -> None:
    """Strict and finite by the one base class; no tuple field, which strict validation
    would take only as a Python tuple (TOML gives lists)."""
    from hypate.solvers.config import InputModel

    schemas = _schemas()
    assert len(schemas) >= 20
    for model in schemas:
        assert model is InputModel or issubclass(model, InputModel), model
        assert model.model_config["strict"] and not model.model_config["allow_inf_nan"]
        for name, field in model.model_fields.items():
            assert "tuple" not in repr(field.annotation), f"{model.__name__}.{name}"


@pytest.mark.parametrize("key, value, field, says", [
    ("length", '"1"', "panel.length", "must be a finite number in (0, 100]; got '1' (a string)"),
    ("length", "true", "panel.length", "got True (a boolean)"),
    ("length", "nan", "panel.length", "must be a finite number in (0, 100]; got nan"),
    ("length", "1", None, None),  # an integer is a number
    ("mesh", "[6.0, 4]", "panel.mesh[0]", "must be an integer in [1, 200]; got 6.0"),
    ("emissivity", "-inf", "panel.emissivity", "must be a finite number in [0, 1]"),
])
def test_values_are_taken_as_written(tmp_path: Path, key: str, value: str, field: str | None,
                                     says: str | None) -> None:
    from hypate.solvers.errors import InputError

    lines = [f"{key} = {value}" if line.split(" =")[0] == key else line
             for line in VALID.splitlines()]
    assert f"{key} = {value}" in lines  # the key is in the base file
    path = tmp_path / "case.toml"
    path.write_text("\n".join(lines))
    if field is None:
        assert load_case(path).panel.length == 1.0
        return
    with pytest.raises(InputError) as info:
        load_case(path)
    assert (info.value.field, says in info.value.message) == (field, True), info.value


def test_a_case_and_a_study_share_one_simulation_schema():
    # issue 42: the keys both files offer are declared once (SimulationKeys): same defaults
    # (SimulationSettings'), same limits, the same refusal; a case file takes a study's
    # initial_deflection, a study the case files' mesh limit
    from hypate.scaling.workflow.vocabulary.study import SimulationSection
    from hypate.solvers.config import MAX_MESH, SimulationConfig, SimulationKeys
    from hypate.solvers.settings import DEFAULTS
    from pydantic import ValidationError

    shared = set(SimulationKeys.model_fields)
    assert {"aero", "time_step", "lsa_modes", "rho_bar", "initial_deflection"} <= shared
    for schema in (SimulationConfig, SimulationSection):
        assert shared <= set(schema.model_fields)
        for name in shared:
            field, base = schema.model_fields[name], SimulationKeys.model_fields[name]
            assert (field.default, field.metadata) == (base.default, base.metadata), name
            assert field.default == getattr(DEFAULTS, name)
        for bad in ({"lsa_modes": 51}, {"rho_bar": 1.5}, {"initial_deflection": 11.0}):
            with pytest.raises(ValidationError):
                schema(**bad)
    assert settings_from_config(SimulationConfig(initial_deflection=0.5)).initial_deflection == 0.5
    assert SimulationSection(mesh=[MAX_MESH, 2]).mesh == [MAX_MESH, 2]
    with pytest.raises(ValidationError):
        SimulationSection(mesh=[MAX_MESH + 1, 2])

"""Fluid ROM (solvers/aero/rom/): POD, POD-kriging, corrections, Jacobians, persistence,
external snapshots, sample planning. Acceptance sizes (Sec. 7.1) are the ``slow`` tests."""
from __future__ import annotations

import csv
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from hypate.solvers.aero.base import SurfacePoints, SurfaceState, dense
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.aero.rom.build import (
    build_rom_from_config,
    check_rom,
    geometry_from_config,
    nrmse,
)
from hypate.solvers.aero.rom.config import load_rom_config, parse_rom_config
from hypate.solvers.aero.rom.geometry import RomGeometry, eq76_wall_temperature
from hypate.solvers.aero.rom.io import FORMAT_VERSION, load_rom, save_rom
from hypate.solvers.aero.rom.model import RomFluid
from hypate.solvers.aero.rom.plan import olh_plan, smart_order, write_plan_csv
from hypate.solvers.aero.rom.pod import PodBasis, PodKriging
from hypate.solvers.aero.rom.snapshots import generate_samples, read_snapshots
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition

REPO = Path(__file__).resolve().parents[2]
STUDY = REPO / "studies" / "rom" / "rom_2d_panel.toml"

SMALL = {
    "panel": {"kind": "2d", "length": 1.0, "leading_edge_length": 1.0, "thickness": 0.0025},
    "grid": {"n_x": 33},
    "reference": {"mach": 6.0, "altitude": 25000.0},
    "modes": [{"m": 1, "range": [-6.0, 6.0]}, {"m": 2, "range": [-2.0, 2.0]},
              {"m": 3, "range": [-2.0, 2.0]}],
    "wall_temperature": {"range": [200.0, 900.0]},
    "training": {"samples": 50, "seed": 3, "restarts": 0, "optimized_modes": 2},
}


@pytest.fixture(scope="module")
def small_rom() -> RomFluid:
    return build_rom_from_config(parse_rom_config(SMALL))


@pytest.fixture(scope="module")
def small_rom_file(small_rom: RomFluid, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rom") / "small.npz"
    save_rom(small_rom, path)
    return path


def _state(geom: RomGeometry, scale: float, amplitudes, nonuniform: bool = True,
           velocity: float = 0.0) -> tuple[SurfacePoints, SurfaceState]:
    pts = geom.points(scale)
    w, ws = geom.deformation(np.asarray(amplitudes, float)[None, :], scale)
    xr = pts.x * scale
    T = (450.0 + 150.0 * xr + 60.0 * np.sin(2 * np.pi * xr)) if nonuniform else np.full(pts.n,
                                                                                        550.0)
    return pts, SurfaceState(w[0], ws[0], velocity * np.sin(np.pi * xr), T)


# -- POD and POD-kriging ------------------------------------------------------------------
def test_pod_energy_criterion_picks_fewest_modes() -> None:
    rng = np.random.default_rng(0)
    basis = np.linalg.qr(rng.normal(size=(80, 6)))[0]
    coef = rng.normal(size=(200, 6)) * np.array([100, 30, 10, 1, 0.1, 0.01])
    Y = 5.0 + coef @ basis.T
    pod = PodBasis(0.005).fit(Y)
    s2 = pod.singular_values_**2
    tail = np.sqrt(1 - np.cumsum(s2) / s2.sum())
    # Eq. (A.14): the chosen N_p is the first with eps_POD < 0.5 %, N_p - 1 is not
    assert pod.error_ < 0.005 and tail[pod.modes_.shape[1] - 2] >= 0.005
    # reconstruction error equals the discarded energy (Eq. A.14 identity, 1e-10)
    E = Y - pod.reconstruct(pod.project(Y))
    Yc = Y - Y.mean(0)
    assert np.linalg.norm(E) / np.linalg.norm(Yc) == pytest.approx(pod.error_, rel=1e-10)


def test_pod_kriging_interpolates_and_jacobian_matches_fd() -> None:
    rng = np.random.default_rng(1)
    D = rng.uniform(-1, 1, size=(40, 3))
    x = np.linspace(0, 1, 20)
    Y = np.sin(np.outer(D[:, 0], 3 * x)) + np.outer(D[:, 1] ** 2, x) + 0.3 * D[:, 2:3]
    pk = PodKriging(1e-6, trend="linear", n_restarts=0, rng=0).fit(D, Y)
    # a GP interpolates its data (invariant): POD truncation 1e-6 and nugget 1e-8 bound it
    rel = np.abs(pk.predict(D) - Y).max() / np.abs(Y).max()
    assert rel < 1e-4
    d0 = np.array([0.1, -0.3, 0.4])
    _, J = pk.predict_jacobian(d0)
    fd = _fd4(lambda d: pk.predict(d[None])[0], d0, 1e-3)
    assert np.linalg.norm(J - fd) / np.linalg.norm(fd) < 1e-5  # Eq. (2.59) vs central FD


# -- the ROM fluid model --------------------------------------------------------------------
def test_small_rom_accuracy_at_reference(small_rom: RomFluid) -> None:
    res = check_rom(small_rom, 30, rng=11)
    # 50 samples, 4 inputs: well converged already (the 200-sample acceptance is slow-marked)
    assert res["pressure_nrmse"] < 0.01 and res["heat_flux_nrmse"] < 0.02, res


def test_corrections_are_identity_at_reference(small_rom: RomFluid) -> None:
    g = small_rom.geometry
    pts, st = _state(g, 1.0, [2.0, -1.0, 0.5], nonuniform=False)
    d = small_rom.inputs(pts, st, small_rom.reference)
    p_pk = small_rom.pressure_model.predict(d[None])[0]
    q_pk = small_rom.heat_model.predict(d[None])[0]
    for corr in ("bl", "pt"):
        loads = small_rom.with_options(correction=corr).evaluate(pts, st, small_rom.reference)
        np.testing.assert_allclose(loads.pressure, p_pk, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(loads.heat_flux, q_pk, rtol=1e-10, atol=1e-9)


def _fd4(f, x: np.ndarray, h: float) -> np.ndarray:
    """Fourth-order central differences, column by column."""
    cols = []
    for e in np.eye(x.size):
        cols.append((8 * (f(x + h * e) - f(x - h * e)) - (f(x + 2 * h * e) - f(x - 2 * h * e)))
                    / (12 * h))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("correction, edge, scale, mach, altitude", [
    ("bl", "rom", 2.0, 7.0, 30000.0), ("pt", "rom", 1.0, 5.0, 20000.0),
    ("bl", "pt", 4.0, 6.0, 25000.0)])
def test_rom_jacobians_match_central_differences(small_rom: RomFluid, correction: str,
                                                 edge: str, scale: float, mach: float,
                                                 altitude: float) -> None:
    fluid = small_rom.with_options(correction=correction, edge_pressure=edge)
    flow = FlowCondition.from_altitude(mach, altitude)
    pts, st = _state(small_rom.geometry, scale, [3.0, -1.0, 0.5], velocity=0.3)
    J = fluid.evaluate(pts, st, flow, jacobians=True).jacobians
    fields = {"w": "displacement", "ws": "slope", "wdot": "velocity", "Tw": "wall_temperature"}
    steps = {"w": 1e-5 / scale, "ws": 1e-5, "wdot": 1e-3, "Tw": 1.0}
    for key, name in fields.items():
        def f(v, name=name):
            kw = {k: getattr(st, k) for k in fields.values()}
            kw[name] = v
            loads = fluid.evaluate(pts, SurfaceState(**kw), flow)
            return np.r_[loads.pressure, loads.heat_flux]

        fd = _fd4(f, getattr(st, name), steps[key])
        an = np.vstack([dense(J["dp_d" + key]), dense(J["dq_d" + key])])
        for part in (slice(0, pts.n), slice(pts.n, 2 * pts.n)):
            ref = np.linalg.norm(fd[part])
            if ref == 0.0:
                assert np.linalg.norm(an[part]) == 0.0, key
                continue
            # acceptance: 1e-5 relative (Frobenius) against central differences
            assert np.linalg.norm(an[part] - fd[part]) / ref < 1e-5, (key, part)


def test_rom_on_another_grid_and_projection(small_rom: RomFluid) -> None:
    pts = SurfacePoints.grid(0.5, 0.5, 0.5, 21, 1)  # xi = 2, coarser grid: interpolated
    xr = pts.x * 2.0
    w = (0.0025 / 2.0) * (2.0 * np.sin(np.pi * xr) - 1.0 * np.sin(2 * np.pi * xr))
    st = SurfaceState(w, pts.streamwise_derivative @ w, 0 * w, np.full(pts.n, 500.0))
    d = small_rom.inputs(pts, st, small_rom.reference)
    # the projection recovers the modal amplitudes of the reference-size deformation
    np.testing.assert_allclose(d, [2.0, -1.0, 0.0, 500.0], atol=1e-10)
    loads = small_rom.evaluate(pts, st, FlowCondition.from_altitude(6.0, 25000.0))
    assert loads.pressure.shape == (21,) and np.all(np.isfinite(loads.heat_flux))


def test_mismatched_panel_is_refused(small_rom: RomFluid) -> None:
    flow = small_rom.reference
    bad = SurfacePoints.grid(1.0, 1.0, 0.5, 33, 1)  # a/L_le = 2 instead of 1
    with pytest.raises(InputError, match="panel mismatch"):
        small_rom.evaluate(bad, SurfaceState.flat(bad.n, 500.0), flow)
    wide = SurfacePoints.grid(1.0, 1.0, 1.0, 33, 4)
    with pytest.raises(InputError, match="2D panel"):
        small_rom.evaluate(wide, SurfaceState.flat(wide.n, 500.0), flow)


def test_conventional_rom_builds_and_predicts() -> None:
    cfg = dict(SMALL, training=dict(SMALL["training"], samples=40),
               conventional={"mach": [5.0, 7.0], "altitude": [20000.0, 30000.0]})
    rom = build_rom_from_config(parse_rom_config(cfg))
    assert rom.kind == "conventional" and rom.n_inputs == 7
    pts, st = _state(rom.geometry, 1.0, [1.0, 0.5, 0.0], nonuniform=False)
    flow = FlowCondition.from_altitude(6.5, 22000.0)
    loads = rom.evaluate(pts, st, flow, jacobians=True)
    p_src, _ = generate_samples(rom.geometry, [[1.0, 0.5, 0.0]], [550.0], flow)
    # 40 samples over 7 inputs: a coarse comparison model, within 5 % of the range
    assert nrmse(p_src, loads.pressure[None], pts.weights)[0] < 0.05
    with pytest.raises(InputError, match="no geometric scaling"):
        rom.evaluate(*_state(rom.geometry, 2.0, [1.0, 0.0, 0.0]), flow)


# -- persistence -----------------------------------------------------------------------------
def test_save_load_roundtrip_and_fluid_model_factory(small_rom: RomFluid,
                                                     small_rom_file: Path) -> None:
    loaded = make_fluid_model(f"rom:{small_rom_file}")
    assert isinstance(loaded, RomFluid)
    with np.load(small_rom_file, allow_pickle=False) as npz:  # no object arrays anywhere
        assert int(npz["format_version"]) == FORMAT_VERSION
        assert npz["input_bounds"].shape == (4, 2)
    pts, st = _state(small_rom.geometry, 2.0, [1.0, 0.3, -0.2])
    flow = FlowCondition.from_altitude(7.0, 30000.0)
    a = small_rom.evaluate(pts, st, flow)
    b = loaded.evaluate(pts, st, flow)
    np.testing.assert_allclose(b.pressure, a.pressure, rtol=1e-9)
    np.testing.assert_allclose(b.heat_flux, a.heat_flux, rtol=1e-9)


def test_corrupted_or_foreign_files_are_refused(small_rom_file: Path, tmp_path: Path) -> None:
    raw = small_rom_file.read_bytes()
    trunc = tmp_path / "trunc.npz"
    trunc.write_bytes(raw[: len(raw) // 2])
    flipped = tmp_path / "flip.npz"
    flipped.write_bytes(raw[:200] + bytes([raw[200] ^ 0xFF]) + raw[201:])
    text = tmp_path / "text.npz"
    text.write_text("not a rom")
    with np.load(small_rom_file, allow_pickle=False) as npz:
        data = {k: npz[k] for k in npz.files}
    tampered = tmp_path / "tampered.npz"
    np.savez(tampered, **dict(data, pressure_mean=data["pressure_mean"] * 1.01))
    version = tmp_path / "version.npz"
    np.savez(version, **dict(data, format_version=np.array(99)))
    missing = tmp_path / "missing.npz"
    np.savez(missing, **{k: v for k, v in data.items() if k != "heat_flux_modes"})
    for path in (trunc, flipped, text, tampered, version, missing, tmp_path / "none.npz"):
        with pytest.raises(InputError):
            load_rom(path)


# -- external snapshots ------------------------------------------------------------------------
def test_external_snapshots_npz_and_csv(tmp_path: Path) -> None:
    cfg = parse_rom_config(SMALL)
    geom = geometry_from_config(cfg)
    D = olh_plan(np.array([[-6, 6], [-2, 2], [-2, 2], [200, 900]], float), 20, 5)
    P, Q = generate_samples(geom, D[:, :3], D[:, 3], cfg.reference.flow())
    pts = geom.points()
    np.savez(tmp_path / "snap.npz", inputs=D, pressure=P, heat_flux=Q, x=pts.x, y=pts.y)
    with open(tmp_path / "snap.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["sample", "a1", "a2", "a3", "T_w", "x", "y", "pressure", "heat_flux"])
        for i in range(D.shape[0]):
            for k in reversed(range(pts.n)):  # any row order
                w.writerow([i, *D[i], pts.x[k], pts.y[k], P[i, k], Q[i, k]])
    for name in ("snap.npz", "snap.csv"):
        d2, p2, q2 = read_snapshots(tmp_path / name, geom)
        np.testing.assert_allclose(d2, D, rtol=1e-12)
        np.testing.assert_allclose(p2, P, rtol=1e-12)
        np.testing.assert_allclose(q2, Q, rtol=1e-12)
    data = dict(SMALL, source={"kind": "snapshots", "path": "snap.csv"})
    rom = build_rom_from_config(parse_rom_config(data), base_dir=tmp_path)
    assert rom.source["kind"] == "snapshots"
    with pytest.raises(InputError, match="external snapshots"):
        check_rom(rom, 3)
    np.savez(tmp_path / "bad.npz", inputs=D[:, :2], pressure=P, heat_flux=Q)
    with pytest.raises(InputError, match="inputs must have shape"):
        read_snapshots(tmp_path / "bad.npz", geom)
    np.savez(tmp_path / "badx.npz", inputs=D, pressure=P, heat_flux=Q, x=pts.x * 1.1)
    with pytest.raises(InputError, match="grid"):
        read_snapshots(tmp_path / "badx.npz", geom)


# -- sample planning ------------------------------------------------------------------------
def test_parallel_generation_equals_serial() -> None:
    geom = geometry_from_config(parse_rom_config(SMALL))
    A = np.random.default_rng(0).uniform(-1, 1, (23, 3))
    T = np.linspace(300, 800, 23)
    flow = FlowCondition.from_altitude(6.0, 25000.0)
    serial = generate_samples(geom, A, T, flow)
    with ThreadPoolExecutor(2) as pool:
        par = generate_samples(geom, A, T, flow, executor=pool, chunk_size=5)
    # equal up to the batch-dependent stopping of the Prandtl-Meyer Newton iteration
    np.testing.assert_allclose(par[0], serial[0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(par[1], serial[1], rtol=1e-9)


@pytest.mark.parametrize("groups", [1, 2])
def test_smart_ordering_halves_restart_distance(groups: int, tmp_path: Path) -> None:
    cfg, _ = load_rom_config(STUDY)
    bounds = np.vstack([[m.range for m in cfg.modes], [cfg.wall_temperature.range]])
    X = olh_plan(bounds, 200, 0)
    naive = np.r_[np.zeros(6), 550.0]  # flat panel at mid-range wall temperature
    order = smart_order(X, naive, groups, rng=0)
    # acceptance: Eq. (2.82) total at least 1.5x smaller than restarting all from w_0
    # (measured 1.61 for n_C = 1, 1.55 for n_C = 2 on this 7-input plan)
    assert order.ratio >= 1.5
    sizes = np.bincount(order.group)
    assert sizes.max() - sizes.min() <= 1  # equal-sized groups
    for g in range(groups):
        seq = order.sequence(g)
        assert order.parent[seq[0]] == -1
        pos = {int(i): p for p, i in enumerate(seq)}
        for i in seq[1:]:  # a restart parent is computed earlier in the same group
            par = order.parent[i]
            assert par == -1 or (order.group[par] == g and pos[int(par)] < pos[int(i)])
    write_plan_csv(tmp_path / "plan.csv", X, order, [f"a{k}" for k in range(1, 7)] + ["T_w"])
    rows = list(csv.DictReader(open(tmp_path / "plan.csv")))
    assert len(rows) == 200 and set(rows[0]) >= {"group", "position", "restart_from", "T_w"}
    total = sum(float(r["distance"]) for r in rows)
    assert total == pytest.approx(order.total_distance, rel=1e-5)


def test_eq76_wall_temperature_stays_in_range() -> None:
    x = np.linspace(0, 1, 65)
    b = olh_plan(np.array([[0.2, 0.9], [-0.3, 0.3], [-0.3, 0.3]]), 200, 0)
    T = eq76_wall_temperature(x, b)
    assert T.min() >= 200.0 - 1e-9 and T.max() <= 900.0 + 1e-9


# -- acceptance sizes (slow) -------------------------------------------------------------------
@pytest.fixture(scope="module")
def study_rom() -> RomFluid:
    cfg, base = load_rom_config(STUDY)
    assert cfg.training.samples <= 200
    return build_rom_from_config(cfg, base)


@pytest.mark.slow
def test_sec71_rom_converges_with_200_samples(study_rom: RomFluid) -> None:
    res = check_rom(study_rom, 100, rng=2024)
    # acceptance (Sec. 7.1, Fig. 7.3): < 1 % pressure, < 2 % heat flux on 100 held-out
    # samples; measured 0.16 % and 0.23 %
    assert res["pressure_nrmse"] < 0.01 and res["heat_flux_nrmse"] < 0.02, res


@pytest.mark.slow
def test_correction_and_scaling_fig76_analogue(study_rom: RomFluid) -> None:
    results = {}
    for mach in (5.0, 6.0, 7.0):
        for alt in (20000.0, 25000.0, 30000.0):
            flow = FlowCondition.from_altitude(mach, alt)
            for xi in (1.0, 2.0, 4.0):
                for corr in ("bl", "pt"):
                    results[mach, alt, xi, corr] = check_rom(
                        study_rom.with_options(correction=corr), 30, flow, xi, "eq76", rng=1)
    bl = np.array([[r["pressure_nrmse"], r["heat_flux_nrmse"]]
                   for k, r in results.items() if k[3] == "bl"])
    pt = np.array([[r["pressure_nrmse"], r["heat_flux_nrmse"]]
                   for k, r in results.items() if k[3] == "pt"])
    # acceptance: corrected ROM (default BL) < 10 % in pressure and heat flux everywhere;
    # BL beats PT for pressure on average (measured mean 0.35 % vs 8.3 %)
    assert bl.max() < 0.10, bl.max(axis=0)
    assert bl[:, 0].mean() < pt[:, 0].mean()


@pytest.mark.slow
def test_nonuniform_wall_temperature_eq76(study_rom: RomFluid) -> None:
    res = check_rom(study_rom, 100, temperature="eq76", rng=5)
    # acceptance: heat-flux NRMSE < 10 % with the Eq. (7.6) non-uniform wall temperature
    assert res["heat_flux_nrmse"] < 0.10 and res["pressure_nrmse"] < 0.10, res

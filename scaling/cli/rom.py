"""``hypate rom``: build, check and plan fluid ROMs (Dissertation Sec. 2.4, 7.1, App. B).

* ``hypate rom build CONFIG.toml --out ROM.npz`` -- OLH samples from the built-in
  shock-expansion source (or external snapshots), POD-kriging, saved as NPZ;
* ``hypate rom check ROM.npz --samples N [--mach M --altitude H --scale XI] [--json]`` --
  mean NRMSE (Eq. 7.7, fractions) of pressure and heat flux on fresh source samples:
  ``{"pressure_nrmse": x, "heat_flux_nrmse": y, "samples": n}``; without ``--samples`` a
  ROM built from CFD snapshots shows its provenance and its errors on its held-out
  snapshots (``{"samples", "pressure": {...}, "heat_flux": {...}, "provenance": {...}}``);
* ``hypate rom plan CONFIG.toml --out PLAN.csv [--samples N --groups n_C]`` -- an OLH plan in
  smart order (App. B) for an external CFD campaign, with the restart distances (Eq. 2.82).
"""
from __future__ import annotations

import argparse
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from hypate.scaling.cli.arguments import integer_in, output_file, positive
from hypate.scaling.cli.commands import HELP
from hypate.scaling.cli.jsonout import dumps
from hypate.scaling.cli.progress import StepProgress
from hypate.scaling.workflow.vocabulary.shipped import resolve
from hypate.solvers.aero.rom.build import build_rom_from_config, check_holdout, check_rom
from hypate.solvers.aero.rom.config import MAX_SAMPLES, MIN_SAMPLES, load_rom_config
from hypate.solvers.aero.rom.io import load_rom, save_rom
from hypate.solvers.aero.rom.plan import olh_plan, smart_order, write_plan_csv
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition

#: Most sample-generating processes of ``rom build`` (a typo must not start thousands).
MAX_WORKERS = 256


def register(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser("rom", help=HELP["rom"],
                            description="Fluid reduced-order models: POD-kriging with "
                            "correction and scaling (Sec. 2.4).")
    cmds = parser.add_subparsers(dest="rom_command", metavar="ACTION",
                                 parser_class=type(parser))
    b = cmds.add_parser("build", help="build a ROM from a TOML build file",
                        description="Sample the built-in source on an OLH plan (or read the "
                        "external snapshots of the file) and fit the POD-kriging ROM.")
    b.add_argument("config", help="ROM build file (TOML), e.g. studies/rom/rom_2d_panel.toml "
                   "or the shipped name rom_2d_panel")
    b.add_argument("--out", required=True,
                   help="output ROM file (.npz); missing folders are created")
    b.add_argument("--samples", type=int, help="override [training] samples")
    b.add_argument("--workers", type=int, default=1,
                   help="processes generating samples (default 1: in-process)")
    b.add_argument("--resume", action="store_true",
                   help="openfoam source: reuse the finished CFD snapshots of OUT's store "
                   "(OUT with the suffix .snapshots) instead of refusing it")
    b.add_argument("--json", action="store_true", help="print a JSON summary")
    b.add_argument("-q", "--quiet", action="store_true",
                   help="no progress output (otherwise on stderr: a bar in a terminal, a "
                   "line per finished step and every 10 s without one)")
    b.set_defaults(func=run_build)

    c = cmds.add_parser("check", help="NRMSE of a ROM against fresh source samples",
                        description="Mean NRMSE (Eq. 7.7, as fractions) of the ROM's pressure "
                        "and heat flux against fresh samples of the built-in source, at the "
                        "reference condition or at --mach/--altitude and scale --scale.")
    c.add_argument("rom", help="ROM file (.npz)")
    c.add_argument("--samples", type=int, help="number of fresh samples of the built-in "
                   "source (required unless the ROM holds held-out CFD snapshots, which are "
                   "then checked)")
    c.add_argument("--mach", type=float, help="free-stream Mach number (default: reference)")
    c.add_argument("--altitude", type=float, help="altitude (m) (default: reference)")
    c.add_argument("--scale", type=float, default=1.0,
                   help="geometric scale ratio xi = L_ref / L (default 1)")
    c.add_argument("--correction", choices=("bl", "pt"), help="pressure correction "
                   "(default: the one stored in the ROM, 'bl')")
    c.add_argument("--temperature", choices=("uniform", "eq76"), default="uniform",
                   help="wall temperature of the samples: uniform (data set 2) or the "
                   "non-uniform Eq. (7.6) form (data set 3)")
    c.add_argument("--seed", type=int, default=12345, help="seed of the fresh samples")
    c.add_argument("--json", action="store_true", help="print JSON")
    # FlowCondition.from_altitude names its arguments; the user typed flags
    c.set_defaults(func=run_check, field_flags={"mach": "--mach", "altitude": "--altitude"})

    p = cmds.add_parser("plan", help="smart-ordered OLH sample plan as CSV (App. B)",
                        description="An OLH plan of the build file's inputs, ordered by the "
                        "smart ordering scheme (kNN graph, n_C groups, minimum spanning trees, "
                        "restart parents) for an external CFD campaign.")
    p.add_argument("config", help="ROM build file (TOML)")
    p.add_argument("--out", required=True, help="output plan (.csv)")
    p.add_argument("--samples", type=int, help="override [training] samples")
    p.add_argument("--groups", type=int, default=1, help="n_C parallel CPU groups")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=run_plan)
    parser.set_defaults(func=lambda args: (parser.print_help(), 2)[1])


def _samples(value: int | None) -> None:
    """``--samples`` of build and plan: the range of ``[training] samples``."""
    if value is not None:
        integer_in(value, "--samples", MIN_SAMPLES, MAX_SAMPLES)


def run_build(args: argparse.Namespace) -> int:

    _samples(args.samples)
    integer_in(args.workers, "--workers", 1, MAX_WORKERS)
    cfg, base = load_rom_config(resolve(args.config, "rom"))
    out = output_file(args.out, "--out", make_folders=True)
    progress = StepProgress("rom build", quiet=args.quiet)
    # CFD snapshots are kept beside the ROM file as they finish (crash-safe; --resume)
    store = out.with_suffix(".snapshots") if cfg.source.kind == "openfoam" else None
    try:
        if args.workers > 1:
            with ProcessPoolExecutor(args.workers) as pool:
                rom = build_rom_from_config(cfg, base, executor=pool, samples=args.samples,
                                            progress=progress, store=store,
                                            resume=args.resume)
        else:
            rom = build_rom_from_config(cfg, base, samples=args.samples, progress=progress,
                                        store=store, resume=args.resume)
    finally:
        progress.close()
    out.parent.mkdir(parents=True, exist_ok=True)  # like `hypate run --out runs/...`
    save_rom(rom, out)
    summary = {"out": str(out), "kind": rom.kind, "samples": int(rom.pressure_model.D_.shape[0]),
               "pressure_pod_modes": rom.pressure_model.n_modes,
               "heat_flux_pod_modes": rom.heat_model.n_modes}
    edge = rom.edge_temperature_model
    if edge is not None:
        summary["edge_temperature_pod_modes"] = edge.n_modes
    if args.json:
        print(dumps(summary, indent=2))
    else:
        print(f"ROM ({rom.kind}) from {summary['samples']} samples: "
              f"{summary['pressure_pod_modes']} pressure"
              + (f", {edge.n_modes} edge-temperature" if edge is not None else "")
              + f" and {summary['heat_flux_pod_modes']} heat-flux POD modes -> {out}")
    return 0


def _print_provenance(prov: dict, heat_flux_law: str) -> None:
    res = prov.get("resolution", {})
    it = prov.get("iterations", {})
    print(f"snapshots: {prov.get('solver', '?')} {prov.get('openfoam_version', '?')}, model "
          f"{prov.get('model', '?')}, {prov.get('snapshots', 0)} training + "
          f"{prov.get('holdout', 0)} held out, {prov.get('rejected', 0)} rejected; "
          f"{res.get('cells_panel', '?')} x {res.get('cells_normal', '?')} cells on the panel, "
          f"wall cell {res.get('wall_cell', float('nan')):g} m; iterations median "
          f"{it.get('median', float('nan')):g} (max {it.get('max', float('nan')):g})"
          + (f"; {prov['lower_courant']} converged at a lower Courant number after a diverged "
             "start" if prov.get("lower_courant") else "")
          + f"; heat flux: {prov.get('heat_flux', '?')}; the ROM's heat flux: {heat_flux_law}")


def run_check(args: argparse.Namespace) -> int:

    rom = load_rom(args.rom, correction=args.correction)
    if args.samples is None:
        if rom.holdout is None:
            raise InputError("--samples", "required: this ROM holds no held-out snapshots")
        result = check_holdout(rom)
        result["provenance"] = rom.provenance
        if args.json:
            print(dumps(result))
            return 0
        if rom.provenance:
            _print_provenance(rom.provenance, rom.heat_flux_law)
        for name in ("pressure", "heat_flux"):
            r = result[name]
            print(f"held-out {name.replace('_', ' ')} on {result['samples']} snapshots, in % "
                  f"of each snapshot's range: NRMSE median {100 * r['nrmse_median']:.2f}, "
                  f"max {100 * r['nrmse_max']:.2f}; largest point error median "
                  f"{100 * r['max_error_median']:.2f}, max {100 * r['max_error_max']:.2f}")
        return 0
    integer_in(args.samples, "--samples", 1, MAX_SAMPLES)
    positive(args.scale, "--scale")
    integer_in(args.seed, "--seed", 0)
    ref = rom.reference
    if args.mach is None and args.altitude is None:
        flow = ref
    else:
        altitude = args.altitude if args.altitude is not None else ref.altitude
        if altitude is None:
            raise InputError("--altitude", "the ROM's reference has no altitude; give one")
        flow = FlowCondition.from_altitude(args.mach if args.mach is not None else ref.mach,
                                           altitude)
    result = check_rom(rom, args.samples, flow, args.scale, args.temperature, rng=args.seed)
    if args.json:
        print(dumps(result))
    else:
        print(f"mean NRMSE on {result['samples']} fresh samples (M = {flow.mach:g}, "
              f"scale {args.scale:g}): pressure {100 * result['pressure_nrmse']:.3f} %, "
              f"heat flux {100 * result['heat_flux_nrmse']:.3f} %")
    return 0


def run_plan(args: argparse.Namespace) -> int:

    _samples(args.samples)
    integer_in(args.groups, "--groups", 1)
    cfg, _ = load_rom_config(resolve(args.config, "rom"))
    out = output_file(args.out, "--out")
    bounds = np.vstack([[m.range for m in cfg.modes], [cfg.wall_temperature.range]])
    names = [f"a{k + 1}" for k in range(len(cfg.modes))] + ["T_w"]
    if cfg.conventional is not None:
        bounds = np.vstack([[cfg.conventional.mach], [cfg.conventional.altitude], bounds])
        names = ["mach", "altitude"] + names
    n = args.samples or cfg.training.samples
    if args.groups > n:
        raise InputError("--groups", f"must be <= the number of samples ({n})")
    X = olh_plan(bounds, n, cfg.training.seed)
    naive = np.where(bounds[:, 0] < 0.0, 0.0, bounds.mean(axis=1))  # flat panel, mid T_w
    if cfg.conventional is not None:
        naive[:2] = bounds[:2].mean(axis=1)
    order = smart_order(X, naive, args.groups, rng=cfg.training.seed)
    write_plan_csv(out, X, order, names)
    summary = {"out": args.out, "samples": n, "groups": args.groups,
               "total_restart_distance": order.total_distance,
               "naive_restart_distance": order.naive_distance, "ratio": order.ratio}
    if args.json:
        print(dumps(summary, indent=2))
    else:
        print(f"{n} samples in {args.groups} group(s) -> {args.out}; total restart distance "
              f"(Eq. 2.82) {order.total_distance:.4g} vs {order.naive_distance:.4g} from the "
              f"naive solution ({order.ratio:.2f}x smaller)")
    return 0

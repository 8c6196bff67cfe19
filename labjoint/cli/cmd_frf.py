"""`labjoint frf RUN... --out FRF.json [--json]` and `labjoint modes RUN...|FRF.json
[--band LO:HI] [--json]`: FRFs of broadband records (H1/H2/Hv, coherence, std; one level
per record) and the modes of any FRF set (LSCF/LSFD with automatic pole selection,
half-power beside), per level."""

from __future__ import annotations

import argparse

from labjoint.cli.output import emit_json, table


def _frf_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--drive", default=None, help="drive channel (default: the one force, else the one voltage)")
    p.add_argument("--responses", default=None, help="response channels, comma-separated (default: all)")
    p.add_argument("--estimator", choices=["H1", "H2", "Hv"], default="H1")
    p.add_argument("--method", choices=["auto", "welch", "periodic", "burst", "block"], default="auto",
                   help="auto: from the excitation (whole periods of a multisine; a burst record by "
                        "--burst; Welch over the active drive of a steady random record; one block for "
                        "a sweep)")
    p.add_argument("--burst", default="block", metavar="block|driven",
                   help="a burst record's estimator: block (default: one unwindowed block per burst, "
                        "its free decay included, raw Y/U: the textbook burst-random H1 as Testlab "
                        "computes it) or driven (each burst's driven part through the local rational "
                        "method: the FRF at the burst's own amplitude, for a nonlinear structure)")
    p.add_argument("--nperseg", type=int, default=None, help="Welch segment length (samples)")
    p.add_argument("--overlap", type=float, default=None, help="Welch overlap, 0..1")
    p.add_argument("--window", default="hann", help="Welch window (scipy name)")


def add_frf_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", nargs="+", metavar="RUN", help="run files (HDF5) of broadband records")
    p.add_argument("--out", required=True, metavar="FRF.json", help="where to write the FRF set")
    p.add_argument("--band", default="drive", metavar="LO:HI|drive|all",
                   help="lines kept (default: where the drive carries power)")
    _frf_options(p)


def add_modes_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("inputs", nargs="+", metavar="RUN|FRF.json", help="run files or FRF sets")
    p.add_argument("--band", default=None, metavar="LO:HI", help="frequency band in Hz")
    p.add_argument("--order", type=int, default=None, help="highest LSCF model order (default: from the lines)")
    _frf_options(p)


def run_frf(args: argparse.Namespace) -> int:
    from labjoint.identify.spectral import frf_out

    args.frf_band = args.band
    res = frf_out(args.runs, args.out, args)
    if getattr(args, "json", False):
        emit_json(res)
        return 0
    print(f"{len(res['levels'])} level(s) -> {args.out}")
    print(table(["run", "level", "units", "lines", "averages", "median coh"],
                [(lv["run"], f"{lv['level']:.4g} {lv['level_units']}", lv["units"], lv["lines"],
                  lv["averages"], lv["median_coherence"]) for lv in res["levels"]]))
    return 0


def run_modes(args: argparse.Namespace) -> int:
    from labjoint.identify.spectral import modes_levels

    levels = modes_levels(args.inputs, args)
    if getattr(args, "json", False):
        emit_json({"levels": levels})
        return 0
    rows = [(lv["run"] or "", "?" if lv["level"] is None else f"{lv['level']:.4g} {lv['level_units']}",
             i + 1, m["frequency_hz"],
             m["damping_ratio"], m["half_power"]["frequency_hz"], m["half_power"]["damping_ratio"])
            for lv in levels for i, m in enumerate(lv["modes"])]
    print(table(["run", "level", "mode", "LSCF Hz", "LSCF zeta", "half-power Hz", "half-power zeta"], rows))
    return 0

"""Inputs of the `labjoint structure` actions: number lists and the structure file with --set."""

from __future__ import annotations

import argparse

from labjoint.errors import InputError


def floats(text: str, field: str, sep: str = ",") -> list[float]:
    """Numbers of ``text`` separated by ``sep`` (InputError naming ``field`` otherwise)."""
    try:
        return [float(x) for x in text.split(sep) if x.strip()]
    except ValueError:
        raise InputError(f"expected numbers separated by '{sep}', got '{text}'", field=field) from None


def load_with_sets(args: argparse.Namespace):
    """The structure file of ``args`` with its ``--set`` parameters applied."""
    from labjoint.structure import load_structure
    from labjoint.structure.modal import parameter_value, with_parameter

    s = load_structure(args.structure)
    for item in args.set:
        key, sep, val = item.partition("=")
        key = key.strip()
        if not sep:
            raise InputError(f"expected PARAM=VALUE, got '{item}'", field="--set")
        try:
            parameter_value(s, key)        # a key no joint has would be ignored silently
        except InputError:
            known = sorted({p for j in s.joints for p in j.law.params}
                           | ({"E_e_pa"} if any(j.layer is not None for j in s.joints) else set()))
            raise InputError(f"no joint of the structure has parameter {key!r}; known: "
                             f"{', '.join(known)}", file=args.structure,
                             field=f"--set {key}") from None
        values = floats(val, f"--set {key}")
        if len(values) != 1:
            raise InputError(f"expected one number, got '{val}'", field=f"--set {key}")
        s = with_parameter(s, key, values[0])
    return s

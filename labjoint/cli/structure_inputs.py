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
    from labjoint.structure.modal import with_parameter

    s = load_structure(args.structure)
    for item in args.set:
        key, sep, val = item.partition("=")
        if not sep:
            raise InputError(f"expected PARAM=VALUE, got '{item}'", field="--set")
        s = with_parameter(s, key.strip(), floats(val, f"--set {key}")[0])
    return s

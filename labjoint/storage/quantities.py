"""Physical quantities of channels and their units: parsing and conversion to SI.

Every channel of a run file carries a *quantity* (``displacement``, ``velocity``,
``acceleration``, ``force``, ``voltage``; anything else, e.g. ``time`` or
``temperature``, is kept as given) and the SI unit of its stored samples
(:data:`SI_UNITS`). Units come from an explicit map or header, written in the usual
spellings (:data:`SPELLINGS`), and are converted at the edge; a unit that does not fit
its quantity is refused naming the channel. A quantity is never guessed from a column
name: ``velocity_m_per_s`` is a name, not a unit.

>>> to_si("acceleration", "g", channel="acc1")
(9.80665, 'm/s^2')
>>> to_si("velocity", "mm/s", channel="laser")
(0.001, 'm/s')
>>> to_si("force", "mV", channel="input_V")
Traceback (most recent call last):
...
labjoint.errors.InputError: 'input_V': unit 'mV' is a voltage, not a force
"""

from __future__ import annotations

from labjoint.errors import InputError

#: The SI unit stored for each known quantity.
SI_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N",
            "voltage": "V", "time": "s"}
#: Quantities a drive may be (a measured force, or an amplifier/generator voltage).
DRIVE_QUANTITIES = ("force", "voltage")
#: Quantities of a structure's motion (what response sensors measure).
MOTION_QUANTITIES = ("displacement", "velocity", "acceleration")
STANDARD_GRAVITY = 9.80665

_MICRO = ("u", "\u00b5", "\u03bc")          # u, micro sign, Greek small mu
_LENGTH = {"m": 1.0, "mm": 1e-3, "nm": 1e-9, **{p + "m": 1e-6 for p in _MICRO}}
_SQUARED = ("^2", "\u00b2", "2", "**2")


def _spellings() -> dict[str, tuple[str, float]]:
    out: dict[str, tuple[str, float]] = {}
    for length, k in _LENGTH.items():
        out[length] = ("displacement", k)
        out[f"{length}/s"] = ("velocity", k)
        for sq in _SQUARED:
            out[f"{length}/s{sq}"] = ("acceleration", k)
    out["g"] = ("acceleration", STANDARD_GRAVITY)
    out.update({"N": ("force", 1.0), "kN": ("force", 1e3), "mN": ("force", 1e-3),
                "V": ("voltage", 1.0), "mV": ("voltage", 1e-3),
                "s": ("time", 1.0), "ms": ("time", 1e-3)})
    return out


#: unit spelling -> (quantity, factor to the quantity's SI unit)
SPELLINGS: dict[str, tuple[str, float]] = _spellings()


def parse_unit(unit: str) -> tuple[str, float] | None:
    """(quantity, factor to SI) of a unit spelling, or None if it is not one we know.

    >>> parse_unit("m/s\u00b2"), parse_unit("\u00b5m"), parse_unit("furlong")
    (('acceleration', 1.0), ('displacement', 1e-06), None)
    """
    u = str(unit).strip().replace(" ", "")
    return SPELLINGS.get(u)


def to_si(quantity: str, unit: str, *, channel: str, file: str | None = None) -> tuple[float, str]:
    """Factor bringing samples in ``unit`` to the SI unit of ``quantity``, and that unit.

    A known quantity needs a unit of that quantity (InputError naming ``channel``
    otherwise); any other quantity keeps its unit as given (factor 1), unless that unit
    is one of a known quantity's (a misspelt quantity).
    """
    q = str(quantity).strip().lower()
    if not q or not q.replace("_", "").isalnum():
        raise InputError(f"quantity {quantity!r} must be a word (e.g. one of {sorted(SI_UNITS)})",
                         file=file, field=channel)
    parsed = parse_unit(unit)
    if q not in SI_UNITS:
        if parsed is not None:             # a typo ('velocty') would keep m/s unconverted
            raise InputError(f"quantity {quantity!r} is not one labjoint knows, but unit "
                             f"{unit!r} is a{'n' if parsed[0][0] in 'aeiou' else ''} "
                             f"{parsed[0]}: write quantity = {parsed[0]!r}",
                             file=file, field=channel)
        return 1.0, str(unit).strip()
    if parsed is None:
        raise InputError(f"unknown unit {unit!r} for a {q}; write one of "
                         f"{', '.join(k for k, v in SPELLINGS.items() if v[0] == q)}",
                         file=file, field=channel)
    uq, factor = parsed
    if uq != q:
        raise InputError(f"unit {unit!r} is a{'n' if uq[0] in 'aeiou' else ''} {uq}, not a {q}",
                         file=file, field=channel)
    return factor, SI_UNITS[q]


def si_unit(quantity: str) -> str | None:
    """The SI unit of a known quantity (None for a quantity kept as given)."""
    return SI_UNITS.get(quantity)


def frf_units(response_quantity: str, drive_quantity: str) -> str:
    """Units of an FRF response/drive, e.g. ``m/s/V`` (velocity per volt).

    >>> frf_units("acceleration", "force"), frf_units("velocity", "voltage")
    ('m/s^2/N', 'm/s/V')
    """
    return f"{SI_UNITS.get(response_quantity, '1')}/{SI_UNITS.get(drive_quantity, '1')}"

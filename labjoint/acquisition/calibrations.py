"""Which calibration factor each channel of a run is read with, and where it came from."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from labjoint.hardware.interfaces import ChannelSpec


def channel_calibrations(channels: Sequence[ChannelSpec], frequency_hz: float,
                         sources: Mapping[str, Sequence[Mapping[str, Any]]] | None = None
                         ) -> dict[str, dict[str, Any]]:
    """Per channel, the factor a run at ``frequency_hz`` is read with, and where it came from.

    The reader converts volts with ``ChannelSpec.units_per_volt`` at the run's
    ``frequency_hz`` (the generator's read-back frequency): the channel's calibration
    table interpolated linearly there (held at the nearest end outside the table), else
    its ``sensitivity``. ``points`` are the table entries that factor comes from (one
    if it matches a point or lies outside the table, else the two around it), each with
    its provenance from ``sources`` (e.g. the calibration runs) when known.

    >>> spec = ChannelSpec("nc", "nanocomposite", "force", "N", 301.0,
    ...                    calibration=((300.0, 280.0), (500.0, 300.0)))
    >>> c = channel_calibrations([spec], 400.0, {"nc": [{"frequency_hz": 300.0, "runs": ["a"]}]})
    >>> c["nc"]["factor"], c["nc"]["interpolation"], c["nc"]["points"][0]["runs"]
    (290.0, 'linear', ['a'])
    """
    out: dict[str, dict[str, Any]] = {}
    f = float(frequency_hz)
    for spec in channels:
        entry: dict[str, Any] = {"factor": spec.units_per_volt(f), "unit": f"{spec.unit}/V",
                                 "frequency_hz": f}
        if not spec.calibration:
            entry.update(source="sensitivity", interpolation="none")
            out[spec.name] = entry
            continue
        tab = sorted((float(a), float(b)) for a, b in spec.calibration)
        freqs = np.array([a for a, _ in tab])
        i = int(np.searchsorted(freqs, f))
        exact = np.flatnonzero(np.isclose(freqs, f, rtol=1e-9, atol=1e-9))
        if exact.size:
            used, how = [int(exact[0])], "exact"
        elif i == 0 or i == len(tab):
            used, how = [min(i, len(tab) - 1)], "nearest (outside the calibrated range)"
        else:
            used, how = [i - 1, i], "linear"
        known = list((sources or {}).get(spec.name, ()))
        points = []
        for j in used:
            fj, kj = tab[j]
            prov = next((dict(p) for p in known
                         if abs(float(p.get("frequency_hz", np.nan)) - fj) <= 1e-6), None)
            point: dict[str, Any] = {"frequency_hz": fj, "factor": kj}
            if prov is None:
                point["source"] = "channel calibration table (config)"
            else:
                point.update({k: v for k, v in prov.items()
                              if k not in ("frequency_hz", "factor", "n_per_v")})
            points.append(point)
        entry.update(source="calibration table", interpolation=how, points=points,
                     table=[list(p) for p in tab])
        out[spec.name] = entry
    return out

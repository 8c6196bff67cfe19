"""Arbitrary waveforms on the AFG1022 (mixed into the driver class): one period loaded
into edit memory, copied to ``USER<channel>`` and played at a repetition frequency.

The block is ``DATA:DATA EMEMory,#<n><length><bytes>``: 2..8,192 points as 14-bit codes
(0 = -peak, 16382 = +peak, 8191 = zero; uint16, big-endian). The driver normalises the
points to a peak of 1 first, so the amplitude setting (Vpp = 2 x peak) is the waveform's
peak whatever its shape; the instrument's point count (``DATA:POINts? EMEMory``) is
checked after the load. How many multisine lines fit at a resolution:
:mod:`labjoint.acquisition.waveforms`.
"""

from __future__ import annotations

import numpy as np

from labjoint.errors import HardwareError, InputError
from labjoint.hardware.interfaces import GeneratorSettings

#: 14-bit waveform codes: 0 is the waveform's -peak, 16382 its +peak, 8191 zero.
CODE_ZERO = 8191
MIN_POINTS, MAX_POINTS = 2, 8192


def codes_14bit(points) -> np.ndarray:
    """Points as 14-bit codes, normalised to a peak of 1 (InputError names what is wrong).

    >>> codes_14bit([-2.0, 0.0, 1.0, 2.0]).tolist()
    [0, 8191, 12286, 16382]
    """
    x = np.asarray(points, dtype=float).ravel()
    if not MIN_POINTS <= x.size <= MAX_POINTS:
        raise InputError(f"the AFG1022 stores {MIN_POINTS}..{MAX_POINTS} waveform points, "
                         f"got {x.size}", field="points")
    if not np.all(np.isfinite(x)):
        raise InputError("waveform points must be finite", field="points")
    peak = float(np.max(np.abs(x)))
    if peak == 0:
        raise InputError("the waveform is constant zero", field="points")
    return np.round(CODE_ZERO + CODE_ZERO * (x / peak)).astype(np.uint16)


def shape_name(text: str) -> str:
    """'sine', 'user' (an arbitrary waveform) or the instrument's word, lower case.

    >>> shape_name("USER1"), shape_name("SINusoid"), shape_name("SQU")
    ('user', 'sine', 'squ')
    """
    t = text.strip().upper()
    if t.startswith("SIN"):
        return "sine"
    if t.startswith("USER") or t.startswith("EMEM"):
        return "user"
    return t.lower()


class ArbitraryWaveforms:
    """Mixed into :class:`~labjoint.hardware.afg1022.AFG1022` (uses its ``_exchange``,
    ``_write``, ``_query_float``, ``_opc``, ``_check_errors`` and ``_apply_shape``)."""

    _wave: np.ndarray | None = None

    def load_waveform(self, points) -> int:
        """Load one period (module doc); the number of points the instrument holds."""
        codes = codes_14bit(points)
        with self._lock:
            cmd = "DATA:DATA EMEMory,"
            with self._exchange(cmd + "<block>") as res:
                res.write_binary_values(cmd, codes.tolist(), datatype="H", is_big_endian=True)
            self._write(f"DATA:COPY USER{self.channel},EMEMory")
            self._opc("waveform load")
            self._check_errors("waveform load")
            n = self._query_float("DATA:POINts? EMEMory")
            if n != codes.size:
                raise HardwareError(f"{self.resource}: loaded {codes.size} waveform points but "
                                    f"the instrument holds {n:g}")
            wave = (codes.astype(float) - CODE_ZERO) / CODE_ZERO
            wave.setflags(write=False)
            self._wave, self._known = wave, None
            return int(codes.size)

    def waveform(self) -> np.ndarray | None:
        return self._wave

    def apply_waveform(self, frequency_hz: float, amplitude_vpp: float,
                       offset_v: float = 0.0) -> GeneratorSettings:
        """Play ``USER<channel>`` ``frequency_hz`` times per second at ``amplitude_vpp``;
        every setting read back and compared, as :meth:`apply` does for a sine."""
        with self._lock:
            if self._wave is None:
                raise HardwareError(f"{self.resource}: no arbitrary waveform loaded "
                                    "(load_waveform first)")
            return self._apply_shape(f"USER{self.channel}", "user", frequency_hz, amplitude_vpp,
                                     offset_v)

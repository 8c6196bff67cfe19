"""What the AFG1022's pyvisa-sim twin needs beyond its YAML: binary waveform blocks, and a
device clear (:func:`_install_clear`).

pyvisa-sim matches every message as UTF-8 text, so the IEEE 488.2 definite-length block
of ``DATA:DATA EMEMory,#<n><length><bytes>`` (14-bit codes as big-endian uint16) cannot
be described in ``configs/afg1022-sim.yaml``. :func:`install` teaches the simulated
device that one message: it checks the block as the instrument would (header digits,
length, an even byte count, 2..8,192 points, codes within 14 bits), keeps the codes, and
hands the YAML the equivalent ``DATA:POINts EMEMory,<n>`` so that ``DATA:POINts?
EMEMory`` answers the stored count. A malformed block becomes a command the YAML does
not know, so the instrument's error queue reports it (-200), as the real one would.
The driver sends exactly what it sends to the real instrument.
"""

from __future__ import annotations

import threading

import numpy as np

HEADER = b"DATA:DATA EMEMory,"
_installed = threading.Lock()
_done = False


def parse_block(message: bytes, eom: bytes = b"\n") -> np.ndarray | None:
    """The codes of a ``DATA:DATA EMEMory`` message, or None if it is malformed.

    >>> parse_block(HEADER + b"#14" + bytes([0, 1, 0x3f, 0xfe]) + b"\\n").tolist()
    [1, 16382]
    >>> parse_block(HEADER + b"#15" + bytes(5) + b"\\n") is None
    True
    """
    body = message[len(HEADER):]
    if body.endswith(eom):
        body = body[:-len(eom)]
    if len(body) < 2 or body[:1] != b"#" or not body[1:2].isdigit() or body[1:2] == b"0":
        return None
    nd = int(body[1:2])
    digits = body[2:2 + nd]
    if len(digits) != nd or not digits.isdigit():
        return None
    n_bytes = int(digits)
    data = body[2 + nd:]
    if len(data) != n_bytes or n_bytes % 2 or not 2 <= n_bytes // 2 <= 8192:
        return None
    codes = np.frombuffer(data, dtype=">u2").astype(np.uint16)
    if np.any(codes > 16383):
        return None
    return codes


def install() -> None:
    """Patch pyvisa-sim's device once so it accepts waveform blocks (module doc)."""
    global _done
    with _installed:
        if _done:
            return
        from pyvisa_sim import devices

        original = devices.Device.write

        def write(self, data: bytes) -> None:
            if isinstance(data, (bytes, bytearray)) and bytes(data).startswith(HEADER) \
                    and not self._input_buffer:
                codes = parse_block(bytes(data), self._query_eom)
                self.ememory = codes
                text = (f"DATA:POINts EMEMory,{codes.size}" if codes is not None
                        else "DATA:DATA EMEMory,MALFORMED")
                return original(self, text.encode() + self._query_eom)
            return original(self, data)

        devices.Device.write = write
        _install_clear()
        _done = True


def _install_clear() -> None:
    """viClear as IEEE 488.2 device clear does on the instrument: its input and output
    queues emptied (a half-read answer dropped), settings and error queue kept. pyvisa-sim
    has none (NotImplementedError), so a query cut short left its answer for the next."""
    from pyvisa import constants
    from pyvisa_sim import highlevel

    def clear(self, session):  # type: ignore[no-untyped-def]
        try:
            device = self.sessions[session].device
        except (KeyError, AttributeError):
            return constants.StatusCode.error_invalid_object
        device._output_buffers.clear()
        device._input_buffer = bytearray()
        return constants.StatusCode.success

    highlevel.SimVisaLibrary.clear = clear

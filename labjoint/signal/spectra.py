"""Auto- and cross-spectra of one drive and several responses, accumulated over blocks.

Welch's method: segments of ``nperseg`` samples, a window, an overlap; the one-sided
spectral densities G_ff, G_yy and G_fy (y against the drive f) are summed segment by
segment, so a record of any length is processed in bounded memory (``feed`` takes the
record in pieces of any size and keeps only the unfinished segment between calls).

From the sums (Bendat & Piersol, *Random Data*, 4th ed., Sec. 9.2):

- H1 = G_fy / G_ff (noise on the response), H2 = G_yy / G_yf (noise on the drive),
  Hv the total-least-squares estimate with equal weights on both noises (its magnitude
  is the geometric mean of |H1| and |H2| at high coherence; phase of H1);
- coherence gamma^2 = |G_fy|^2 / (G_ff G_yy) (Eq. 9.63);
- normalised random error of |H| and of the phase (rad), Eq. 9.90 / Table 9.6:
  eps = sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d)), with n_d the number of independent
  averages; overlapping Hann segments count as n / (1 + 2 rho^2), rho the window's
  correlation at the overlap (Welch 1967: rho = 0.167 at half overlap).

>>> fs, n = 1000.0, 1 << 14
>>> rng = np.random.default_rng(0)
>>> f = rng.normal(size=n)
>>> w = Welch(512, fs, responses=1)
>>> w.feed(f[:5000], 2 * f[None, :5000]); w.feed(f[5000:], 2 * f[None, 5000:])
>>> bool(np.allclose(w.h1()[0, 1:], 2.0)), w.count
(True, 63)
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.fft as sfft
from numpy.lib.stride_tricks import sliding_window_view
from scipy.signal import get_window

from labjoint.errors import InputError

#: segments transformed at once (bounds the temporaries: segments x channels x nperseg)
BATCH_SAMPLES = 1 << 21


class Welch:
    """Streamed Welch sums of one drive and ``responses`` response channels."""

    def __init__(self, nperseg: int, fs: float, responses: int, window: str = "hann",
                 overlap: float = 0.5, dtype: Any = np.float64) -> None:
        if nperseg < 8:
            raise InputError(f"a segment needs at least 8 samples, got {nperseg}", field="nperseg")
        if not 0 <= overlap < 1:
            raise InputError(f"must be in [0, 1), got {overlap}", field="overlap")
        self.nperseg, self.fs, self.window_name = int(nperseg), float(fs), window
        self.step = max(1, int(round(nperseg * (1 - overlap))))
        self.dtype = np.dtype(dtype)
        self.window = get_window(window, self.nperseg).astype(self.dtype)
        # one-sided density scaling: 2 / (fs sum w^2), DC and Nyquist single
        self.scale = np.full(self.nperseg // 2 + 1, 2.0 / (fs * np.sum(self.window.astype(float) ** 2)))
        self.scale[0] /= 2
        if self.nperseg % 2 == 0:
            self.scale[-1] /= 2
        nf, S = self.scale.size, int(responses)
        self.gff = np.zeros(nf)
        self.gyy = np.zeros((S, nf))
        self.gfy = np.zeros((S, nf), complex)
        self.count = 0
        self._tail = np.zeros((S + 1, 0), self.dtype)

    @property
    def freq_hz(self) -> np.ndarray:
        return np.fft.rfftfreq(self.nperseg, 1.0 / self.fs)

    def feed(self, drive: np.ndarray, responses: np.ndarray) -> None:
        """Add the next piece of the record: ``drive`` (n,), ``responses`` (S, n)."""
        x = np.empty((1 + len(responses), self._tail.shape[1] + len(drive)), self.dtype)
        t = self._tail.shape[1]
        x[:, :t] = self._tail
        x[0, t:] = drive
        x[1:, t:] = responses
        n = x.shape[1]
        nseg = 0 if n < self.nperseg else (n - self.nperseg) // self.step + 1
        per = max(1, BATCH_SAMPLES // (self.nperseg * x.shape[0]))
        for s0 in range(0, nseg, per):
            s1 = min(nseg, s0 + per)
            block = x[:, s0 * self.step: (s1 - 1) * self.step + self.nperseg]
            segs = sliding_window_view(block, self.nperseg, axis=1)[:, ::self.step]  # (C, k, L)
            X = sfft.rfft(segs * self.window, axis=-1)      # (C, k, f)
            cross = (X[0].conj() * X[1:]).sum(axis=1)
            power = (X.real ** 2 + X.imag ** 2).sum(axis=1)
            self.gff += power[0]
            self.gyy += power[1:]
            self.gfy += cross
            self.count += s1 - s0
        self._tail = x[:, nseg * self.step:].copy()

    # --- estimates from the sums ------------------------------------------------------
    def densities(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(G_ff, G_yy, G_fy), one-sided densities (unit^2/Hz)."""
        if self.count == 0:
            raise InputError(f"the record is shorter than one segment of {self.nperseg} samples",
                             field="record")
        k = self.scale / self.count
        return self.gff * k, self.gyy * k, self.gfy * k

    def averages(self) -> float:
        """Independent averages n_d (overlap counted by the window's correlation)."""
        if self.step >= self.nperseg or self.count < 2:
            return float(self.count)
        lag = self.nperseg - self.step
        w = self.window.astype(float)
        rho = float(np.dot(w[:lag], w[self.step:]) / np.dot(w, w))
        return float(self.count / (1 + 2 * rho ** 2))

    def h1(self) -> np.ndarray:
        gff, _, gfy = self.densities()
        with np.errstate(divide="ignore", invalid="ignore"):
            return gfy / gff

    def estimates(self) -> dict[str, np.ndarray]:
        """H1, H2, Hv (S, nf), coherence (S, nf) and the normalised random error eps."""
        gff, gyy, gfy = self.densities()
        return estimates_from(gff, gyy, gfy, self.averages())


def estimates_from(gff: np.ndarray, gyy: np.ndarray, gfy: np.ndarray, n_d: float) -> dict[str, np.ndarray]:
    """H1, H2, Hv, coherence and eps from the spectral sums (module docstring)."""
    tiny = 1e-300
    ok = gff > 1e-12 * gff.max() if gff.size and gff.max() > 0 else np.zeros_like(gff, bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        h1 = np.where(ok, gfy / np.maximum(gff, tiny), np.nan)
        h2 = np.where(ok & (np.abs(gfy) > 0), gyy / np.conj(gfy), np.nan)
        coh = np.where(ok & (gyy > 0), np.abs(gfy) ** 2 / (gff * gyy), 0.0)
        coh = np.clip(coh, 0.0, 1.0)
        # Hv (TLS, equal noise weights): the larger root of G_yf H^2 + (G_ff - G_yy) H - G_fy = 0
        d = gyy - gff
        hv_mag_num = d + np.sqrt(d ** 2 + 4 * np.abs(gfy) ** 2)
        hv = np.where(ok & (np.abs(gfy) > 0), hv_mag_num / (2 * np.conj(gfy)), np.nan)
        eps = np.where(coh > 0, np.sqrt(1 - coh) / (np.sqrt(coh) * np.sqrt(2 * n_d)), np.inf)
    return {"H1": h1, "H2": h2, "Hv": hv, "coherence": coh, "eps": eps, "n_d": np.asarray(n_d)}

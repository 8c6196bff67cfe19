"""An independent generator of joint records (numpy/scipy only, no labjoint law inside).

Joint laws written here from their textbook definitions: linear and cubic springs,
viscous damping, one Jenkins element (spring k in series with a Coulomb slider of slip
force f_s, return-mapped per sample), Bouc-Wen (z' = A u' - b|u'||z|^(n-1) z - g u'|z|^n,
integrated on a fine substep grid), and a quadratic-in-velocity drag (a law that is not in
labjoint's vocabulary). Records are written in design.md's CSV import format.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def jenkins(u: np.ndarray, k: float, f_s: float) -> np.ndarray:
    """Force of a spring k in series with a Coulomb slider (slip force f_s), relaxed at u[0]."""
    out = np.empty_like(u)
    slider = u[0]
    for i, x in enumerate(u):
        f = k * (x - slider)
        if f > f_s:
            slider = x - f_s / k
            f = f_s
        elif f < -f_s:
            slider = x + f_s / k
            f = -f_s
        out[i] = f
    return out


def bouc_wen(u: np.ndarray, A: float, b: float, g: float, n: float = 1.0, sub: int = 20
             ) -> np.ndarray:
    """Bouc-Wen hysteretic force z along u (explicit midpoint on ``sub`` substeps per sample)."""
    z = 0.0
    out = np.empty_like(u)
    out[0] = 0.0
    for i in range(1, u.size):
        du = (u[i] - u[i - 1]) / sub
        for _ in range(sub):
            def rate(zz):
                return A * du - b * abs(du) * abs(zz) ** (n - 1) * zz - g * du * abs(zz) ** n
            zm = z + 0.5 * rate(z)
            z = z + rate(zm)
        out[i] = z
    return out


def law(u: np.ndarray, v: np.ndarray, hidden: dict) -> np.ndarray:
    """Joint force of the effects named in ``hidden`` along (u, v)."""
    F = hidden.get("k", 0.0) * u
    if "c" in hidden:
        F = F + hidden["c"] * v
    if "k3" in hidden:
        F = F + hidden["k3"] * u ** 3
    if "jenkins" in hidden:
        F = F + jenkins(u, *hidden["jenkins"])
    if "bw" in hidden:
        F = F + bouc_wen(u, *hidden["bw"])
    if "quad" in hidden:                       # not in the vocabulary: c2 v |v|
        F = F + hidden["quad"] * v * np.abs(v)
    return F


def sine_run(amp: float, freq: float, fs: float, hidden: dict, noise: float, cycles: int = 12,
             dc: float = 0.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, u measured, F measured): the joint driven in displacement by a sine ramped up over
    two cycles from rest, the force from :func:`law`; Gaussian noise of ``noise`` times the
    force rms on the force, a sensor offset ``dc`` on the displacement."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(cycles * fs / freq)) / fs
    env = np.clip(t * freq / 2.0, 0.0, 1.0)
    w = 2 * np.pi * freq
    u = amp * env * np.sin(w * t)
    v = np.gradient(u, 1 / fs)
    F = law(u, v, hidden)
    F = F + noise * np.std(F) * rng.standard_normal(F.size)
    return t, u + dc, F


def random_run(rms: float, band: tuple[float, float], fs: float, seconds: float, hidden: dict,
               noise: float, dc: float = 0.0, seed: int = 0, sweep: bool = False
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, u, F) under band-limited random displacement (or a linear sine sweep over
    ``band`` when ``sweep``), starting from rest (a half-second lead-in of zeros)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * fs)
    t = np.arange(n) / fs
    if sweep:
        f0, f1 = band
        ph = 2 * np.pi * (f0 * t + 0.5 * (f1 - f0) / seconds * t * t)
        u = np.sin(ph)
    else:
        spec = np.fft.rfft(rng.standard_normal(n))
        f = np.fft.rfftfreq(n, 1 / fs)
        spec[(f < band[0]) | (f > band[1])] = 0.0
        u = np.fft.irfft(spec, n)
    u = rms * u / np.std(u)
    lead = int(0.5 * fs)
    ramp = np.clip(np.arange(n) / (0.05 * fs), 0, 1)
    u = np.concatenate([np.zeros(lead), u * ramp])
    t = np.arange(u.size) / fs
    v = np.gradient(u, 1 / fs)
    F = law(u, v, hidden)
    F = F + noise * np.std(F) * rng.standard_normal(F.size)
    return t, u + dc, F


def write_csv(path: Path, t, u, F, **meta) -> Path:
    """A run in design.md's CSV import format."""
    path = Path(path)
    head = "".join(f"# {k}: {v}\n" for k, v in meta.items())
    body = np.column_stack([t, u, F])
    with path.open("w") as fh:
        fh.write(head + "time_s,displacement_m,force_N\n")
        np.savetxt(fh, body, delimiter=",", fmt="%.10g")
    return path

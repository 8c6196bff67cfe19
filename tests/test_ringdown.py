"""Backbones from ringdowns (labjoint.signal.ringdown) against closed forms and against
oscillators integrated here (Duffing; an Iwan friction oscillator of Jenkins elements)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from labjoint.errors import InputError
from labjoint.signal.ringdown import ringdown_backbone

F0, ZETA = 30.0, 0.01


def damped(t, a0, f, zeta, phase=0.3):
    wn = 2 * np.pi * f
    return a0 * np.exp(-zeta * wn * t) * np.cos(wn * np.sqrt(1 - zeta ** 2) * t + phase)


def by_method(b, method):
    return [p for p in b.points if p.method == "ringdown_" + method]


@pytest.mark.parametrize("method", ["hilbert", "peaks"])
def test_linear_damped_sine_gives_exact_frequency_and_damping_at_every_amplitude(method):
    fs = 2000.0
    t = np.arange(int(3 * fs)) / fs
    b = ringdown_backbone(damped(t, 1e-3, F0, ZETA), fs, methods=(method,), sensor="tip")
    pts = by_method(b, method)
    assert len(pts) >= 10 and b.amplitude_units == "m" and b.sensor == "tip"
    amp = np.array([p.amplitude for p in pts])
    assert amp.max() / amp.min() > 30                      # over more than a decade
    for p in pts:
        assert p.frequency_hz == pytest.approx(F0, rel=2e-5)
        assert p.damping_ratio == pytest.approx(ZETA, rel=3e-3)
        assert 0 < p.frequency_sd_hz < 1e-3 and 0 < p.damping_sd < 1e-4
    # the amplitude is the envelope at the window's time: consecutive windows differ by
    # exp(-zeta wn T_window), T_window = 4 damped periods
    ratio = amp[1:] / amp[:-1]
    expect = np.exp(ZETA * 2 * np.pi * F0 * 4 / (F0 * np.sqrt(1 - ZETA ** 2)))
    assert np.allclose(ratio, expect, rtol=2e-3)


def test_acceleration_converted_to_displacement_only_when_asked():
    fs = 2000.0
    t = np.arange(int(2 * fs)) / fs
    w = 2 * np.pi * F0
    acc = -w * w * damped(t, 1e-3, F0, 0.002)              # ~ acceleration of that motion
    plain = ringdown_backbone(acc, fs, quantity="acceleration", methods=("hilbert",))
    disp = ringdown_backbone(acc, fs, quantity="acceleration", methods=("hilbert",), to_displacement=True)
    assert plain.amplitude_units == "m/s^2" and disp.amplitude_units == "m"
    wd = w * np.sqrt(1 - 0.002 ** 2)
    assert disp.array("amplitude") == pytest.approx(plain.array("amplitude") / wd ** 2, rel=1e-6)
    assert any("omega^2" in n for n in disp.notes)


def test_two_modes_isolated_by_band_pass():
    fs = 4000.0
    t = np.arange(int(3 * fs)) / fs
    x = damped(t, 1e-3, F0, ZETA) + damped(t, 2e-3, 180.0, 0.002, 1.0)
    x = x[:int(1.5 * fs)]
    for mode, f, z in ((30.0, F0, ZETA), (180.0, 180.0, 0.002)):
        b = ringdown_backbone(x, fs, mode_hz=mode)
        assert len(b.points) >= 6
        for p in b.points:
            assert p.frequency_hz == pytest.approx(f, rel=1e-4)
            assert p.damping_ratio == pytest.approx(z, rel=5e-3)


def test_two_modes_too_close_are_refused_with_what_would_help():
    fs = 2000.0
    t = np.arange(int(4 * fs)) / fs
    x = damped(t, 1e-3, 30.0, 0.005) + damped(t, 1e-3, 31.5, 0.005, 1.0)
    with pytest.raises(InputError, match="too close to separate.*excite one mode alone"):
        ringdown_backbone(x, fs, mode_hz=30.0)


def test_too_few_cycles_above_the_noise_is_refused():
    fs = 2000.0
    t = np.arange(int(2 * fs)) / fs
    rng = np.random.default_rng(3)
    x = damped(t, 1e-3, F0, 0.02) + 5e-5 * rng.standard_normal(t.size)   # below 10x within 6 cycles
    with pytest.raises(InputError, match="too few cycles above the noise.*higher level"):
        ringdown_backbone(x, fs, noise_rms=5e-5)
    with pytest.raises(InputError, match="too few cycles above the noise"):
        ringdown_backbone(x, fs)                     # the noise estimated from the record's end
    # the same decay, given the noise, keeps only windows above 10 x the noise
    y = damped(t, 1e-3, F0, 0.01) + 2e-6 * rng.standard_normal(t.size)
    b = ringdown_backbone(y, fs, noise_rms=2e-6)
    assert min(b.array("amplitude")) > 10 * 2e-6
    for p in b.points:          # with noise: the true values within 4 standard uncertainties
        assert abs(p.frequency_hz - F0) < 4 * p.frequency_sd_hz + 1e-4
        assert abs(p.damping_ratio - ZETA) < 4 * p.damping_sd + 1e-5


def test_duffing_backbone_follows_the_first_order_closed_form():
    """x'' + 2 zeta w0 x' + w0^2 (x + e x^3) = 0: f(A) = f0 sqrt(1 + 3/4 e A^2) (first
    order; the next term is 3/256 (e A^2)^2 relative), viscous zeta(A) = zeta0 w0 / w(A)."""
    fs, w0, z0, eps, a0 = 3000.0, 2 * np.pi * F0, 0.01, 1e5, 1e-3      # e a0^2 = 0.1
    sol = solve_ivp(lambda t, y: [y[1], -2 * z0 * w0 * y[1] - w0 ** 2 * (y[0] + eps * y[0] ** 3)],
                    (0, 4.0), [a0, 0.0], method="DOP853", rtol=1e-11, atol=1e-15,
                    t_eval=np.arange(int(4.0 * fs)) / fs)
    b = ringdown_backbone(sol.y[0], fs, window_cycles=2)     # a short window: little smoothing bias
    assert {p.method for p in b.points} == {"ringdown_hilbert", "ringdown_peaks"}
    for method, rtol in (("peaks", 6e-4), ("hilbert", 2e-4)):
        # the successive-peaks frequencies scatter more (within their uncertainty)
        pts = by_method(b, method)
        A = np.array([p.amplitude for p in pts])
        expect = F0 * np.sqrt(1 + 0.75 * eps * A ** 2)
        assert np.allclose([p.frequency_hz for p in pts], expect, rtol=rtol)
        assert (expect.max() / F0 - 1) > 0.01           # the hardening is well resolved
        assert np.allclose([p.damping_ratio for p in pts], z0 * F0 / expect, rtol=0.02)


def iwan_ringdown(fs, seconds, a0, m, k_r, k_el, slips, c, substeps=40):
    """Mass on a spring k_r, a dashpot c and Jenkins elements (stiffness k_el each, slip
    displacements ``slips``), released from x = a0 at rest; velocity Verlet with each
    slider's exact return map (force clipped to +-k_el s_i)."""
    dt = 1.0 / (fs * substeps)
    fmax = k_el * np.asarray(slips)
    f_el = np.clip(k_el * a0, -fmax, fmax)                 # virgin loading to a0
    x, v = a0, 0.0
    acc = -(k_r * x + f_el.sum() + c * v) / m
    out = np.empty(int(seconds * fs))
    for i in range(out.size):
        for _ in range(substeps):
            vh = v + 0.5 * dt * acc
            xn = x + dt * vh
            f_el = np.clip(f_el + k_el * (xn - x), -fmax, fmax)
            x = xn
            acc = -(k_r * x + f_el.sum() + c * vh) / m
            v = vh + 0.5 * dt * acc
        out[i] = x
    return out


def jenkins_describing(A, k_el, slip):
    """First harmonic of one Jenkins element's steady loop at amplitude A: in-phase
    stiffness and dissipated energy per cycle (closed form of the piecewise loop)."""
    if A <= slip:
        return k_el, 0.0
    th = np.linspace(0, 2 * np.pi, 20001)[:-1]
    x = A * np.cos(th)
    fs_ = k_el * slip
    f = np.where(th < np.pi, np.maximum(fs_ - k_el * (A - x), -fs_), np.minimum(-fs_ + k_el * (x + A), fs_))
    k_eq = 2 * np.mean(f * np.cos(th)) / A
    return k_eq, 4 * fs_ * (A - slip)


def test_iwan_friction_oscillator_damping_rises_with_amplitude_as_its_describing_function():
    fs, m, k = 1500.0, 1.0, (2 * np.pi * F0) ** 2
    k_r, n_el = 0.8 * k, 8
    k_el = 0.2 * k / n_el
    slips = 1e-5 * np.linspace(1, 8, n_el)
    c = 2 * 0.002 * np.sqrt(k * m)
    x = iwan_ringdown(fs, 4.0, 1.2e-4, m, k_r, k_el, slips, c)
    b = ringdown_backbone(x, fs, methods=("peaks", "hilbert"), noise_rms=1e-12)
    for method in ("peaks", "hilbert"):
        pts = by_method(b, method)
        A = np.array([p.amplitude for p in pts])
        zeta = np.array([p.damping_ratio for p in pts])
        f = np.array([p.frequency_hz for p in pts])
        K = np.empty(A.size)
        W = np.empty(A.size)
        for i, a in enumerate(A):
            parts = [jenkins_describing(a, k_el, s) for s in slips]
            K[i] = k_r + sum(p[0] for p in parts)
            W[i] = sum(p[1] for p in parts)
        w = np.sqrt(K / m)
        assert np.allclose(f, w / (2 * np.pi), rtol=2e-3)
        zeta_expect = W / (2 * np.pi * K * A ** 2) + c / (2 * m * w)
        assert np.allclose(zeta, zeta_expect, rtol=0.06, atol=2e-4)
        low = (A > 1.5e-5) & (A < 6e-5)
        assert np.all(np.diff(zeta[low]) > 0)               # micro-slip: damping rises with A
        assert zeta[low].max() > 3 * zeta.min()


def test_hilbert_and_peaks_are_two_backbones_and_two_measurements(tmp_path):
    """A ringdown's two estimators are two backbones (one per method), so the comparison
    judges them as two measurements, each split in amplitude on its own points."""
    from labjoint.compare.backbone_api import _named
    from labjoint.signal.backbone import save_backbones

    fs = 2000.0
    t = np.arange(int(3 * fs)) / fs
    both = ringdown_backbone(damped(t, 1e-3, F0, ZETA), fs, sensor="tip")
    parts = both.by_method()
    assert [{p.method for p in b.points} for b in parts] == [{"ringdown_hilbert"}, {"ringdown_peaks"}]
    assert sum(len(b.points) for b in parts) == len(both.points)
    for b in parts:          # each alone ascending in amplitude, with the record's notes
        a = b.array("amplitude")
        assert np.all(np.diff(a) > 0) and b.notes == both.notes and b.sensor == "tip"
    save_backbones(tmp_path / "rd.json", parts)
    names = [n for n, *_ in _named([tmp_path / "rd.json"])]
    assert names == ["rd:ringdown_hilbert", "rd:ringdown_peaks"]

"""The hysteresis-loop pipeline of seed 002 on a streamed or in-memory record.

filter (zero-phase Butterworth, seed 002) -> cycle boundaries (phase of the
displacement's fundamental) -> each cycle resampled -> loop quantities per cycle
(:mod:`labjoint.identify.loop`) -> steady-state detection over the per-cycle summary
-> mean and std over steady cycles. Records arrive as blocks of (displacement, force)
and only a chunk plus a cycle is held at a time, so a 10-minute, 50 kS/s record never
sits in memory; per-cycle results (a few hundred bytes a cycle) are kept.
"""

from __future__ import annotations

from itertools import chain
from typing import Any, Iterable, Iterator

import numpy as np

from labjoint.errors import InputError
from labjoint.identify.loop import DEFAULT_STIFFNESS, PER_CYCLE, LoopResult, summarize
from labjoint.identify.loopstream import LoopStream, checked_blocks
from labjoint.identify.plausible import (Plausibility, refuse_far_amplitude, refuse_frequency_mismatch,
                                         refuse_impossible, refuse_unresolved)
from labjoint.identify.resolution import correct_phase, resolution, sensor_phase
from labjoint.signal import validate
from labjoint.signal.clipping import refuse_clipped
from labjoint.signal.cycles import DEFAULT_POINTS
from labjoint.signal.excitation import (Excitation, detect_excitation, detect_streamed,
                                         require_sine)
from labjoint.signal.filter import PAPER_CUTOFF_HZ, PAPER_ORDER, analysis_cutoff
from labjoint.signal.frequency import estimate_frequency
from labjoint.signal.prefetch import helper_pool, prefetch
from labjoint.signal.steady import detect_steady
from labjoint.storage.roles import channel_roles

#: Samples per block when an in-memory record is fed through the streaming pipeline.
BLOCK_SAMPLES = 1 << 18
#: Samples gathered from the start of a record to estimate its frequency.
PROBE_SAMPLES = 1 << 16
#: Named in the refusal of a record that is not a steady sine.
PIPELINE = ("the hysteresis-loop pipeline (labjoint analyze, and fit, diagnose and ladder "
            "on sine records)")
#: Shorter records are left to the cycle checks (too short to tell their excitation).
MIN_DETECT_SAMPLES = 256
#: A cycle is usable when its duration is within these fractions of 1/f.
PERIOD_RANGE = (0.8, 1.25)


def analyze_blocks(blocks: Iterable[Any], fs: float, frequency_hz: float | None = None,
                   cutoff_hz: float | None = PAPER_CUTOFF_HZ, *, order: int = PAPER_ORDER,
                   n_points: int = DEFAULT_POINTS, n_harmonics: int = 5,
                   rel_tol: float = 0.01, min_cycles: int = 3,
                   phase_correction_rad: float = 0.0, phase_uncertainty_rad: float = 0.0,
                   phase_note: str = "", threads: bool = True,
                   plausibility: Plausibility | None = None) -> LoopResult:
    """Hysteresis-loop results of a record given as blocks of (displacement m, force N).

    ``phase_correction_rad`` rotates the force's fundamental (the force sensor's
    calibrated phase lead over the displacement's); ``phase_uncertainty_rad`` is that
    phase's standard uncertainty, propagated into W and C with the noise
    (:mod:`labjoint.identify.resolution`). ``plausibility``: the limits of :mod:`.plausible`
    (None: its defaults). ``threads=False`` keeps the whole pipeline in the calling thread
    (a batch that runs one record per core); by default reading and filtering overlap the
    loop measurements in helper threads.

    Each block is a pair of equal-length 1-D arrays or a (2, n) array. Without
    ``frequency_hz`` the frequency is estimated from the first ``PROBE_SAMPLES``. The
    low-pass cutoff is ``min(cutoff_hz, 0.45 fs)`` (``None``: no filter); the rule
    applied is stated in ``metadata["cutoff_rule"]``.
    """
    fs = validate.sample_rate(fs)
    it = checked_blocks(blocks)
    head: list[np.ndarray] = []
    if frequency_hz is None:
        n = 0
        for blk in it:
            head.append(blk)
            n += blk.shape[1]
            if n >= PROBE_SAMPLES:
                break
        if not head:
            raise InputError("is empty: no samples to analyse", field="blocks")
        probe = np.concatenate([b[0] for b in head])
        try:
            f = estimate_frequency(probe, fs, min_hz=3.0 * fs / probe.size)
        except InputError as exc:
            raise InputError(f"not given, and the first {probe.size} displacement samples "
                             f"give no frequency ({exc.message})", field="frequency_hz") from None
        source = f"estimated from the first {probe.size} samples"
    else:
        f = validate.positive(frequency_hz, "frequency_hz")
        source = "given"
    if f >= fs / 2:
        raise InputError(f"{f:g} Hz is at or above the Nyquist frequency {fs / 2:g} Hz of "
                         f"the {fs:g} Hz sampling", field="frequency_hz")
    cutoff, rule = analysis_cutoff(fs, cutoff_hz)
    refuse_unresolved(f, fs, cutoff, order, plausibility)
    _check_int(min_cycles, "min_cycles", 1)
    _check_int(n_points, "n_points", 8)
    _check_int(n_harmonics, "n_harmonics", 1, n_points // 2 - 1)
    stream = LoopStream(fs, f, cutoff, order, n_points, n_harmonics, threads)
    # two blocks read ahead: the reader keeps up with the filter and the loop kernel on
    # two cores (one ahead left both waiting for it; one more block of memory)
    stream.run(chain(head, prefetch(it, depth=2, threads=threads)))
    per_cycle, bounds = stream.finish()
    if per_cycle:
        correct_phase(per_cycle, float(phase_correction_rad), f)
    return _assemble(per_cycle, bounds, fs, f, rel_tol, min_cycles, float(phase_uncertainty_rad),
                     plausibility, {
        "frequency_source": source, "cutoff_hz": cutoff, "cutoff_rule": rule,
        "filter": (f"zero-phase Butterworth order {order} (sosfiltfilt): -6.02 dB at the "
                   "cutoff (seed 002)" if cutoff is not None else "none"),
        "n_samples": stream.n_samples, "n_points": n_points,
        "phase_correction_deg": float(np.degrees(phase_correction_rad)),
        "phase_uncertainty_deg": float(np.degrees(phase_uncertainty_rad)),
        "phase_note": phase_note or ("no sensor phase correction given; the W resolution "
                                     "holds only the cycle-to-cycle scatter"),
    })


def analyze_arrays(displacement: np.ndarray, force: np.ndarray, fs: float,
                   frequency_hz: float | None = None,
                   cutoff_hz: float | None = PAPER_CUTOFF_HZ, *,
                   excitation: np.ndarray | None = None, **kwargs: Any) -> LoopResult:
    """:func:`analyze_blocks` on in-memory arrays, record means removed first.

    ``excitation``: the signal the excitation is detected from (the drive or reference
    force), by default ``force``.
    """
    u = validate.signal(displacement, "displacement", min_samples=2)
    F = validate.signal(force, "force", min_samples=2)
    validate.same_length(F, u, "force", "displacement")
    if F.size >= MIN_DETECT_SAMPLES:
        x = F if excitation is None else validate.signal(excitation, "excitation")
        require_sine(detect_excitation(x, fs), PIPELINE)
    u = u - u.mean()
    F = F - F.mean()
    blocks = (np.stack([u[i:i + BLOCK_SAMPLES], F[i:i + BLOCK_SAMPLES]])
              for i in range(0, u.size, BLOCK_SAMPLES))
    return analyze_blocks(blocks, fs, frequency_hz, cutoff_hz, **kwargs)


def analyze_run(run: Any, frequency_hz: float | None = None,
                cutoff_hz: float | None = PAPER_CUTOFF_HZ, **kwargs: Any) -> LoopResult:
    """:func:`analyze_arrays` on a :class:`labjoint.storage.run.Run` (SI units).

    The frequency comes from ``frequency_hz``, else the run's metadata, else is estimated.
    """
    f = frequency_hz if frequency_hz is not None else run.frequency_hz
    if len(run.time) < 2:
        raise InputError(f"has {len(run.time)} samples; a run needs at least 2", field="time")
    if len(run.time) != len(run.displacement):
        raise InputError(f"has {len(run.time)} samples but displacement has "
                         f"{len(run.displacement)}", field="time")
    inst = run.metadata.get("phase_uncertainty_deg")
    if inst and "phase_uncertainty_rad" not in kwargs:
        kwargs["phase_uncertainty_rad"] = float(np.radians(float(inst)))
        kwargs.setdefault("phase_note", f"instrument phase match +- {inst} deg (run metadata)")
    result = analyze_arrays(run.displacement, run.force, run.sample_rate_hz, f, cutoff_hz,
                            excitation=run.excitation, **kwargs)
    result.metadata["run"] = run.name
    return result


def _check_int(value: Any, name: str, lo: int, hi: int | None = None) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
            or value < lo or (hi is not None and value > hi):
        span = f">= {lo}" if hi is None else f"from {lo} to {hi}"
        raise InputError(f"must be an integer {span}, got {value!r}", field=name)


def _assemble(per_cycle: dict[str, np.ndarray], bounds: np.ndarray, fs: float, f: float,
              rel_tol: float, min_cycles: int, phase_u: float, plausibility: Plausibility | None,
              meta: dict[str, Any]) -> LoopResult:
    n = per_cycle["energy_loss"].size if per_cycle else 0
    if n < min_cycles:
        raise InputError(f"has {n} complete cycles at {f:g} Hz ({meta['n_samples']} "
                         f"samples at {fs:g} Hz); at least {min_cycles} are needed",
                         field="displacement")
    duration = np.diff(bounds) * f / fs
    valid = ((duration >= PERIOD_RANGE[0]) & (duration <= PERIOD_RANGE[1])
             & (per_cycle["displacement_amplitude"] > 0))
    if int(valid.sum()) < min_cycles:
        raise InputError(f"has only {int(valid.sum())} usable cycles of {n} (duration "
                         f"within {PERIOD_RANGE} periods, non-zero amplitude); at least "
                         f"{min_cycles} are needed", field="displacement")
    u_med = float(np.median(per_cycle["displacement_amplitude"][valid]))
    refuse_far_amplitude({"displacement_amplitude_m": u_med}, plausibility)  # before any U^2
    phase = np.angle(per_cycle["force_harmonics"][:, 0]
                     * np.conj(per_cycle["displacement_harmonics"][:, 0]))
    steady = detect_steady(per_cycle["displacement_amplitude"], per_cycle["force_amplitude"],
                           phase, rel_tol=rel_tol, valid=valid)
    result = LoopResult(frequency_hz=f, sample_rate_hz=fs, bounds=bounds, valid=valid,
                        steady=steady.mask, steady_state=steady,
                        **{k: per_cycle[k] for k in PER_CYCLE})
    result.summary = summarize(result)
    u_w, below, extra = resolution(result.energy_loss, result.force_harmonics[:, 0],
                                   result.displacement_harmonics[:, 0], result.steady, phase_u)
    result.energy_loss_uncertainty, result.below_resolution = u_w, below
    u_amp = result.summary["displacement_amplitude_m"]
    extra["damping_ns_per_m_uncertainty"] = extra["energy_loss_j_uncertainty"] / (
        np.pi * 2 * np.pi * f * u_amp ** 2) if u_amp > 0 else float("nan")
    result.summary.update(extra)
    refuse_impossible(result.summary, plausibility)
    span = bounds[steady.stop] - bounds[steady.start]
    measured = float(fs * (steady.stop - steady.start) / span) if span > 0 else float("nan")
    refuse_frequency_mismatch(f, measured, meta["frequency_source"], plausibility)
    warnings = [f"only {steady.n_steady} of {n} cycles are steady"] if steady.n_steady < 0.5 * n else []
    result.metadata = {
        **meta, "frequency_measured_hz": measured,
        "amplitude_estimator": "half peak-to-peak of the filtered cycle",
        "stiffness_estimator": DEFAULT_STIFFNESS, "rel_tol": rel_tol,
        "mean_removal": ("record means removed; every estimator is offset-invariant, so "
                         "streamed blocks need no record mean"),
        "n_cycles": n, "n_valid": int(valid.sum()), "steady_start": steady.start,
        "steady_stop": steady.stop, "steady_window": steady.window,
        "steady_noise": steady.noise, "steady_note": steady.note, "warnings": warnings,
    }
    return result


FILE_BLOCK_SAMPLES = 1 << 18
#: Run metadata copied into a file analysis's result metadata.
RUN_KEYS = ("excitation_vpp", "torque_nm", "normal_force_n", "plan", "plan_step", "status")


def analyze_file(path: Any, force: str = "joint", frequency_hz: float | None = None,
                 cutoff_hz: float | None = PAPER_CUTOFF_HZ, threads: bool = True,
                 **kwargs: Any) -> LoopResult:
    """:func:`analyze_blocks` streamed from a run file, so memory stays bounded.

    Displacement is ``disp_1 - disp_2`` (or the single imported ``displacement``
    channel), force the joint sensor (``force="joint"``) or the reference sensor.
    ``threads=False``: the excitation check, reading and filtering in this thread too.
    """
    from labjoint.storage import open_run

    with open_run(path) as rf:
        roles = channel_roles(rf.metadata, rf.channel_names)
        disp, fch = roles.require(force, str(rf.path))
        f = frequency_hz if frequency_hz is not None else rf.frequency_hz
        step = FILE_BLOCK_SAMPLES
        ref = roles.reference_force
        xch = ref if ref in rf.channel_names else fch

        def check_excitation(found: Excitation) -> None:
            require_sine(found, PIPELINE, f"run {rf.name} ({xch})")

        def blocks() -> Iterator[np.ndarray]:
            other = np.empty(min(step, rf.n_samples))       # the second displacement
            for a in range(0, rf.n_samples, step):
                if detected.done():                        # refuse as soon as it is known
                    check_excitation(detected.result())
                b = min(a + step, rf.n_samples)
                blk = np.empty((2, b - a))
                rf.physical(disp[0], a, b, out=blk[0])
                if len(disp) == 2:      # a clipped probe does not show in the difference
                    o = rf.physical(disp[1], a, b, out=other[:b - a])
                    refuse_clipped(blk[0], disp[0]), refuse_clipped(o, disp[1])
                    blk[0] -= o
                rf.physical(fch, a, b, out=blk[1])
                yield blk

        if "phase_correction_rad" not in kwargs and f is not None:
            delta, u, note = sensor_phase(rf.channel(fch), [rf.channel(c) for c in disp], f,
                                          rf.metadata.get("phase_uncertainty_deg"))
            kwargs.update(phase_correction_rad=delta, phase_uncertainty_rad=u, phase_note=note)
        # the excitation is identified alongside the analysis (its spectra overlap the
        # filtering); a record that is not a steady sine is refused either way, and its
        # refusal takes precedence over any error the analysis ran into
        with helper_pool(threads, "labjoint-detect") as pool:
            detected = pool.submit(detect_streamed, lambda a, b: rf.physical(xch, a, b),
                                   rf.n_samples, rf.sample_rate_hz, rf.metadata)
            try:
                result = analyze_blocks(blocks(), rf.sample_rate_hz, f, cutoff_hz,
                                        threads=threads, **kwargs)
            except InputError:
                check_excitation(detected.result())
                raise
            check_excitation(detected.result())
        result.metadata.update(run=rf.name, path=str(rf.path), force_channel=fch,
                               **{k: rf.metadata.get(k) for k in RUN_KEYS if k in rf.metadata})
        return result

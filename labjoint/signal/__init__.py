"""Signal conditioning: zero-phase low-pass (seed 002), frequency, cycles, steady state.

Everything works on numpy arrays (SI units); the streaming classes take blocks so a
record never has to be held whole.
"""

from labjoint.signal.cycles import cycles, harmonics
from labjoint.signal.filter import ZeroPhaseStream, analysis_cutoff, butter_sos, lowpass
from labjoint.signal.frequency import estimate_frequency
from labjoint.signal.phase import CycleSegmenter, segment_cycles
from labjoint.signal.steady import SteadyState, detect_steady

__all__ = ["CycleSegmenter", "SteadyState", "ZeroPhaseStream", "analysis_cutoff",
           "butter_sos", "cycles", "detect_steady", "estimate_frequency", "harmonics",
           "lowpass", "segment_cycles"]

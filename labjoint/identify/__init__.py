"""Identification from measured runs: the hysteresis-loop pipeline of seed 002 here;
stick-slip boundary, friction and calibration in their own modules.
"""

from labjoint.identify.analyze import analyze_arrays, analyze_blocks, analyze_run
from labjoint.identify.loop import LoopResult

__all__ = ["LoopResult", "analyze_arrays", "analyze_blocks", "analyze_run"]

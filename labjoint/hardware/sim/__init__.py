"""Physics-based simulated rigs: seed 002's bolted lap joint (the default) and, with
``[sim] rig = "structure"``, seed 000's pipe assembly on a shaker (:mod:`.structure_rig`).

Entry points: :func:`open_sim` (generator, DAQ, rig from a rig config), :class:`SimRig`,
:class:`SimDAQ`, :class:`MemoryGenerator`, :class:`SimConfig`.
"""

from labjoint.hardware.sim.config import SimConfig
from labjoint.hardware.sim.devices import MemoryGenerator, SimDAQ, open_sim
from labjoint.hardware.sim.rig import SimRig, TrueState
from labjoint.hardware.sim.sensors import nanocomposite_true_factor

__all__ = ["MemoryGenerator", "SimConfig", "SimDAQ", "SimRig", "TrueState", "nanocomposite_true_factor", "open_sim"]

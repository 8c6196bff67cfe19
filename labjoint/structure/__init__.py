"""Structures: 1-D beam finite elements with joints whose tangential law is any effect of
:mod:`labjoint.models`, modal analysis and stage-1 updating, Craig-Bampton reduction,
harmonic balance with continuation, and time integration (seed 000).

Typical use::

    from labjoint.structure import load_structure, modes, update_stiffness
    s = load_structure("configs/structure-seed000.toml")
    modes(s, 2).frequencies_hz
    update_stiffness(s, [28.5, 177.0]).value
"""

from labjoint.structure.assembly import Structure
from labjoint.structure.config import load_structure, structure_from_dict
from labjoint.structure.law import JointLaw
from labjoint.structure.modal import Modes, UpdateResult, modes, update_stiffness

__all__ = ["Structure", "load_structure", "structure_from_dict", "JointLaw", "Modes",
           "UpdateResult", "modes", "update_stiffness"]

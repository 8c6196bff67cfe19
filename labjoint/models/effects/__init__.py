"""Registry of the joint-model effects, one class per vocabulary name.

>>> sorted(REGISTRY) == sorted(EFFECTS)
True
>>> get_effect("iwan").param_names
('F_S', 'K_T', 'chi', 'beta')
"""

from __future__ import annotations

from labjoint.errors import InputError
from labjoint.models.effects.backlash import Backlash
from labjoint.models.effects.base import (
    Effect,
    ElasticEffect,
    ForceEffect,
    HystereticEffect,
    InputEffect,
    ModifierEffect,
    SlipModifiers,
)
from labjoint.models.effects.bouc_wen import BoucWen
from labjoint.models.effects.coulomb import Coulomb
from labjoint.models.effects.delay import ChannelDelay
from labjoint.models.effects.elastic import CubicStiffness, LinearStiffness, Offset
from labjoint.models.effects.even import BilinearStiffness, Contact, QuadraticStiffness
from labjoint.models.effects.inertia import Inertia
from labjoint.models.effects.iwan import Iwan
from labjoint.models.effects.modifiers import AsymmetricSlip, Wear
from labjoint.models.effects.richard_abbott import RichardAbbott
from labjoint.models.effects.saturating import SaturatingStiffness
from labjoint.models.effects.valanis import Valanis
from labjoint.models.effects.viscous import Viscous
from labjoint.vocabulary import EFFECTS

REGISTRY: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (LinearStiffness, Viscous, Coulomb, Iwan, BoucWen, Valanis, RichardAbbott,
                CubicStiffness, QuadraticStiffness, BilinearStiffness, Contact, SaturatingStiffness,
                Offset, AsymmetricSlip, Inertia, Wear, Backlash, ChannelDelay)
}
assert set(REGISTRY) == set(EFFECTS), "every vocabulary effect needs exactly one class"


def get_effect(name: str) -> Effect:
    """A new instance of the effect called ``name``; InputError lists the vocabulary."""
    key = name.strip()
    if key not in REGISTRY:
        raise InputError(f"unknown effect '{key}'; the vocabulary is: {', '.join(EFFECTS)}",
                         field="model")
    return REGISTRY[key]()


__all__ = ["REGISTRY", "get_effect", "Effect", "ElasticEffect", "ForceEffect", "HystereticEffect",
           "ModifierEffect", "InputEffect", "SlipModifiers"]

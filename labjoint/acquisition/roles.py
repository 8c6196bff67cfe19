"""Which DAQ channel plays which part: displacement, joint force, reference force."""

from __future__ import annotations

from typing import Any

import numpy as np

from labjoint.config import RigConfig
from labjoint.errors import ConfigError
from labjoint.hardware.interfaces import ChannelSpec


def engine_roles(channels: list[ChannelSpec], config: RigConfig | None, simulated: bool
                 ) -> dict[str, Any]:
    """Displacement, joint-force and reference-force channel names and the backend: from
    the config (each must be a DAQ channel), else inferred from the channels' quantities
    and sensors."""
    names = [c.name for c in channels]
    if config is not None:
        r = config.rig
        roles = {"displacement_channels": list(r.displacement_channels),
                 "joint_force_channel": r.joint_force_channel or None,
                 "reference_force_channel": r.reference_force_channel,
                 "rig_backend": r.backend}
        for key in ("displacement_channels", "joint_force_channel", "reference_force_channel"):
            for n in np.atleast_1d(roles[key]):
                if n is not None and n not in names:
                    raise ConfigError(f"channel {n!r} is not among the DAQ channels {names}",
                                      file=config.source or None, field=f"rig.{key}")
        return roles
    return {"displacement_channels": [c.name for c in channels if c.quantity == "displacement"],
            "joint_force_channel": next((c.name for c in channels if c.sensor == "nanocomposite"), None),
            "reference_force_channel": next((c.name for c in channels if c.sensor == "force"), None),
            "rig_backend": "sim" if simulated else "real"}

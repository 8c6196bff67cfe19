"""Which channels of a run hold the relative displacement, the joint force and the
reference (drive) force: the one place these rules live.

Rules, from the run's metadata first: ``displacement_channels`` (two: their difference,
``disp_1 - disp_2`` on seed 002's rig; one: as is), else a ``displacement`` channel
(an imported CSV), else ``disp_1``/``disp_2``; the joint force is ``joint_force_channel``,
else ``force`` (imported) or ``shear_nc`` (the nanocomposite sensor); the reference force
``reference_force_channel``, else ``force_ref``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable

from labjoint.errors import InputError, NotApplicable

FORCE_CHOICES = ("joint", "reference")


@dataclass(frozen=True)
class ChannelRoles:
    """Channel names by role; ``force(kind)`` picks the joint or the reference sensor.

    >>> r = channel_roles({}, ["force_ref", "disp_1", "disp_2", "shear_nc"])
    >>> r.displacement, r.joint_force, r.reference_force
    (['disp_1', 'disp_2'], 'shear_nc', 'force_ref')
    >>> channel_roles({}, ["time_s", "displacement", "force"]).force("joint")
    'force'
    """

    displacement: list[str]
    joint_force: str
    reference_force: str
    names: tuple[str, ...]

    def force(self, kind: str = "joint") -> str:
        """The joint (interface) or the reference (drive) force channel."""
        if kind not in FORCE_CHOICES:
            raise InputError(f"force must be 'joint' or 'reference', got {kind!r}", field="force")
        return self.joint_force if kind == "joint" else self.reference_force

    def require(self, kind: str = "joint", source: str | None = None) -> tuple[list[str], str]:
        """Displacement channel(s) and the ``kind`` force channel, all present, or an error
        naming the missing channel (and ``source``, the file)."""
        fch = self.force(kind)
        if not self.displacement:
            raise NotApplicable("run has no displacement channel (an accelerometer-only "
                                f"record?); channels: {list(self.names)}", file=source,
                                field="displacement_channels")
        if len(self.displacement) not in (1, 2):
            raise InputError("displacement_channels must name one or two channels",
                             file=source, field="displacement_channels")
        for c in [*self.displacement, fch]:
            if c not in self.names:
                raise NotApplicable(f"run has no channel {c!r}; channels: {list(self.names)}",
                                 file=source, field=c)
        return list(self.displacement), fch

    @property
    def present(self) -> dict[str, list[str]]:
        """Role -> channels that exist (empty where a role has none)."""
        ok = 1 <= len(self.displacement) <= 2 and all(c in self.names for c in self.displacement)
        return {"displacement": list(self.displacement) if ok else [],
                "force": [self.joint_force] if self.joint_force in self.names else [],
                "reference_force": ([self.reference_force]
                                    if self.reference_force in self.names else [])}


def channel_roles(metadata: dict[str, Any], channel_names: Iterable[str]) -> ChannelRoles:
    """The roles of ``channel_names`` under the rules of the module doc."""
    names = tuple(str(c) for c in channel_names)
    if "displacement_channels" in metadata:
        disp = [str(c) for c in metadata["displacement_channels"]]
    elif "displacement" in names:
        disp = ["displacement"]
    else:
        disp = ["disp_1", "disp_2"]
    joint = metadata.get("joint_force_channel") or ("force" if "force" in names else "shear_nc")
    reference = metadata.get("reference_force_channel") or "force_ref"
    return ChannelRoles(disp, str(joint), str(reference), names)

"""Which channels of a run hold the relative displacement, the joint force and the
reference (drive) force: the one place these rules live.

Rules, from the run's metadata first: ``displacement_channels`` (two: their difference,
``disp_1 - disp_2`` on seed 002's rig; one: as is), else a ``displacement`` channel
(an imported CSV), else ``disp_1``/``disp_2``; the joint force is ``joint_force_channel``,
else ``force`` (imported) or ``shear_nc`` (the nanocomposite sensor); the reference force
``reference_force_channel``, else ``force_ref``.

Drives and responses (any number of each): ``drive_channels`` and ``response_channels``
of the metadata (every imported or newly written run lists them), else, for older files,
from the rules above and each channel's stored quantity (``channel_quantities``): the
drives are the reference force (or, without one, the joint force) and every voltage
channel; the responses every motion channel and a joint force that is not the drive.
A voltage is never a force: a force role that names a voltage channel, or a run whose
only drive is a voltage, is refused with one line naming the channel.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterable

from labjoint.errors import InputError

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
    quantities: dict[str, str] = field(default_factory=dict)
    drives: tuple[str, ...] = ()
    responses: tuple[str, ...] = ()

    def role(self, channel: str) -> str:
        """``drive``, ``response`` or ``other``."""
        return "drive" if channel in self.drives else \
            "response" if channel in self.responses else "other"

    def force(self, kind: str = "joint") -> str:
        """The joint (interface) or the reference (drive) force channel."""
        if kind not in FORCE_CHOICES:
            raise InputError(f"force must be 'joint' or 'reference', got {kind!r}", field="force")
        return self.joint_force if kind == "joint" else self.reference_force

    def require(self, kind: str = "joint", source: str | None = None) -> tuple[list[str], str]:
        """Displacement channel(s) and the ``kind`` force channel, all present, or an error
        naming the missing channel (and ``source``, the file)."""
        fch = self.force(kind)
        q = self.quantities
        if q and (fch not in self.names or q.get(fch) == "voltage"):
            volts = [c for c in self.drives if q.get(c) == "voltage"] or \
                [c for c in self.names if q.get(c) == "voltage"]
            if fch not in self.names and not any(q.get(c) == "force" for c in self.names) and volts:
                raise InputError(f"no force channel: the drive is a voltage ({', '.join(volts)}), "
                                 "never used as a force; this pipeline needs a measured force",
                                 file=source, field=volts[0])
            if q.get(fch) == "voltage":
                raise InputError(f"no force channel: {fch!r} is a voltage, never used as a force",
                                 file=source, field=fch)
        if q and not any(c in self.names for c in self.displacement):
            motion = [f"{c} ({q[c]})" for c in self.names if q.get(c) in ("velocity", "acceleration")]
            if motion:
                raise InputError("no displacement channel: the responses are "
                                 f"{', '.join(motion)}; this pipeline needs the relative "
                                 "displacement across the joint", file=source,
                                 field=self.displacement[0] if self.displacement else "displacement")
        for c in self.displacement:
            if q and c in self.names and q.get(c) not in (None, "displacement"):
                raise InputError(f"channel {c!r} is a {q[c]}, not a displacement; this pipeline "
                                 "needs a relative displacement", file=source, field=c)
        if len(self.displacement) not in (1, 2):
            raise InputError("displacement_channels must name one or two channels",
                             file=source, field="displacement_channels")
        for c in [*self.displacement, fch]:
            if c not in self.names:
                raise InputError(f"run has no channel {c!r}; channels: {list(self.names)}",
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
    quantities = {str(k): str(v) for k, v in (metadata.get("channel_quantities") or {}).items()}
    drives, responses = drive_response(metadata, names, quantities, str(joint), str(reference))
    return ChannelRoles(disp, str(joint), str(reference), names, quantities, drives, responses)


def drive_response(metadata: dict[str, Any], names: tuple[str, ...], quantities: dict[str, str],
                   joint: str, reference: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Drive and response channels: the metadata's lists, else the module doc's rules.

    >>> drive_response({}, ("force_ref", "disp_1", "shear_nc"), {"force_ref": "force",
    ...                 "disp_1": "displacement", "shear_nc": "force"}, "shear_nc", "force_ref")
    (('force_ref',), ('disp_1', 'shear_nc'))
    """
    if "drive_channels" in metadata or "response_channels" in metadata:
        return (tuple(str(c) for c in metadata.get("drive_channels") or ()),
                tuple(str(c) for c in metadata.get("response_channels") or ()))
    force_drive = reference if reference in names else joint if joint in names else None
    drives = [c for c in names if c == force_drive or quantities.get(c) == "voltage"]
    motion = ("displacement", "velocity", "acceleration")
    responses = [c for c in names if c not in drives
                 and (quantities.get(c) in motion or c == joint)]
    return tuple(drives), tuple(responses)

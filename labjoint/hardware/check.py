"""``labjoint hw check``: which instruments and DAQ devices this machine can see, and
whether the configured rig is ready (``ok``; the CLI exits 3 when not).

:func:`hardware_check` returns plain data (the CLI prints it, or its JSON);
:func:`format_check` renders it for a terminal. Nothing here changes an instrument's
state: the generator is only identified (device clear, ``*IDN?``, amplitude unit pinned
to Vpp, ``OUTPut<n>:IMPedance?`` probed) and its session released with the outputs
untouched. On the real backend the DAQ channels are checked against the module (IEPE,
coupling, range) and the drive limits against its flat band. What is left for the
operator to confirm on the front panels: docs/bench-bringup.md.
"""

from __future__ import annotations

from typing import Any

import pyvisa

from labjoint.errors import LabjointError
from labjoint.hardware.afg1022 import AFG1022, resolve_visa_library

NO_NIDAQMX = ("NI-DAQmx driver not installed (the nidaqmx Python package is, but not NI's "
              "C library: install NI-DAQmx, e.g. `python -m nidaqmx installdriver`)")


def hardware_check(config: Any = None) -> dict[str, Any]:
    """Probe VISA backends, the configured generator and NI-DAQmx; return plain data.

    ``config`` is a :class:`labjoint.config.RigConfig` (or anything with the same
    ``generator`` and ``daq`` attributes); without it only the backends are listed.
    """
    gen = getattr(config, "generator", None)
    daq = getattr(config, "daq", None)
    result: dict[str, Any] = {"visa": [_visa_backend("")]}
    sim_lib = getattr(gen, "visa_library", "") or ""
    if sim_lib.endswith("@sim"):
        result["visa"].append(_visa_backend(sim_lib))
    real = getattr(getattr(config, "rig", None), "backend", "real") == "real"
    result["generator"] = _generator(gen) if gen is not None else None
    if result["generator"] is not None and not real and not sim_lib.endswith("@sim"):
        result["generator"]["needed"] = False  # the simulated rig's in-memory generator
    result["nidaqmx"] = _nidaqmx_status()
    if daq is not None:
        result["daq"] = _daq_match(daq, result["nidaqmx"])
        if real:
            result["daq"]["config_error"] = _daq_config(daq, getattr(config, "limits", None))
    result["problems"] = _problems(result, real)
    result["ok"] = not result["problems"]
    return result


def _problems(result: dict[str, Any], real: bool) -> list[str]:
    """What keeps the configured rig from running: an unreachable generator; on the real
    backend a configured DAQ module not found (the simulated rig has its own DAQ)."""
    out = []
    g = result.get("generator")
    if g is not None and not g["reachable"] and g.get("needed", True):
        err = g["error"] or ""
        out.append(f"the generator {err}" if "not reachable" in err else
                   f"the generator {g['resource']} is not reachable: {err}")
    d = result.get("daq")
    if real and d is not None and d["found"] is not True:
        why = "NI-DAQmx is not installed" if d["found"] is None else "no such device"
        out.append(f"the DAQ {d['module']} at {d['device']} is not found ({why})")
    if real and d is not None and d.get("config_error"):
        out.append(f"the DAQ config: {d['config_error']}")
    return out


def _daq_config(daq: Any, limits: Any) -> str | None:
    """Why the configured channels or drive limits do not suit the module (None if they do)."""
    from labjoint.hardware.nidaq import check_channels, check_drive_band

    try:
        check_channels(daq.module, daq.specs())
        if limits is not None:
            check_drive_band(daq.module, daq.specs(), daq.sample_rate_hz,
                             limits.min_frequency_hz, limits.max_frequency_hz)
    except LabjointError as exc:
        return str(exc)
    return None


def _visa_backend(visa_library: str) -> dict[str, Any]:
    entry: dict[str, Any] = {"library": visa_library or "(default)", "available": False,
                             "resources": [], "error": None}
    try:
        lib = resolve_visa_library(visa_library)
        rm = pyvisa.ResourceManager(lib)
        entry["resources"] = list(rm.list_resources())
        entry["available"] = True
    except LabjointError as exc:
        entry["error"] = str(exc)
    except pyvisa.errors.VisaIOError as exc:  # e.g. no resources found
        entry["available"] = True
        if exc.error_code != pyvisa.constants.StatusCode.error_resource_not_found:
            entry["error"] = str(exc)
    except Exception as exc:  # no VISA library, or a backend failing (pyvisa-py: ValueError)
        entry["error"] = f"no usable VISA library: {type(exc).__name__}: {exc}"
    return entry


def _generator(gen: Any) -> dict[str, Any]:
    entry: dict[str, Any] = {"resource": gen.resource, "visa_library": gen.visa_library or "(default)",
                             "simulated": (gen.visa_library or "").endswith("@sim"),
                             "reachable": False, "idn": None, "error": None,
                             "load": getattr(gen, "load", "INF"), "load_settable": None}
    drv = AFG1022(gen.resource, gen.visa_library, gen.timeout_ms, gen.channel,
                  load=entry["load"])
    try:
        drv.connect()
        entry["idn"] = drv.identify()
        entry["reachable"], entry["load_settable"] = True, drv.load_settable
    except LabjointError as exc:
        entry["error"] = str(exc)
    except Exception as exc:  # whatever a VISA backend raises: reported, never a traceback
        entry["error"] = f"{gen.resource} not reachable: {type(exc).__name__}: {exc}"
    finally:
        drv.release()
    return entry


def _nidaqmx_status() -> dict[str, Any]:
    entry: dict[str, Any] = {"driver_installed": False, "driver_version": None,
                             "devices": [], "message": None}
    try:
        import nidaqmx.errors
        import nidaqmx.system
    except ImportError as exc:
        entry["message"] = f"nidaqmx Python package not installed ({exc})"
        return entry
    try:
        system = nidaqmx.system.System.local()
        v = system.driver_version
        entry["driver_version"] = f"{v.major_version}.{v.minor_version}.{v.update_version}"
        entry["driver_installed"] = True
        entry["devices"] = [{"name": d.name, "product_type": d.product_type,
                             "serial": f"{d.dev_serial_num:X}" if d.dev_serial_num else ""}
                            for d in system.devices]
        entry["message"] = (f"NI-DAQmx {entry['driver_version']}, "
                            f"{len(entry['devices'])} device(s)")
    except nidaqmx.errors.DaqNotFoundError:
        entry["message"] = NO_NIDAQMX
    except nidaqmx.errors.Error as exc:
        entry["message"] = f"NI-DAQmx error: {exc}"
    return entry


def _daq_match(daq: Any, status: dict[str, Any]) -> dict[str, Any]:
    found = [d for d in status["devices"] if d["name"] == daq.device]
    entry: dict[str, Any] = {"device": daq.device, "module": daq.module,
                             "found": bool(found) if status["driver_installed"] else None,
                             "product_type": found[0]["product_type"] if found else None}
    if found and found[0]["product_type"] != daq.module:
        entry["warning"] = (f"{daq.device} is a {found[0]['product_type']}, "
                            f"config says {daq.module}")
    return entry


def format_check(result: dict[str, Any]) -> str:
    """Render :func:`hardware_check`'s result as plain lines for a terminal."""
    lines = ["VISA"]
    for b in result.get("visa", []):
        if b["available"]:
            res = ", ".join(b["resources"]) or "no instruments found"
            lines.append(f"  {b['library']}: {res}")
        else:
            lines.append(f"  {b['library']}: unavailable ({b['error']})")
    g = result.get("generator")
    if g is not None:
        kind = "simulated" if g["simulated"] else "real"
        lines.append(f"Function generator ({kind}) {g['resource']}")
        if g.get("needed") is False:
            lines.append("  not used: the simulated rig's in-memory generator drives it")
        elif g["reachable"]:
            lines.append(f"  {g['idn']}")
            lines.append(f"  load {g['load']}: " + ("set over VISA" if g["load_settable"] else
                         "OUTPut:IMPedance not supported, set it on the front panel"))
        else:
            lines.append(f"  {g['error']}" if "not reachable" in (g["error"] or "")
                         else f"  not reachable: {g['error']}")
    n = result["nidaqmx"]
    lines.append("NI-DAQmx")
    lines.append(f"  {n['message']}")
    for d in n["devices"]:
        lines.append(f"  {d['name']}: {d['product_type']} {d['serial']}".rstrip())
    d = result.get("daq")
    if d is not None:
        state = {None: "cannot look for it without the driver", True: "found",
                 False: "not found"}[d["found"]]
        lines.append(f"  configured {d['module']} at {d['device']}: {state}")
        if d.get("warning"):
            lines.append(f"  warning: {d['warning']}")
        if d.get("config_error"):
            lines.append(f"  config: {d['config_error']}")
    if "ok" in result:
        lines.append("ready: every configured instrument answers" if result["ok"] else
                     "NOT READY: " + "; ".join(result["problems"]))
    return "\n".join(lines)

"""``labjoint hw check``: which instruments and DAQ devices this machine can see.

:func:`hardware_check` returns plain data (the CLI prints it, or its JSON);
:func:`format_check` renders it for a terminal. Nothing here changes an instrument's
state: the generator is only asked ``*IDN?`` and its session released with the output
untouched.
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
    result["generator"] = _generator(gen) if gen is not None else None
    result["nidaqmx"] = _nidaqmx_status()
    if daq is not None:
        result["daq"] = _daq_match(daq, result["nidaqmx"])
    real = getattr(getattr(config, "rig", None), "backend", "real") == "real"
    result["problems"] = _problems(result, real)
    result["ok"] = not result["problems"]
    return result


def _problems(result: dict[str, Any], real: bool) -> list[str]:
    """What keeps the configured rig from running: an unreachable generator; on the real
    backend a configured DAQ module not found (the simulated rig has its own DAQ)."""
    out = []
    g = result.get("generator")
    if g is not None and not g["reachable"]:
        out.append(f"the generator {g['resource']} is not reachable: {g['error']}")
    d = result.get("daq")
    if real and d is not None and d["found"] is not True:
        why = "NI-DAQmx is not installed" if d["found"] is None else "no such device"
        out.append(f"the DAQ {d['module']} at {d['device']} is not found ({why})")
    return out


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
    except (ValueError, OSError) as exc:  # no VISA library installed, or it failed to load
        entry["error"] = f"no usable VISA library: {exc}"
    except pyvisa.errors.VisaIOError as exc:  # e.g. no resources found
        entry["available"] = True
        if exc.error_code != pyvisa.constants.StatusCode.error_resource_not_found:
            entry["error"] = str(exc)
    return entry


def _generator(gen: Any) -> dict[str, Any]:
    entry: dict[str, Any] = {"resource": gen.resource, "visa_library": gen.visa_library or "(default)",
                             "simulated": (gen.visa_library or "").endswith("@sim"),
                             "reachable": False, "idn": None, "error": None}
    drv = AFG1022(gen.resource, gen.visa_library, gen.timeout_ms, gen.channel)
    try:
        drv.connect()
        entry["idn"] = drv.identify()
        entry["reachable"] = True
    except LabjointError as exc:
        entry["error"] = str(exc)
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
        lines.append(f"  {g['idn']}" if g["reachable"] else f"  not reachable: {g['error']}")
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
    if "ok" in result:
        lines.append("ready: every configured instrument answers" if result["ok"] else
                     "NOT READY: " + "; ".join(result["problems"]))
    return "\n".join(lines)

"""Exception types shared by every layer."""

from __future__ import annotations


class LabjointError(Exception):
    """Base class of every error labjoint raises on purpose."""


class InputError(LabjointError, ValueError):
    """Bad input: a file, request, config or parameter.

    The message names what is wrong and, where known, the file, line, column or field.
    """

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        line: int | None = None,
        column: str | None = None,
        field: str | None = None,
    ) -> None:
        self.message = message
        self.file = None if file is None else str(file)
        self.line = line
        self.column = column
        self.field = field
        super().__init__(str(self))

    def __str__(self) -> str:
        where = []
        if self.file is not None:
            where.append(self.file + (f":{self.line}" if self.line is not None else ""))
        elif self.line is not None:
            where.append(f"line {self.line}")
        if self.column is not None:
            where.append(f"column '{self.column}'")
        if self.field is not None:
            where.append(f"'{self.field}'")
        return (", ".join(where) + ": " if where else "") + self.message


class NotApplicable(InputError):
    """The run is sound but not what the pipeline handles (not a steady sine, no
    displacement sensor): a reprocess counts it as "not applicable", not as a failure."""


class ConfigError(InputError):
    """A configuration file or value is invalid."""


class HardwareError(LabjointError):
    """An instrument failed, timed out or disconnected."""


class InstrumentTimeout(HardwareError):
    """An instrument did not answer in time."""


class BufferOverrun(HardwareError):
    """The DAQ buffer overflowed: samples were lost."""


class LimitExceeded(LabjointError):
    """A safety limit (amplitude, frequency, displacement, force) was exceeded."""

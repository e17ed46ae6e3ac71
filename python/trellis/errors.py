"""Errors raised by Trellis, with the library's messages (the same as the CLI's)."""


class TrellisError(Exception):
    """Any error reported by the library. `file`, `line` and `element` say where, when known."""

    def __init__(self, message, file="", line=0, element=""):
        super().__init__(message)
        self.file = file
        self.line = line
        self.element = element


class InputError(TrellisError):
    """A malformed or unreadable input file (lattice, design, mesh, toolpath, G-code, profile)."""


class SettingError(TrellisError, ValueError):
    """An unknown setting or keyword, a wrong type, a value out of range, a broken rule."""


class GeometryError(TrellisError):
    """Input that parses but cannot be planned, sliced or written."""


class MachineError(TrellisError):
    """The output would not print as meant on the machine: outside the bed, a tool or mixing
    hotend it lacks, a bath route on an in-air machine, a temperature, speed or power over its
    limits. Nothing was written."""


class TrellisWarning(UserWarning):
    """A warning of the library (what the CLI prints on stderr): the output is written but may
    not be what was meant. The reader functions (check, analyze, compare, view, render) warn so;
    a route's ``Result.warnings`` holds its own."""

"""Errors that reach the user.

Every error the user can cause (a bad config value, a malformed file, a missing
directory) is raised as a :class:`ThermoswarmError` subclass whose message is one
line naming the file, field or value and what was expected.  The CLI prints it as
``error: <message>`` and exits with status 2; it never shows a traceback for these.
"""

from __future__ import annotations


class ThermoswarmError(Exception):
    """Base class of errors caused by the user's input; the message is for the user."""

    exit_code = 2


class ConfigError(ThermoswarmError, ValueError):
    """A configuration key or value is unknown, of the wrong type or out of range."""


class InputError(ThermoswarmError, ValueError):
    """An input file or dataset is missing, unreadable or malformed."""


class OutputError(ThermoswarmError, OSError):
    """An output location cannot be written (missing parent, not a directory, ...)."""


class NoBlobsError(InputError):
    """Too few moving blobs in a video's frames to measure the animals' size."""

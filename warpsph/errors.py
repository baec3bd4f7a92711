"""Exceptions with messages meant for users."""

import unicodedata


def _escaped(c: str) -> str:
    if c in "\n\r":
        return "\\n" if c == "\n" else "\\r"
    if c != "\t" and unicodedata.category(c) in ("Cc", "Zl", "Zp"):  # control, line and paragraph separators
        return f"\\u{ord(c):04X}"
    return c


def one_line(text: str) -> str:
    """``text`` with every character that could break it into lines written as a TOML escape (messages
    echo scene strings and keys, which may hold any character)."""
    return "".join(map(_escaped, text))


class InputError(ValueError):
    """Something the user gave (scene, arguments, files to resume from) cannot be used."""


class SceneError(InputError):
    """A scene is malformed; ``key`` is the dotted key path, e.g. ``materials.soil.poisson_ratio``."""

    def __init__(self, key: str, message: str):
        self.key = one_line(key)
        self.message = one_line(message)
        super().__init__(f"{self.key}: {self.message}" if key else self.message)


class SimulationError(RuntimeError):
    """A run went unstable or could not continue (NaN, infinity, speed beyond the scene's bound)."""


class OutputError(RuntimeError):
    """The run could not write its output (a directory it may not write, a full disk)."""


class DeviceError(InputError):
    """The Warp device asked for is not one Warp knows, or is not on this machine."""


class SceneWarning(UserWarning):
    """A scene value that is valid but implausible for soil and rock (mostly a unit typed wrong)."""

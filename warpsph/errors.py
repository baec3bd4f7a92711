"""Exceptions with messages meant for users."""


class InputError(ValueError):
    """Something the user gave (scene, arguments, files to resume from) cannot be used."""


class SceneError(InputError):
    """A scene is malformed; ``key`` is the dotted key path, e.g. ``materials.soil.poisson_ratio``."""

    def __init__(self, key: str, message: str):
        self.key = key
        self.message = message
        super().__init__(f"{key}: {message}" if key else message)


class SimulationError(RuntimeError):
    """A run went unstable or could not continue (NaN, infinity, speed beyond the scene's bound)."""

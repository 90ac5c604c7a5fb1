"""User-facing errors: one clear line that names the bad value and what to do."""

__all__ = ["EvodevoError", "ConfigError", "CheckpointError"]


class EvodevoError(Exception):
    """An error caused by the user's input; the CLI prints its message without a traceback."""


class ConfigError(EvodevoError, ValueError):
    """A configuration value, key or file is wrong."""


class CheckpointError(EvodevoError):
    """A checkpoint or saved artefact is missing, corrupt, or belongs to something else."""

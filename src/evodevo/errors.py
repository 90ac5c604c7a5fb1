"""User-facing errors: one clear line that names the bad value and what to do."""

__all__ = ["EvodevoError", "ConfigError", "CheckpointError", "env_module_error"]


class EvodevoError(Exception):
    """An error caused by the user's input; the CLI prints its message without a traceback."""


class ConfigError(EvodevoError, ValueError):
    """A configuration value, key or file is wrong."""


class CheckpointError(EvodevoError):
    """A checkpoint or saved artefact is missing, corrupt, or belongs to something else."""


def env_module_error(env_id: str, exc: ImportError) -> EvodevoError:
    """The error for a ``"module:EnvName-v0"`` id whose module cannot be imported."""
    return EvodevoError(
        f"cannot make environment {env_id!r}: {str(exc).splitlines()[0]} (is the folder "
        "holding the module on the Python path? e.g. PYTHONPATH=. evodevo ...)"
    )

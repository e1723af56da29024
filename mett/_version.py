"""mett's version, the one place it is written: read by ``pyproject.toml`` (hatchling's dynamic version) and exported as ``mett.__version__``."""

__version__ = "0.1.0.dev0"

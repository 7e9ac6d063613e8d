"""The version of pincal (one place: ``pincal.__version__`` and the CLI's ``--version`` read it;
pyproject.toml repeats it for packaging, and a test checks they agree)."""

__version__ = "0.2.0"

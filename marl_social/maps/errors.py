"""The maps' one error type, and the check that the optional `lanelet2` package is there."""

from __future__ import annotations

INSTALL_HINT = 'pip install -e ".[maps]"'


class MapError(ValueError):
    """A map cannot be read: a missing or malformed file, an unknown built-in name.

    A ValueError, so the `marl-social` command line prints it as one line without a traceback.
    """


def require_lanelet2():
    """The `lanelet2` module, or a MapError with the install hint when it is not installed."""
    try:
        import lanelet2
    except ImportError:
        raise MapError(f"reading a Lanelet2 map needs the lanelet2 package: {INSTALL_HINT}") \
            from None
    return lanelet2

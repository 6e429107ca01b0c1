"""The one rule for seeds: a non-negative integer below 2**63, of any integer type."""

from __future__ import annotations

import numbers

MAX_SEED = 2**63 - 1  # the largest seed (numpy's int64); SeedSequence takes any, the CLI too


def checked_seed(seed, name: str = "seed") -> int | None:
    """`seed` as a Python int (None stays None), or a one-line ValueError naming `name`.

    Python and numpy integers in [0, MAX_SEED] are seeds and give the same episode as the equal
    Python int; bools, floats (also 2.0), strings and negative or larger numbers are not.
    """
    if seed is None:
        return None
    if isinstance(seed, numbers.Integral) and not isinstance(seed, bool):
        value = int(seed)
        if 0 <= value <= MAX_SEED:
            return value
    raise ValueError(f"{name} must be an integer in [0, 2**63 - 1], got {seed!r} "
                     f"({type(seed).__name__})")


def seed_argument(text: str) -> int:
    """Argparse `type` of a seed option: the seed, or argparse's one-line error."""
    import argparse

    try:
        return checked_seed(int(text))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected an integer in [0, 2**63 - 1], got {text!r}") from None

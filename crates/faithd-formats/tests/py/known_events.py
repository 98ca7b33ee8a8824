"""The known event list shared by the AEDAT 4 interop scripts and tests/aedat4_interop.rs.

Event i: t = T0 + 37 i + i // 7 microseconds, x = 7919 i mod 240,
y = (104729 i + 13) mod 180, polarity = bit 7 of 2654435761 i.
The Rust side computes the same list and the same checksum.
"""

import sys

T0_US = 1_700_000_000_000_000
MODULUS = (1 << 61) - 1


def known_event(i):
    return (T0_US + 37 * i + i // 7, (7919 * i) % 240, (104729 * i + 13) % 180, ((2654435761 * i) >> 7) & 1)


def checksum(events):
    """Order-sensitive checksum over (t, x, y, p) tuples."""
    total = 0
    for i, (t, x, y, p) in enumerate(events):
        total = (total + (t * 1_000_003 + x * 1009 + y * 31 + p) % MODULUS * (i + 1)) % MODULUS
    return total


def import_dv():
    try:
        import dv_processing as dv  # noqa: F401
    except ImportError as error:
        print(
            f"dv_processing is not installed for {sys.executable} ({error}); "
            "install it with: python3 -m pip install dv-processing",
            file=sys.stderr,
        )
        sys.exit(3)
    return dv

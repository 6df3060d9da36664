"""Seeds: every random stream of evsim derives from a numpy SeedSequence, so outputs can be regenerated bit for bit
from the recorded entropy and spawn key."""

from __future__ import annotations

import numpy as np

from .errors import InvalidParameterError


def as_seed_sequence(seed: int | np.random.SeedSequence) -> np.random.SeedSequence:
    """An int (>= 0) or a SeedSequence as a SeedSequence."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0:
        return np.random.SeedSequence(int(seed))
    raise InvalidParameterError(f"seed must be a non-negative int or a numpy SeedSequence, got {seed!r}")


def child_seed(ss: np.random.SeedSequence, *path: int) -> np.random.SeedSequence:
    """The descendant of ss at spawn-key suffix `path` (SeedSequence.spawn's i-th child for one index), derived
    from ss's entropy and spawn key alone, so independent of how often ss was spawned before."""
    return np.random.SeedSequence(ss.entropy, spawn_key=(*ss.spawn_key, *(int(i) for i in path)))


def seed_record(ss: np.random.SeedSequence) -> dict[str, int | list[int]]:
    """JSON form of a SeedSequence: SeedSequence(entropy, spawn_key=spawn_key) regenerates it."""
    return {"entropy": int(ss.entropy), "spawn_key": [int(k) for k in ss.spawn_key]}

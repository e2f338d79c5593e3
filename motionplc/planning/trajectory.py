"""Immutable multi-axis trajectory: one :class:`Profile` per axis on a common time base."""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from motionplc.planning.profile import Profile, Sample


class TrajectorySamples(NamedTuple):
    """Arrays of shape (n_axes, n_times)."""

    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray


class Trajectory:
    """Synchronised profiles of several axes.

    ``sync`` is the synchronisation actually used ("time", "phase" or "none"); ``note`` says
    why it differs from the one asked for (e.g. phase synchronisation of non-collinear inputs).
    ``duration`` is the longest profile's duration; with time or phase synchronisation every
    profile ends within 1e-9 s of it.
    """

    __slots__ = ("profiles", "duration", "sync", "note", "independent_min_durations")

    profiles: tuple[Profile, ...]
    duration: float
    sync: str
    note: str
    independent_min_durations: tuple[float, ...]

    def __init__(
        self,
        profiles: Sequence[Profile],
        sync: str,
        note: str = "",
        independent_min_durations: Sequence[float] = (),
    ) -> None:
        # object.__setattr__ spelled out: the compiled build (a native class, as Profile) turns
        # these into direct stores
        profs = tuple(profiles)
        object.__setattr__(self, "profiles", profs)
        # a list, not a generator (plan_sync builds one per call)
        object.__setattr__(self, "duration", max([p.duration for p in profs], default=0.0))
        object.__setattr__(self, "sync", sync)
        object.__setattr__(self, "note", note)
        object.__setattr__(self, "independent_min_durations", tuple(independent_min_durations))

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("Trajectory is immutable")

    @property
    def dofs(self) -> int:
        return len(self.profiles)

    def at(self, t: float) -> tuple[Sample, ...]:
        """One :class:`Sample` per axis at time ``t`` (each clamped to its own profile)."""
        return tuple(p.at(t) for p in self.profiles)

    def sample(self, ts: Sequence[float] | np.ndarray) -> TrajectorySamples:
        """Vectorised :meth:`at`: arrays of shape (n_axes, len(ts))."""
        rows = [p.sample(ts) for p in self.profiles]
        return TrajectorySamples(
            np.array([r.p for r in rows]),
            np.array([r.v for r in rows]),
            np.array([r.a for r in rows]),
            np.array([r.j for r in rows]),
        )

    def __repr__(self) -> str:
        return f"Trajectory(dofs={self.dofs}, duration={self.duration:.9g}, sync={self.sync!r})"

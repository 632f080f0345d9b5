"""Segments: what every reflecting surface becomes for the echo search.

A :class:`Segments` pack holds straight segments ``a -> b`` with the unit tangents at both
ends: equal to the segment direction on *flat* segments (exact mirror-image reflection),
the true curve tangents on *smooth* ones (samples of a curve, so a specular point is found
between samples). A :class:`Surface` is anything that discretises into segments and
samples into points; the surface types are in :mod:`sonarsim.surfaces`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sonarsim.geometry import FloatArray

__all__ = ["DEFAULT_RESOLUTION", "Segments", "Surface"]

DEFAULT_RESOLUTION = 0.01
"""Default sampling step along curved surfaces (m)."""


@dataclass(frozen=True)
class Segments:
    """Packed straight segments ``a -> b`` with end tangents.

    Attributes
    ----------
    a, b : ndarray, shape (S, 2)
        Segment end points (m).
    ta, tb : ndarray, shape (S, 2)
        Unit tangents at ``a`` and ``b`` (both equal to the direction for flat segments).
    flat : ndarray of bool, shape (S,)
        True for truly straight pieces (exact mirror-image reflection).
    surface : ndarray of intp, shape (S,)
        Index of the surface each segment belongs to.
    """

    a: FloatArray
    b: FloatArray
    ta: FloatArray
    tb: FloatArray
    flat: NDArray[np.bool_]
    surface: NDArray[np.intp]

    def __len__(self) -> int:
        return int(self.a.shape[0])

    @staticmethod
    def empty() -> Segments:
        """No segments."""
        z = np.zeros((0, 2))
        return Segments(z, z, z, z, np.zeros(0, bool), np.zeros(0, np.intp))

    @staticmethod
    def concat(parts: Sequence[Segments]) -> Segments:
        """Concatenate segment packs, keeping their surface indices."""
        if not parts:
            return Segments.empty()
        return Segments(
            np.concatenate([p.a for p in parts]),
            np.concatenate([p.b for p in parts]),
            np.concatenate([p.ta for p in parts]),
            np.concatenate([p.tb for p in parts]),
            np.concatenate([p.flat for p in parts]),
            np.concatenate([p.surface for p in parts]),
        )

    def with_surface(self, index: int) -> Segments:
        """The same segments labelled as belonging to surface ``index``."""
        return Segments(
            self.a, self.b, self.ta, self.tb, self.flat, np.full(len(self), index, np.intp)
        )


class Surface(Protocol):
    """What the world needs from a surface."""

    @property
    def name(self) -> str:
        """Label."""
        ...

    @property
    def truth(self) -> bool:
        """Whether the surface belongs in a simulation's truth profile."""
        ...

    def segments(self, resolution: float = DEFAULT_RESOLUTION) -> Segments:
        """Discretise into segments no longer than ``resolution`` where curved."""
        ...

    def sample(self, spacing: float = DEFAULT_RESOLUTION) -> FloatArray:
        """Points along the surface, at most ``spacing`` apart, in surface order."""
        ...

    def transformed(
        self, angle: float, offset: ArrayLike, resolution: float = DEFAULT_RESOLUTION
    ) -> Surface:
        """The surface rotated by ``angle`` about the origin, then shifted by ``offset``."""
        ...

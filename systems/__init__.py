"""rmdrake.systems: Drake LeafSystems and diagram builders (thin wrappers over the
numerics in :mod:`rmdrake`)."""

from rmdrake.systems.sensors import RangeFinder

__all__: list[str] = ["RangeFinder"]

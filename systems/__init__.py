"""rmdrake.systems: Drake LeafSystems and diagram builders (thin wrappers over the
numerics in :mod:`rmdrake`)."""

__all__: list[str] = []

"""Robot cells shipped with rmdrake (YAML, :mod:`rmdrake.model.scene`)."""

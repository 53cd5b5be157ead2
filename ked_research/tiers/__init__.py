"""The tiers study: the three tiers side by side on the validity study's scenes (``study``)."""

"""The work-precision study: each solver's error against its run time (``study`` runs it; ``analysis`` and
``report`` read and render its stored files)."""

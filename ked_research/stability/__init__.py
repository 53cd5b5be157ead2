"""The stability study: the stiff and extreme scenes each solver must still solve (``study`` runs it; ``analysis``
and ``report`` read and render its stored files)."""

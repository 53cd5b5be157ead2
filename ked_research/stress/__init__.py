"""The stress study: the link stresses of each tier against Exudyn's (``study`` runs it; ``data`` and ``report``
read and render its stored files)."""

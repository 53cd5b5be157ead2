"""The ``ked`` command line: every command of the harness, on top of the numerical packages.

``ked_quasi``, ``exudyn_models`` and ``compare`` import no click; each command here is a thin layer
over one documented Python call, and loads only what it uses (``ked --help`` imports no solver).
"""

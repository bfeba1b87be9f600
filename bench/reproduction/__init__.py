"""Per-document reproduction of the seed experiments (``make reproduce``).

One module per source document in ``../shared/seeds/`` (``seed000`` ... ``seed004``), each with
``run(workdir, figdir) -> (row, pngs)``; shared scenario, config, run, metric and plot helpers
in :mod:`bench.reproduction.common`; ``python -m bench.reproduction`` runs them and writes
``reproduction/README.md`` and the figures.
"""

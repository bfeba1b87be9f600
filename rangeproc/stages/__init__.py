"""The eight stages of ``rangeproc run``, in order; ``rangeproc.pipeline`` strings them together.

=========  ==========================  ===================================================
stage      module                      what it does
=========  ==========================  ===================================================
read       ``stages.read``             every sensor file into SI logs (``io``)
screen     ``stages.screen``           absurd data removed with a reason, angle units checked
                                       (``editing``)
assemble   ``stages.assemble``         every row with its sensor's geometry (``fusion.assemble``,
                                       ``frames``)
associate  ``stages.associate``        rows sorted into objects (``tracking``)
fuse       ``stages.fuse``             filter, smoother, registration per object (``fusion``,
                                       ``estimation``)
products   ``stages.products``         tracks on the output grid, residuals, summaries,
                                       plausibility lines
write      ``stages.write``            staged, atomic outputs: tables and exports (``io``,
                                       ``interchange``)
report     ``stages.report``           figures and the report page (``report``)
=========  ==========================  ===================================================

Each stage module imports only the library rooms below it (``io``, ``editing``, ``frames``,
``models``, ``estimation``, ``fusion``, ``tracking``, ``interchange``, ``report``) and earlier
stages' containers; no library room imports a stage.
"""

#: The stages in order: the names the progress display and ``summary.json``'s
#: ``stage_seconds`` use.
STAGES = ("read", "screen", "assemble", "associate", "fuse", "products", "write", "report")

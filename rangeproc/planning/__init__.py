"""Pre-flight planning (``rangeproc plan``): the accuracy a planned flight can achieve with a
config's sensors, by the run's own models and smoother (``planning.plan``)."""

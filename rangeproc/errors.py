"""Exception hierarchy. The library raises these; only ``cli.py`` maps them to exit codes."""


class RangeprocError(Exception):
    """Base class of every error rangeproc raises on purpose."""


class ConfigError(RangeprocError):
    """The config is unusable. The message names the config file and the key at fault."""


class DataError(RangeprocError):
    """An input data file is unusable. The message names the file and the row/column at fault."""


class NumericalError(RangeprocError):
    """An estimator failed numerically (non-finite state, covariance not positive definite)."""

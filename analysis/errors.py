"""Exception types of the numerical core.

`InputError` marks bad input that the user can fix (the CLI reports it in one line and exits
with code 2). Packages above `analysis` derive their own bad-input errors from it.
"""


class InputError(ValueError):
    """Bad input: the message names the problem and how to fix it."""


class ModelError(InputError):
    """A model file or model definition is invalid."""


class RecordingError(InputError):
    """Recorded data has the wrong shape, kind or values."""


class EstimationError(RuntimeError):
    """An estimator could not produce a result from otherwise valid input."""

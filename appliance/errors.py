"""The one exception type the command line turns into a one-line error."""


class ApplianceError(Exception):
    """An error a user can act on.

    Its message is one line that names the file, key or device and what is wrong;
    the command line prints it as ``error: <message>`` and exits non-zero.
    Each package subclasses it (``ConfigError``, ``CalibrationError``, ...).
    """

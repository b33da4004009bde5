"""The one exception type users see for bad input."""


class InputError(ValueError):
    """Bad input from a user: the message is one line and says what to change.

    It is a ``ValueError`` so Python callers can catch it as such; the command
    line prints its message and exits with status 2.
    """

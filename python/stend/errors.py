"""Errors of the stend module: the messages and exit codes of the `stend` program (docs/errors.md)."""


class Error(Exception):
    """What the `stend` program reports as an error: ``message`` is the line it prints on stderr
    (``"error: …"``), ``exit_code`` its exit code; ``document`` the command's --json document when
    the command ran and ended with that code (a run that did not complete), else None."""

    def __init__(self, message, exit_code, document=None):
        super().__init__(message)
        self.message = message
        self.exit_code = exit_code
        self.document = document


class UsageError(Error):
    """Exit code 1: an option is wrong (unknown, out of range, nothing to do)."""


class InputError(Error):
    """Exit code 2: an experiment, model or data file or a run folder cannot be used as it is."""


class FitFailed(Error):
    """Exit code 3: the analysis ran and failed."""


class IoFailure(Error):
    """Exit code 4: a write failed, a device did not answer, a run failed on the bench."""


class Stopped(Error):
    """Exit code 130: the run was stopped (Ctrl-C) and closed as interrupted."""


_BY_CODE = {1: UsageError, 2: InputError, 3: FitFailed, 4: IoFailure, 130: Stopped}


def error_for(exit_code):
    """The Error subclass of an exit code."""
    return _BY_CODE.get(exit_code, Error)


def raise_outcome(exit_code, document, what):
    """Raises the Error of a command that ended with a nonzero exit code (``what`` says which)."""
    message = document.get("message") if isinstance(document, dict) else None
    text = f"{what}: exit code {exit_code}" + (f" — {message}" if message else "")
    raise error_for(exit_code)(text, exit_code, document)

"""Exceptions shared between runners, solvers and the CLI.

"""


class RunError(RuntimeError):
    """A run failed for a reason the user should read (no convergence, unstable time step, ...).

    The CLI prints the message, writes summary.json with ``converged = false`` and the message,
    keeps history.csv, and exits with status 1. Runners may attach partial results in
    ``results`` (a dict merged into summary.json).
    """

    def __init__(self, message: str, results: dict | None = None):
        super().__init__(message)
        self.results = dict(results or {})


class SceneError(ValueError):
    """A scene file (or a ``--set`` override) is invalid. The message names the file and key; the
    CLI prints it and exits with status 2 before anything is written."""

"""Ctrl-C and SIGTERM stop a command the same way, wherever they land: as a
KeyboardInterrupt, so that every `finally` runs (a temporary file is removed, an output
folder's lock released, workers stopped) and the dispatcher (physval.cli) says it in one
line with exit code 130. What must not be cut in two (the report that marks an
interrupted run as such) is written with both signals held off until it is done.
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

STOPPING = (signal.SIGINT, signal.SIGTERM)


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled as Ctrl-C is."""


def _raise_terminated(signum, frame):
    raise Terminated()


@contextmanager
def sigterm_as_ctrl_c():
    """Within: SIGTERM raises Terminated, as SIGINT raises KeyboardInterrupt (a SIGINT that
    was ignored when the process started stays ignored, as POSIX asks of a background job).
    Outside the main thread, nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


@contextmanager
def held_off():
    """Within: SIGINT and SIGTERM wait (blocked); one that came meanwhile is delivered on the
    way out, and raises there."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, STOPPING)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)

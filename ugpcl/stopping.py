"""Ending a run when it is asked to: Ctrl-C (SIGINT) and SIGTERM stop ``ugpcl`` within ``GRACE`` seconds on any
device, however long the kernel it is waiting for.

Python runs a signal handler only between bytecodes of the main thread, so a run waiting for a long kernel (an
all-pairs step of four million boids on a CPU, a burn-in of 100,000 sweeps) would hear SIGTERM only when the
device is done, minutes later, and the interpreter's exit then waits for the queue to drain. Here the handlers
raise as before (``KeyboardInterrupt``, ``Terminated``), so a responsive run unwinds and reports what it wrote; and
every signal also wakes a watcher thread (``signal.set_wakeup_fd``: CPython's C-level handler writes the signal
number to a pipe the moment the signal arrives, whatever the main thread is doing). The watcher gives the main
thread ``GRACE`` seconds to unwind and exit; if the process is still there, it prints the one line the main thread
could not and ends the process with ``os._exit`` (128 + the signal), leaving the device's work behind. Outputs are
written to temporary names and renamed when whole, so an abandoned write leaves the previous file in place.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections.abc import Callable

GRACE = 1.0
"""Seconds the main thread has to unwind after a signal before the watcher ends the process."""


class Terminated(Exception):
    """SIGTERM arrived: ends the run like Ctrl-C does, with exit 143 (128 + SIGTERM)."""


def _raise_terminated(signum, frame):
    raise Terminated


def exit_code(signum: int) -> int:
    return 128 + signum


class StopWatch:
    """``with StopWatch(message):`` around a front end's command, in the main thread. Inside, SIGINT raises
    ``KeyboardInterrupt`` and SIGTERM ``Terminated`` in the main thread, and either ends the process within GRACE
    seconds of its arrival even when the main thread is stuck in the device or in the interpreter's exit.
    ``message(signum)`` is the line printed when the main thread could not print its own; ``reported()`` marks that
    it did. Leaving the block without a signal puts the previous handlers back (a test calling ``main()``
    in-process keeps its own)."""

    def __init__(self, message: Callable[[int], str]):
        self.message = message
        self._reported = threading.Event()
        self._signalled = False

    def __enter__(self) -> StopWatch:
        self._read, write = os.pipe()
        os.set_blocking(write, False)
        self._write = write
        self._previous = (
            signal.set_wakeup_fd(write, warn_on_full_buffer=False),
            signal.signal(signal.SIGTERM, _raise_terminated),
            signal.signal(signal.SIGINT, signal.default_int_handler),
        )
        self._thread = threading.Thread(target=self._watch, name="ugpcl-stop-watch", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        if self._signalled:
            return  # the watcher ends the process by the deadline, whatever the exit does
        wakeup, term, intr = self._previous
        signal.set_wakeup_fd(wakeup)
        signal.signal(signal.SIGTERM, term)
        signal.signal(signal.SIGINT, intr)
        os.close(self._write)  # the watcher reads end-of-file and returns
        self._thread.join()
        os.close(self._read)

    def reported(self) -> None:
        self._reported.set()

    def _watch(self) -> None:
        while True:
            received = os.read(self._read, 64)
            if not received:
                return  # the block ended without a signal
            stops = [s for s in received if s in (signal.SIGINT, signal.SIGTERM)]
            if stops:
                break
        self._signalled = True
        signum, deadline = stops[0], time.monotonic() + GRACE
        if self._reported.wait(GRACE):
            time.sleep(max(0.0, deadline - time.monotonic()))  # the main thread's own exit, if it comes first
        else:
            _bounded(lambda: print(self.message(signum), file=sys.stderr, flush=True))
        _bounded(sys.stdout.flush)
        os._exit(exit_code(signum))


def _bounded(write: Callable[[], None], seconds: float = 0.25) -> None:
    """Run ``write`` in a thread of its own, waiting at most ``seconds``: a stream the stuck main thread holds
    locked must not keep the process alive."""

    def guarded() -> None:
        try:
            write()
        except Exception:  # a courtesy line; ending the process is the point
            pass

    thread = threading.Thread(target=guarded, daemon=True)
    thread.start()
    thread.join(seconds)

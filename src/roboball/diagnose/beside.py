"""Work run beside the diagnosis's own thread: a steer setting's search, a Drake prediction.

Given a second thread (Numba's count: the workflow gives each job one, so the pipeline's jobs
run everything in turn) a diagnosis runs two independent calls at once; their compiled loops
and Drake's steps release the GIL.  The call beside runs in a daemon thread, not a
ThreadPoolExecutor's: an error or Ctrl-C in the main thread then ends the command at once, where
an executor would first wait for the other call to finish (tens of seconds of a search).
"""
from __future__ import annotations

import threading

import numba


def second_thread() -> bool:
    """Whether this diagnosis may run two calls at once."""
    return numba.get_num_threads() > 1


class Beside:
    """`fn(*args, **kwargs)` started in a daemon thread; `result()` waits for it and returns its
    value, or raises its error in the caller's thread."""

    def __init__(self, fn, *args, **kwargs):
        self._value, self._error = None, None
        self._thread = threading.Thread(target=self._run, args=(fn, args, kwargs), daemon=True,
                                        name=f"roboball-beside-{getattr(fn, '__name__', 'call')}")
        self._thread.start()

    def _run(self, fn, args, kwargs) -> None:
        try:
            self._value = fn(*args, **kwargs)
        except BaseException as exc:        # handed to the caller by result()
            self._error = exc

    def result(self):
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._value

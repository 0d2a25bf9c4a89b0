"""Reading ahead in a thread (issue 13): the items of an iterator (the IMU table's next chunk,
read and checked) produced in a reader thread while the caller's compiled loop, which releases
the GIL, runs on the current one; and glibc's one malloc arena for the package's threads.
Infrastructure beside :mod:`inmotion._jit` and :mod:`inmotion._aot`, below every layer, so
that the streaming filter (:meth:`inmotion.estimation.velocity_aided.VelocityAidedRun.
run_stream`) and the file readers (:mod:`inmotion.io.bundle_stream`, which re-exports these
names) share it."""
from __future__ import annotations

import queue
import threading

__all__ = ["read_ahead", "one_malloc_arena", "READ_AHEAD"]

#: items a reader thread may read beyond the one its consumer holds (:func:`read_ahead`)
READ_AHEAD = 1

_M_ARENA_MAX = -8                      # glibc's mallopt parameter (malloc.h)


_arena_set = False


def one_malloc_arena():
    """Make glibc's malloc serve every thread from its main arena (``mallopt(M_ARENA_MAX,
    1)``, once; elsewhere nothing); called before any of the package's threads starts (the
    reader, :class:`inmotion.io.bundle_stream.TruthReducer`'s, the command line's and the
    result writer's). The reader thread's chunks are allocated by it and freed by the
    consumer; in a thread arena of their own the freed chunks were not reused by the main
    thread, and the peak memory of ``bench_memory.py``'s 4 h ``navigate`` varied from run to
    run with the threads' timing (issue 13: 195-212 MiB, 4 h / 1 h 1.09-1.19 against the
    target 1.15; with one arena 191-192 MiB, 1.11). It changes no result."""
    global _arena_set
    if _arena_set:
        return
    _arena_set = True
    try:
        import ctypes
        ctypes.CDLL("libc.so.6").mallopt(_M_ARENA_MAX, 1)
    except (OSError, AttributeError):
        pass


class _ReadAhead:
    """The items of an iterator, produced in a reader thread at most ``depth`` beyond the one
    the consumer holds (:func:`read_ahead`). The thread holds only the iterator, the queue,
    the slots and the stop flag (not this object), so dropping this object stops it."""

    def __init__(self, it, depth: int):
        self._it, self._depth = it, max(1, int(depth))
        self._q = self._slots = self._stop = self._thread = None
        self._done = False

    def __iter__(self):
        return self

    def _start(self):
        one_malloc_arena()
        self._q = queue.SimpleQueue()                # bounded by the slots
        self._slots = threading.Semaphore(self._depth)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=_read_ahead_run,
                                        args=(self._it, self._q, self._slots, self._stop),
                                        name="inmotion-reader", daemon=True)
        self._it = None
        self._thread.start()

    def __next__(self):
        if self._done:
            raise StopIteration
        if self._thread is None:
            self._start()
        kind, item = self._q.get()
        if kind == "item":
            # the item before this one is done with: the reader may read the next
            self._slots.release()
            return item
        self._done = True
        self._thread.join()
        if kind == "error":
            # the reader's exception itself (a BadInput keeps its message, file, row, time)
            raise item
        raise StopIteration

    def close(self):
        """Stop the reader (its iterator closed in its thread) and wait for it."""
        self._done = True
        if self._thread is not None:
            self._stop.set()
            self._slots.release()                    # wake a reader waiting for a slot
            self._thread.join()

    def __del__(self):
        if self._stop is not None:
            self._stop.set()
            self._slots.release()


def _read_ahead_run(it, q, slots, stop):
    """The reader thread: ``("item", x)`` per item of ``it`` (each read once a slot is free),
    then ``("end", None)`` or ``("error", exception)``; returns early (``it`` closed) once
    ``stop`` is set."""
    try:
        while True:
            slots.acquire()
            if stop.is_set():
                return
            try:
                x = next(it)
            except StopIteration:
                q.put(("end", None))
                return
            q.put(("item", x))
            del x
    except BaseException as e:                    # noqa: BLE001 (raised in the consumer)
        q.put(("error", e))
    finally:
        close = getattr(it, "close", None)
        if close is not None:
            close()


def read_ahead(it, depth: int = READ_AHEAD):
    """The items of ``it`` in order, read in a reader thread at most ``depth`` items beyond
    the one the consumer holds: issue 13's command-line run reads and checks the next IMU
    chunk (pyarrow's decoding, numpy's checks) while the filter's compiled loop runs on the
    current one, which releases the GIL (the ahead-of-time extension's functions,
    :func:`inmotion._aot_build._releasing_gil`). Memory stays bounded: ``depth`` + 1 items
    alive (with ``depth = 1``: the one being processed and the next, read meanwhile); the
    reader waits for the consumer to ask for the next item before it reads another. The
    thread starts at the first item asked for; an exception in it is raised in the consumer
    as it was raised (a :class:`BadInput` gives the same message and exit status) when its
    place in the sequence is reached. ``close()`` (or dropping the object) stops it. ``it``
    must not be read from elsewhere meanwhile."""
    return _ReadAhead(it, depth)

"""Reading ahead: the next items of a sequence read on a thread while this one is processed.

A sequence of 3D frames reads one cycle of frames, computes, writes, and reads the next; a
capture of PNG or TIFF files spends as long decoding a 1280 x 1024 cycle as the fused kernel
spends on it (``benchmarks/bench_sequence.py``). :class:`ReadAhead` takes the reading off that
path: reader threads (one by default) read the next ``depth`` items (OpenCV's and tifffile's
decoders release the GIL, and :class:`~fringe3d.io.capture_frames.CaptureFrames` decodes a
cycle's files in parallel) while the caller processes the current one; the items are handed
over in order.

Bounded (at most ``depth`` items read and not yet taken), in order, an error raised by a read
raised by the iteration at that item (the file named as the reader names it), and stopped on
:meth:`ReadAhead.close` (the end of a ``with`` block, an exception or ``KeyboardInterrupt``
in the caller): the reads not started are cancelled and the one running is waited for.
"""
from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Generic, TypeVar

K = TypeVar("K")
T = TypeVar("T")

#: Items read ahead by default: a few cycles (a 1280 x 1024 3-step cycle is 3.9 MB)
DEPTH = 3


class ReadAhead(Generic[K, T]):
    """``read(key)`` of every key of ``keys``, in order, read up to ``depth`` keys ahead.

    Parameters
    ----------
    read : callable
        Reads one item; it runs on the reader thread.
    keys : iterable
        The keys, in the order their items are wanted (taken lazily, ``depth`` ahead).
    depth : int
        Items read and not yet taken, at most (at least 1).
    workers : int
        Reader threads: items read at once (default 1; more for reads that spend their time in
        decoders releasing the GIL, e.g. a cycle of PNG files, whose next cycles then decode
        beside it; still handed over in order).

    Examples
    --------
    >>> with ReadAhead(lambda k: k * k, range(4), depth=2) as items:
    ...     list(items)
    [0, 1, 4, 9]
    """

    def __init__(self, read: Callable[[K], T], keys: Iterable[K], depth: int = DEPTH, workers: int = 1):
        if depth < 1:
            raise ValueError(f"read-ahead depth must be at least 1, got {depth}")
        if workers < 1:
            raise ValueError(f"read-ahead workers must be at least 1, got {workers}")
        self._read = read
        self._keys = iter(keys)
        self._depth = int(depth)
        self._pool: ThreadPoolExecutor | None = ThreadPoolExecutor(max_workers=int(workers),
                                                                   thread_name_prefix="fringe3d-read-ahead")
        self._pending: deque[Future] = deque()

    def __enter__(self) -> Iterator[T]:
        return iter(self)

    def __exit__(self, *exc) -> None:
        self.close()

    def __iter__(self) -> Iterator[T]:
        try:
            self._fill()
            while self._pending:
                fut = self._pending.popleft()
                self._fill()  # the next read queued before this item is handed over
                yield fut.result()
        finally:
            self.close()

    def _fill(self) -> None:
        """Queue reads until ``depth`` are pending (or the keys run out)."""
        while self._pool is not None and len(self._pending) < self._depth:
            try:
                key = next(self._keys)
            except StopIteration:
                return
            self._pending.append(self._pool.submit(self._read, key))

    def close(self) -> None:
        """Stop reading: cancel the reads not started, wait for those running (idempotent)."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        for fut in self._pending:
            fut.cancel()
        self._pending.clear()
        pool.shutdown(wait=True, cancel_futures=True)

"""Shared-memory state blocks between a node's processes (the paper's SharedMemory module).

A node's control loop (1 kHz, its own process) and its fabric process exchange *state* through
a fixed-layout block; events travel on queues (docs/architecture.md §8). One process writes a
block, any number read it. Consistency without locks comes from a sequence lock: the writer
makes the counter odd, writes, makes it even; a reader copies the payload and retries if the
counter was odd or changed meanwhile. Nobody ever waits on the other side, so the control loop
cannot be stalled by a slow reader.

Layout: an 8-byte sequence counter in the host's byte order (a block never leaves its host),
then one record of a numpy structured dtype.
"""

from __future__ import annotations

import fcntl
import logging
import multiprocessing
import os
import time
from multiprocessing import resource_tracker, shared_memory

import numpy as np

HEADER = 8
READ_TIMEOUT_S = 0.1  # [s] how long `read` retries before a writer mid-write counts as gone
LATEST_TIMEOUT_S = 0.002  # [s] how long `read_latest` retries before using its last copy


log = logging.getLogger(__name__)


class TornRead(RuntimeError):
    """The writer kept writing while we tried to read: retries exhausted."""


class BlockInUse(RuntimeError):
    """A block of this name belongs to a process that is still running on this host."""


def _create(name: str, size: int) -> shared_memory.SharedMemory:
    """A new block, claimed for as long as this process keeps it open.

    The creator holds an exclusive `flock` on the block's file: the kernel drops it when the
    process ends, however it ends. A block whose name is taken but whose claim is gone was
    left by a process that was killed (SIGKILL never runs the unlink): it is removed and
    made anew, so a node restarted after a crash starts; one still claimed is a live
    process's, and taking its name would tear its state."""
    try:
        shm = shared_memory.SharedMemory(name=name, create=True, size=size)
    except FileExistsError:
        if _claimed(name):
            raise BlockInUse(
                f"shared block {name} belongs to a running process on this host (the same "
                "session and node id started twice?)"
            ) from None
        stale = shared_memory.SharedMemory(name=name)
        stale.close()
        stale.unlink()
        log.warning("removed shared block %s, left by a process that was killed", name)
        shm = shared_memory.SharedMemory(name=name, create=True, size=size)
    fcntl.flock(shm._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # type: ignore[attr-defined]
    return shm


def _claimed(name: str) -> bool:
    """Whether a living process holds the claim on block `name` (see `_create`)."""
    try:
        fd = os.open(f"/dev/shm/{name.lstrip('/')}", os.O_RDONLY)
    except FileNotFoundError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)  # the probe's own lock, if it got one, goes with it
    return False


def _untrack(shm: shared_memory.SharedMemory) -> None:
    """Stop this process's resource tracker from unlinking a block it only attached to.

    Before Python 3.13 (`track=False`), attaching registers the block with the tracker, which
    unlinks it when the attaching process exits: a view closing first would remove the running
    node's block under it. Only the creator may unlink.

    A multiprocessing child (a node's loop or view process) shares its parent's tracker, which
    already holds the creator's registration and unlinks nothing before the whole family
    exits: unregistering there would drop the creator's entry, and the creator's own unlink
    then ends in a KeyError traceback from the tracker. So a child leaves it alone.
    """
    if os.name == "posix" and multiprocessing.parent_process() is None:
        resource_tracker.unregister(shm._name, "shared_memory")  # type: ignore[attr-defined]


class SharedBlock:
    """One seqlock-protected record in shared memory."""

    def __init__(self, name: str, dtype: np.dtype, create: bool = False) -> None:
        self.dtype = np.dtype(dtype)
        size = HEADER + self.dtype.itemsize
        if create:
            self._shm = _create(name, size)
        else:
            self._shm = shared_memory.SharedMemory(name=name)
        self._owner = create
        if not create:
            _untrack(self._shm)
        buf = self._shm.buf
        assert buf is not None  # None only once closed
        self._buf: memoryview | None = buf
        self._record = np.ndarray((), dtype=self.dtype, buffer=buf, offset=HEADER)
        self._payload = buf[HEADER:size]
        # The counter is read and written through a native 'Q' view: one 8-byte load or store.
        # `struct.pack_into` zero-fills its target before packing, so a counter written with
        # it passed through 0 on every write, and a reader that caught two such moments
        # around its copy took a torn record for a whole one (seen at about one read in a
        # million with a writer writing flat out).
        self._seq = buf[:HEADER].cast("Q")
        self.retries = 0
        self.stale_reads = 0  # `read_latest` calls answered with the previous copy
        self._last: np.void | None = None
        if create:
            self._seq[0] = 0
            self._record[()] = np.zeros((), dtype=self.dtype)

    @property
    def name(self) -> str:
        return self._shm.name

    def sequence(self) -> int:
        return self._seq[0]

    def peek(self, field: str) -> object:
        """One field as it is now, without the sequence lock: a hint that may be mid-write,
        to decide whether a full (and, for a large record, costly) `read()` is worth it."""
        return self._record[field].item()

    def write(self, values: np.void | np.ndarray) -> None:
        """Publish a whole record (writer side only)."""
        seq = self._seq[0]
        self._seq[0] = seq + 1  # odd: a write is in progress
        self._record[()] = values
        self._seq[0] = seq + 2

    def write_fields(self, **fields: float | int) -> None:
        """Update some fields, keeping the others (writer side only).

        The new record is built first and published by `write`, in one copy: the interpreter
        can hand its lock to another thread between any two statements, and a writer caught
        mid-write that way (a busy node process, a loaded machine) holds every reader off
        until it runs again; a loop over the fields gave it a statement per field to be caught.
        """
        record = self._record.copy()
        for key, value in fields.items():
            record[key] = value
        self.write(record)

    def read(self, timeout_s: float = READ_TIMEOUT_S) -> np.void:
        """A consistent copy of the record; never blocks the writer.

        Spins briefly, then yields the CPU: if the writer was preempted mid-write (two cores,
        a busy machine), spinning would only keep it from finishing.

        Between the two looks at the counter it takes only the raw bytes (a quarter of a
        microsecond) and builds the record after: a writer writing flat out leaves a gap of
        about a microsecond between writes, and a numpy copy (1-3 µs) inside the window never
        fitted in it, so such a reader could starve until its timeout.
        """
        deadline = None
        spins = 0
        while True:
            before = self._seq[0]
            if not before & 1:
                raw = bytearray(self._payload)
                if self._seq[0] == before:
                    return np.frombuffer(raw, dtype=self.dtype)[0]
            self.retries += 1
            spins += 1
            if spins > 100:
                now = time.monotonic()
                deadline = deadline or now + timeout_s
                if now > deadline:
                    raise TornRead(f"shared block {self.name}: no consistent read in {timeout_s} s")
                time.sleep(0)

    def read_latest(self, timeout_s: float = LATEST_TIMEOUT_S) -> np.void:
        """A consistent copy of the record or, when the writer has been mid-write for longer
        than `timeout_s` (preempted), the last consistent copy this reader took, counted in
        `stale_reads`. For loops: they keep their rate and never end on a torn read. Before
        its first copy it waits as `read` does, and raises `TornRead` as it does."""
        try:
            self._last = self.read(timeout_s if self._last is not None else READ_TIMEOUT_S)
        except TornRead:
            if self._last is None:
                raise
            self.stale_reads += 1
        return self._last

    def close(self) -> None:
        del self._record
        self._payload.release()
        self._seq.release()
        self._buf = None
        self._shm.close()
        if self._owner:
            self._shm.unlink()


def new_record(dtype: np.dtype) -> np.void:
    """A zeroed record to fill and write."""
    # numpy's stubs type `[()]` of a 0-d array as an array; of a structured one it is a void.
    return np.zeros((), dtype=dtype)[()]  # type: ignore[return-value]


def block_name(session: str, node_id: str, part: str) -> str:
    """A node's block name, `carlaverse-<session>-<node id>-<part>`, so a viewer can attach."""
    return f"carlaverse-{session}-{node_id}-{part}"


class BlockReader:
    """A reader of another process's block that attaches once the block exists: `read()` is
    None until then, on a torn read (counted) and, when the layout has `running`, until the
    writer's loop has ticked once."""

    def __init__(self, name: str, dtype: np.dtype) -> None:
        self.name = name
        self.dtype = dtype
        self.torn_reads = 0
        self._block: SharedBlock | None = None

    def read(self) -> np.void | None:
        if self._block is None:
            try:
                self._block = SharedBlock(self.name, self.dtype)
            except FileNotFoundError:
                return None  # the writer creates it when its loop starts
        try:
            record = self._block.read()
        except TornRead:
            self.torn_reads += 1
            return None
        running = "running" not in (self.dtype.names or ()) or bool(record["running"])
        return record if running else None

    def close(self) -> None:
        if self._block is not None:
            self._block.close()
            self._block = None

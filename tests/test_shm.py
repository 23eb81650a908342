"""The seqlock block: consistent reads while another process writes flat out."""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from multiprocessing.process import BaseProcess
from pathlib import Path

import numpy as np
import pytest

from carlaverse.shm import LATEST_TIMEOUT_S, SharedBlock, TornRead, new_record

DTYPE = np.dtype([("a", "<f8"), ("b", "<f8"), ("c", "<i8"), ("pad", "<f8", (16,))])


def _writer(name: str, count: int, started) -> None:  # type: ignore[no-untyped-def]
    block = SharedBlock(name, DTYPE)
    record = new_record(DTYPE)
    started.set()
    for k in range(1, count + 1):
        record["a"] = k
        record["b"] = -k
        record["c"] = k
        record["pad"][:] = k
        block.write(record)
    block.close()


WRITES = 200_000


@contextmanager
def _written_flat_out() -> Iterator[tuple[SharedBlock, BaseProcess]]:
    """A block and a process writing WRITES records into it as fast as it can."""
    name = f"cv-test-{uuid.uuid4().hex[:8]}"
    block = SharedBlock(name, DTYPE, create=True)
    ctx = mp.get_context("spawn")
    started = ctx.Event()
    writer = ctx.Process(target=_writer, args=(name, WRITES, started))
    writer.start()
    try:
        assert started.wait(30)
        yield block, writer
    finally:
        writer.join(30)
        block.close()


def test_reads_are_never_torn_while_another_process_writes() -> None:
    with _written_flat_out() as (block, writer):
        seen = set()
        while writer.is_alive() or not seen:
            r = block.read()
            k = r["c"]
            # every field comes from the same write
            assert r["a"] == k and r["b"] == -k and (r["pad"] == k).all()
            seen.add(int(k))
        assert len(seen) > 10  # we really did read while it wrote


def test_the_counter_never_goes_back_while_another_process_writes() -> None:
    """Every read of the counter is at least the one before: a write must never show a reader
    a counter it had already passed (struct's pack_into zero-filled it on every write, and a
    reader that saw 0 around its copy took a torn record for a whole one)."""
    with _written_flat_out() as (block, writer):
        last, reads, back = 0, 0, []
        while writer.is_alive():
            seq = block.sequence()
            if seq < last:
                back.append((last, seq))
            last = max(last, seq)
            reads += 1
        writer.join(30)
        assert not back, f"{len(back)} of {reads} reads went back, first {back[:3]}"
        assert block.sequence() == 2 * WRITES


def _stalled_writer(name: str, steps) -> None:  # type: ignore[no-untyped-def]
    """Writes 1; on `go`, stops half-way through writing 2 (its sequence odd) until `resume`,
    as a writer the scheduler or another thread of its process took the CPU from would."""
    wrote, go, stalled, resume = steps
    block = SharedBlock(name, DTYPE)
    record = new_record(DTYPE)
    record["c"] = 1
    block.write(record)
    wrote.set()
    go.wait(30)
    seq = block.sequence()
    block._seq[0] = seq + 1  # a write begun
    stalled.set()
    resume.wait(30)
    record["c"] = 2
    block._record[()] = record
    block._seq[0] = seq + 2  # and finished
    block.close()


def test_read_latest_answers_with_the_last_copy_while_the_writer_is_stalled_mid_write() -> None:
    name = f"cv-test-{uuid.uuid4().hex[:8]}"
    block = SharedBlock(name, DTYPE, create=True)
    ctx = mp.get_context("spawn")
    wrote, go, stalled, resume = steps = [ctx.Event() for _ in range(4)]
    writer = ctx.Process(target=_stalled_writer, args=(name, steps))
    fresh = SharedBlock(name, DTYPE)  # a reader that takes no copy before the stall
    try:
        writer.start()
        assert wrote.wait(30)
        assert int(block.read_latest()["c"]) == 1
        go.set()
        assert stalled.wait(30)
        with pytest.raises(TornRead):
            block.read(timeout_s=0.01)
        with pytest.raises(TornRead):  # nothing to fall back on: it says so
            fresh.read_latest()
        took = []
        for _ in range(5):
            started = time.monotonic()
            assert int(block.read_latest()["c"]) == 1
            took.append(time.monotonic() - started)
        assert block.stale_reads == 5
        # a 1 kHz loop keeps its rate: a call waits its own budget, not `read`'s 0.1 s
        assert min(took) < LATEST_TIMEOUT_S + 0.02, took
        resume.set()
        writer.join(30)
        assert int(block.read_latest()["c"]) == 2 and block.stale_reads == 5
    finally:
        resume.set()
        go.set()
        writer.join(30)
        fresh.close()
        block.close()


def test_write_fields_keeps_the_rest() -> None:
    block = SharedBlock(f"cv-test-{uuid.uuid4().hex[:8]}", DTYPE, create=True)
    try:
        block.write_fields(a=1.5, c=3)
        block.write_fields(b=2.0)
        r = block.read()
        assert (r["a"], r["b"], r["c"]) == (1.5, 2.0, 3)
        assert block.sequence() == 4
    finally:
        block.close()


def test_a_process_that_only_attached_leaves_the_block_to_its_owner() -> None:
    """Python < 3.13 tracks attached blocks and unlinked them when the attaching process exited."""
    owner = SharedBlock(f"cv-test-{os.getpid()}-attach", np.dtype([("v", "<f8")]), create=True)
    try:
        code = (
            "import numpy as np; from carlaverse.shm import SharedBlock; "
            f"SharedBlock({owner.name!r}, np.dtype([('v', '<f8')])).close(); "
            # wait for this process's tracker to clean up, as it would at exit
            "from multiprocessing import resource_tracker as rt; rt._resource_tracker._stop()"
        )
        subprocess.run([sys.executable, "-c", code], check=True, timeout=60)
        again = SharedBlock(owner.name, np.dtype([("v", "<f8")]))  # still there
        again.close()
    finally:
        owner.close()


FAMILY = """
import multiprocessing as mp
import numpy as np
from multiprocessing import resource_tracker as rt
from carlaverse.shm import SharedBlock

DTYPE = np.dtype([("v", "<f8")])


def attach(name):
    SharedBlock(name, DTYPE).close()


if __name__ == "__main__":
    owner = SharedBlock("cv-test-{pid}-family", DTYPE, create=True)
    child = mp.get_context("spawn").Process(target=attach, args=(owner.name,))
    child.start()
    child.join(60)
    assert child.exitcode == 0
    owner.close()  # unlinks: the shared tracker must still know the block
    rt._resource_tracker._stop()  # wait for the tracker to handle everything, as at exit
"""


def test_a_loop_process_attaching_leaves_the_owners_tracking_alone(tmp_path) -> None:
    """A node's loop or view process shares the node's tracker: no KeyError at the unlink."""
    script = tmp_path / "family.py"
    script.write_text(FAMILY.replace("{pid}", str(os.getpid())))
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=60, cwd=Path(__file__).resolve().parents[1])  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr and "KeyError" not in done.stderr, done.stderr


CREATOR = """
import sys
import numpy as np
from carlaverse.shm import SharedBlock
block = SharedBlock(sys.argv[1], np.dtype([("x", "<f8")]), create=True)
print("created", flush=True)
sys.stdin.read()  # until killed
"""


def test_a_block_left_by_a_killed_creator_is_made_anew_and_a_live_ones_is_not_taken() -> None:
    """SIGKILL runs no unlink, so a killed node's blocks stay in /dev/shm; its restart must
    start (a FileExistsError traceback before), while a second live creator of the same name
    (the same node started twice) is refused in one sentence, not handed the first's state."""
    from carlaverse.shm import BlockInUse

    name = f"cv-test-{uuid.uuid4().hex[:8]}"
    # In a process group of its own, killed as a group (as `procs` stops a child, or a
    # terminal's ^\ does): multiprocessing's resource tracker dies with it and cleans nothing.
    creator = subprocess.Popen(
        [sys.executable, "-c", CREATOR, name],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    try:
        assert creator.stdout is not None and creator.stdout.readline().strip() == "created"
        with pytest.raises(BlockInUse, match="running process"):
            SharedBlock(name, np.dtype([("x", "<f8")]), create=True)
        assert Path(f"/dev/shm/{name}").exists()  # the refusal took nothing from the owner
    finally:
        os.killpg(creator.pid, signal.SIGKILL)
        creator.wait(10)
    assert Path(f"/dev/shm/{name}").exists()  # left behind by the kill
    block = SharedBlock(name, np.dtype([("x", "<f8")]), create=True)
    try:
        block.write(np.array((1.5,), dtype=block.dtype))
        assert float(block.read()["x"]) == 1.5
    finally:
        block.close()  # the owner's close unlinks
    assert not Path(f"/dev/shm/{name}").exists()

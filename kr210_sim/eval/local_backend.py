"""The local backend: episodes in this process (one worker) or in local worker processes.

Worker processes are started with ``spawn`` (no threads or GL contexts inherited), each talks to
the driver over its own pipe (no shared queues, hence no semaphores to leak), and each ignores
SIGINT and SIGTERM: a Ctrl-C on the terminal or a SIGTERM to the process group reaches the whole
group, and only the driver acts on it. The driver then kills its workers (SIGKILL) and joins
them, so none is left behind and none prints a traceback. On Linux a worker also dies with the
driver if the driver itself is killed outright.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
from collections import deque
from collections.abc import Iterable, Iterator
from multiprocessing.connection import Connection, wait
from pathlib import Path
from types import TracebackType
from typing import Any

from kr210_sim.errors import Kr210SimError
from kr210_sim.eval import episode
from kr210_sim.util.processes import die_with_parent

#: Episodes queued per worker process (one running, one waiting in its pipe).
QUEUED_PER_WORKER = 2


class EpisodeError(Kr210SimError):
    """An episode raised an exception (a bug: episodes report failures, they do not raise)."""


def _died(index: int) -> EpisodeError:
    return EpisodeError(
        f"a worker process died running episode {index}; "
        "the finished episodes are kept: continue with --resume"
    )


def _worker_main(
    conn: Connection,
    parent: int,
    randomize: bool,
    scene: str | None,
    ik: str | None,
    ik_timeout: float | None = None,
    perceive: episode.Perceive = False,
) -> None:
    """A worker process: run the episodes the driver sends, reply with their records."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    die_with_parent(parent)
    try:
        episode.load_pristine(scene)
        while (job := conn.recv()) is not None:
            index, seed = job
            try:
                reply: tuple[Any, ...] = (
                    "ok",
                    index,
                    episode.record_of(index, seed, randomize, scene, ik, ik_timeout, perceive),
                )
            except Exception as exc:
                reply = ("error", index, f"{type(exc).__name__}: {exc}")
            conn.send(reply)
    except (EOFError, OSError):  # the driver went away: nothing to report to
        return


class LocalBackend:
    """Runs episodes in this process (``workers == 1``) or in ``workers`` local processes.

    Use as a context manager: leaving it stops every worker (killed and joined if episodes were
    still running).

    Args:
        workers: Worker processes (1: run in this process).
        randomize: Randomise each episode's target.
        scene: MJCF scene path, or None for the committed scene.
        ik: SPEC of the user's IK, or None for ours.
        ik_timeout: Time limit per call of that IK [s], or None.
        perceive: Pick from what the sensors see (``--perceive``).
    """

    name = "local"

    def __init__(
        self,
        workers: int,
        randomize: bool,
        scene: Path | None,
        ik: str | None = None,
        ik_timeout: float | None = None,
        perceive: episode.Perceive = False,
    ) -> None:
        self.workers = workers
        self.perceive = perceive
        self.randomize = randomize
        self.scene = str(scene) if scene is not None else None
        self.ik = ik
        self.ik_timeout = ik_timeout
        self._procs: list[mp.process.BaseProcess] = []
        self._conns: list[Connection] = []

    def execution(self) -> dict[str, Any]:
        """How the work is spread (for the report's ``wall_execution``)."""
        return {"backend": self.name, "workers": self.workers, "nodes": 1}

    def __enter__(self) -> LocalBackend:
        return self.start()

    def start(self) -> LocalBackend:
        """Start the worker processes (none for one worker); :meth:`close` stops them."""
        if self.workers == 1:
            episode.load_pristine(self.scene)
            return self
        ctx = mp.get_context("spawn")
        try:
            for _ in range(self.workers):
                mine, theirs = ctx.Pipe()
                proc = ctx.Process(
                    target=_worker_main,
                    args=(
                        theirs,
                        os.getpid(),
                        self.randomize,
                        self.scene,
                        self.ik,
                        self.ik_timeout,
                        self.perceive,
                    ),
                    name="kr210_sim-evaluate",
                )
                proc.start()
                theirs.close()
                self._procs.append(proc)
                self._conns.append(mine)
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def close(self, graceful: bool = False) -> None:
        """Stop the workers: ask them to finish when ``graceful``, else kill them; join them."""
        for proc, conn in zip(self._procs, self._conns, strict=True):
            if graceful:
                try:
                    conn.send(None)
                except OSError:
                    pass
            else:
                proc.kill()
        for proc, conn in zip(self._procs, self._conns, strict=True):
            proc.join(timeout=10.0 if graceful else None)
            if proc.exitcode is None:  # did not finish: kill it
                proc.kill()
                proc.join()
            conn.close()
            proc.close()
        self._procs.clear()
        self._conns.clear()

    def results(self, jobs: Iterable[tuple[int, int]]) -> Iterator[list[dict[str, Any]]]:
        """Run ``jobs`` (``(index, seed)`` pairs), yielding records as they finish (any order).

        Raises:
            EpisodeError: When an episode raises, or a worker process dies.
        """
        if self.workers == 1:
            for index, seed in jobs:
                yield [
                    episode.record_of(
                        index,
                        seed,
                        self.randomize,
                        self.scene,
                        self.ik,
                        self.ik_timeout,
                        self.perceive,
                    )
                ]
            return
        todo = iter(jobs)
        queued: dict[Connection, deque[int]] = {c: deque() for c in self._conns}
        conn_of = {p.sentinel: c for p, c in zip(self._procs, self._conns, strict=True)}

        def feed(conn: Connection) -> None:
            while len(queued[conn]) < QUEUED_PER_WORKER:
                job = next(todo, None)
                if job is None:
                    return
                queued[conn].append(job[0])
                try:
                    conn.send(job)
                except OSError:
                    raise _died(queued[conn][0]) from None

        for conn in self._conns:
            feed(conn)
        while any(queued.values()):
            busy = [c for c, q in queued.items() if q]
            for ready in wait([*busy, *conn_of]):
                if isinstance(ready, int):  # a worker's sentinel: it exited
                    conn = conn_of.pop(ready)
                    if queued[conn] and not conn.poll():
                        raise _died(queued[conn][0])
                    continue
                assert isinstance(ready, Connection)
                try:
                    status, index, payload = ready.recv()
                except (EOFError, OSError):  # closed, or reset with data unread
                    raise _died(queued[ready][0]) from None
                queued[ready].remove(index)
                if status != "ok":
                    raise EpisodeError(f"episode {index} raised {payload}")
                feed(ready)
                yield [payload]
        self.close(graceful=True)

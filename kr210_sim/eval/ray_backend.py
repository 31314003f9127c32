"""The Ray backend: episodes batched into Ray tasks on a cluster, or on a Ray started here.

Ray is an optional extra (``pip install '.[ray]'`` in a clone); every node needs the same
kr210_sim, MuJoCo and ruckig (each chunk reports its versions and the driver refuses a mix) and,
for ``--scene``, the scene at the same path.

Fault tolerance: a chunk whose worker process or node dies is retried by Ray (up to
:data:`MAX_RETRIES` times). A chunk is a pure function of its episodes' seeds, so a retry returns
the same records, and the driver keys results by episode number: an episode is never counted
twice, and none is lost while retries remain.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable, Iterator
from itertools import islice
from pathlib import Path
from types import TracebackType
from typing import Any

from kr210_sim.errors import ConfigError, Kr210SimError
from kr210_sim.eval import episode
from kr210_sim.eval.local_backend import EpisodeError

log = logging.getLogger(__name__)

#: Retries of a chunk whose worker process or node died.
MAX_RETRIES = 5
#: Most episodes in one task (a task of 16 episodes runs ~1.5 s: Ray's ~1 ms per task is noise).
MAX_CHUNK = 16
#: Aim for at least this many chunks per worker, so the last ones finish together.
CHUNKS_PER_WORKER = 4
#: Object store of a Ray started by evaluate itself [bytes] (results are a few kB a chunk).
LOCAL_OBJECT_STORE = 256 * 2**20

INSTALL_HINT = (
    "--backend ray needs Ray: pip install 'ray>=2.50,<3' (in a clone: pip install '.[ray]')"
)
#: Seconds to wait for a cluster's address to answer before giving up [s].
CONNECT_TIMEOUT = 10.0


def chunk_size(episodes: int, workers: int) -> int:
    """Episodes per task for ``episodes`` to run on ``workers`` concurrent tasks."""
    return max(1, min(MAX_CHUNK, episodes // (workers * CHUNKS_PER_WORKER)))


class RayBackend:
    """Runs episodes as Ray tasks.

    Use as a context manager: entering connects to the cluster (or starts Ray here), leaving
    disconnects, which ends this job's tasks on the cluster (or stops the Ray started here).

    Args:
        workers: Tasks in flight at a time (None: the cluster's CPUs); when Ray is started
            here, also its CPU count.
        randomize: Randomise each episode's target.
        scene: MJCF scene path (the same on every node), or None for the committed scene.
        ik: SPEC of the user's IK (its file at the same path on every node), or None.
        ik_timeout: Time limit per call of that IK [s], or None.
        perceive: Pick from what the sensors see (``--perceive``).
        address: Cluster address (``auto`` or ``host:port``), or None to start Ray here.
        episodes: Episodes to run (caps the workers and sizes the chunks).
    """

    name = "ray"

    def __init__(
        self,
        workers: int | None,
        randomize: bool,
        scene: Path | None,
        address: str | None,
        episodes: int,
        ik: str | None = None,
        ik_timeout: float | None = None,
        perceive: episode.Perceive = False,
    ) -> None:
        self.workers = workers or 0
        self.perceive = perceive
        self.randomize = randomize
        self.scene = str(scene.resolve()) if scene is not None else None
        self.ik = ik
        self.ik_timeout = ik_timeout
        self.address = address
        self.episodes = episodes
        self.cpus = 0
        self.nodes = 0
        self.chunk = 1
        self._ray: Any = None
        self._pending: dict[Any, list[int]] = {}

    def execution(self) -> dict[str, Any]:
        """How the work is spread (for the report's ``wall_execution``)."""
        return {
            "backend": self.name,
            "address": self.address or "local",
            "workers": self.workers,
            "nodes": self.nodes,
            "cpus": self.cpus,
            "chunk": self.chunk,
        }

    def __enter__(self) -> RayBackend:
        return self.start()

    def start(self) -> RayBackend:
        """Connect to the cluster (or start Ray here); :meth:`close` disconnects."""
        try:
            import ray
        except ImportError:
            raise ConfigError(INSTALL_HINT) from None
        common: dict[str, Any] = {"log_to_driver": False, "logging_level": logging.WARNING}
        if self.address not in (None, "auto"):
            probe_address(self.address)
        try:
            if self.address is None:
                ray.init(
                    address="local",
                    num_cpus=self.workers or os.cpu_count() or 1,
                    include_dashboard=False,
                    object_store_memory=LOCAL_OBJECT_STORE,
                    # Ray runs its workers at niceness 15 by default: on a machine shared
                    # with other work they would get a fraction of the CPU that local
                    # processes (niceness 0) get.
                    _system_config={"worker_niceness": 0},
                    **common,
                )
            else:
                ray.init(address=self.address, **common)
        except (ConnectionError, ValueError, RuntimeError) as exc:
            where = f"the Ray cluster at {self.address}" if self.address else "a local Ray"
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise ConfigError(f"cannot start or reach {where}: {first}") from exc
        self._ray = ray
        self.cpus = int(ray.cluster_resources().get("CPU", 0))
        self.nodes = sum(1 for n in ray.nodes() if n.get("Alive"))
        self.workers = max(1, min(self.workers or self.cpus, self.episodes))
        self.chunk = chunk_size(self.episodes, self.workers)
        log.info(
            "Ray: %d node(s), %d CPU(s); %d tasks in flight of %d episodes each",
            self.nodes,
            self.cpus,
            self.workers,
            self.chunk,
        )
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Disconnect: stop a Ray started here, or end this job on the cluster.

        No ``ray.cancel``: when this driver disconnects, the cluster ends its job and kills the
        job's workers, tasks running or not (and Ray 2.60's driver can abort when a forced
        cancel races a task's reply).
        """
        ray, self._ray = self._ray, None
        self._pending.clear()
        if ray is not None:
            ray.shutdown()

    def results(self, jobs: Iterable[tuple[int, int]]) -> Iterator[list[dict[str, Any]]]:
        """Run ``jobs`` (``(index, seed)`` pairs) in chunks, yielding each chunk's records.

        Raises:
            EpisodeError: When an episode raises.
            Kr210SimError: When a chunk is lost for good (retries exhausted) or a node runs
                other library versions than this process.
        """
        from kr210_sim.util.versions import versions

        ray = self._ray
        assert ray is not None, "use RayBackend as a context manager"
        mine = versions()
        task = ray.remote(num_cpus=1, max_retries=MAX_RETRIES)(episode.run_chunk)
        todo = iter(jobs)

        def submit() -> None:
            while len(self._pending) < self.workers:
                chunk = list(islice(todo, self.chunk))
                if not chunk:
                    return
                ref = task.remote(
                    chunk, self.randomize, self.scene, self.ik, self.ik_timeout, self.perceive
                )
                self._pending[ref] = [i for i, _ in chunk]

        submit()
        while self._pending:
            done, _ = ray.wait(list(self._pending), num_returns=1)
            for ref in done:
                indices = self._pending.pop(ref)
                try:
                    out = ray.get(ref)
                except ray.exceptions.RayTaskError as exc:
                    cause = exc.cause if exc.cause is not None else exc
                    raise EpisodeError(
                        f"episodes {indices[0]}-{indices[-1]} raised "
                        f"{type(cause).__name__}: {cause}"
                    ) from None
                except ray.exceptions.RayError as exc:
                    first = str(exc).strip().splitlines()[0]
                    raise Kr210SimError(
                        f"Ray lost episodes {indices[0]}-{indices[-1]} after {MAX_RETRIES} "
                        f"retries ({type(exc).__name__}: {first}); the finished episodes are "
                        "kept: continue with --resume"
                    ) from None
                if out["versions"] != mine:
                    diff = {k: v for k, v in out["versions"].items() if mine.get(k) != v}
                    raise Kr210SimError(
                        f"a Ray node runs {diff}, this process { ({k: mine.get(k) for k in diff}) }"
                        ": install the same versions on every node"
                    )
                submit()
                yield out["records"]


def probe_address(address: str, timeout: float = CONNECT_TIMEOUT) -> None:
    """Fail in one line when nothing answers at a cluster's ``HOST:PORT`` (or
    ``ray://HOST:PORT``) within ``timeout`` [s]: Ray itself retries for minutes.

    Raises:
        ConfigError: The address is not HOST:PORT, or no connection could be made in time.
    """
    import socket

    where = address.removeprefix("ray://")
    host, sep, port = where.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ConfigError(f"--address {address!r}: expected auto or HOST:PORT")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout):
            pass
    except OSError as exc:
        why = "no answer" if isinstance(exc, TimeoutError) else exc.strerror or str(exc)
        raise ConfigError(
            f"cannot reach the Ray cluster at {address}: {why} within {timeout:g} s; "
            "is the head node running (ray start --head)?"
        ) from None

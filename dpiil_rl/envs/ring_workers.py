"""A batch of ring simulations, stepped in this process or spread over worker processes.

With ``workers = 0`` every simulation lives in the calling process. With ``workers = W > 0`` the N
simulations are split into W contiguous groups, each stepped by its own process; one step sends one
small numpy message per worker, so two workers give close to 2x on two cores (TorchRL's
``ParallelEnv`` did not, docs/design.md, "Measured pitfalls"). The policy always runs batched in the main process.
"""

from __future__ import annotations

import multiprocessing as mp
from multiprocessing.connection import Connection
from typing import Any, Sequence

import numpy as np

from dpiil_rl.envs.ring_task import RingGeometry

Frame = dict[str, np.ndarray]


def _stack(frames: Sequence[Frame]) -> Frame:
    return {key: np.stack([f[key] for f in frames]) for key in frames[0]}


def _worker(conn: Connection, geometry: RingGeometry, settings: Any, count: int) -> None:
    from dpiil_rl.envs.ring_sim import RingSim  # noqa: PLC0415

    try:
        sims = [RingSim(geometry, settings) for _ in range(count)]
        conn.send(("ready", None))
    except Exception as err:  # report a build failure to the parent instead of dying silently
        conn.send(("error", f"{type(err).__name__}: {err}"))
        return
    while True:
        command, payload = conn.recv()
        try:
            if command == "reset":
                conn.send(("ok", _stack([sims[i].reset(seed) for i, seed in payload])))
            elif command == "step":
                conn.send(("ok", _stack([sim.step(a) for sim, a in zip(sims, payload)])))
            elif command == "render":
                index, args = payload
                conn.send(("ok", sims[index].render(*args)))
            elif command == "close":
                for sim in sims:
                    sim.close()
                conn.send(("ok", None))
                return
        except Exception as err:
            conn.send(("error", f"{type(err).__name__}: {err}"))


class RingSimBatch:
    """``num_envs`` simulations: ``reset(indices, seeds)`` and ``step(actions [N, 6])`` return stacked frames."""

    def __init__(self, geometry: RingGeometry, settings: Any, num_envs: int, workers: int = 0) -> None:
        if int(workers) < 0:
            raise ValueError(f"workers = {workers}: expected 0 (simulate in this process) or a positive process count")
        self.num_envs = int(num_envs)
        # one simulation gains nothing from a process of its own: it runs here
        self.workers = min(int(workers), self.num_envs) if self.num_envs > 1 else 0
        self._sims: list[Any] = []
        self._conns: list[Connection] = []
        self._procs: list[Any] = []
        self._groups: list[range] = []
        if self.workers == 0:
            from dpiil_rl.envs.ring_sim import RingSim  # noqa: PLC0415

            self._sims = [RingSim(geometry, settings) for _ in range(self.num_envs)]
            return
        bounds = np.linspace(0, self.num_envs, self.workers + 1).round().astype(int)
        ctx = mp.get_context("spawn")  # never fork a process that holds torch threads
        for w in range(self.workers):
            group = range(int(bounds[w]), int(bounds[w + 1]))
            parent, child = ctx.Pipe()
            proc = ctx.Process(
                target=_worker, args=(child, geometry, settings, len(group)), daemon=True, name=f"ring-sim-{w}"
            )
            proc.start()
            self._conns.append(parent)
            self._procs.append(proc)
            self._groups.append(group)
        for w in range(self.workers):
            self._receive(w)

    # ---------------------------------------------------------------------------- commands
    def reset(self, indices: Sequence[int], seeds: Sequence[int]) -> Frame:
        """Reset the simulations ``indices`` with ``seeds``; frames in the order of ``indices``."""
        if not self._conns:
            return _stack([self._sims[i].reset(s) for i, s in zip(indices, seeds)])
        by_worker: dict[int, list[tuple[int, int]]] = {}
        order: list[tuple[int, int]] = []
        for i, seed in zip(indices, seeds):
            w = self._worker_of(i)
            by_worker.setdefault(w, []).append((i - self._groups[w].start, int(seed)))
            order.append((w, len(by_worker[w]) - 1))
        for w, items in by_worker.items():
            self._conns[w].send(("reset", items))
        results = {w: self._receive(w) for w in by_worker}
        return _stack([{k: v[j] for k, v in results[w].items()} for w, j in order])

    def step(self, actions: np.ndarray) -> Frame:
        if not self._conns:
            return _stack([sim.step(a) for sim, a in zip(self._sims, actions)])
        for w, group in enumerate(self._groups):
            self._conns[w].send(("step", actions[group.start : group.stop]))
        parts = [self._receive(w) for w in range(self.workers)]
        return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}

    def render(self, index: int, width: int, height: int, camera: str) -> np.ndarray:
        """RGB image ``[height, width, 3]`` of simulation ``index`` (see :meth:`RingSim.render`)."""
        if not self._conns:
            return self._sims[index].render(width, height, camera)
        w = self._worker_of(index)
        self._conns[w].send(("render", (index - self._groups[w].start, (width, height, camera))))
        return self._receive(w)

    def close(self) -> None:
        for sim in self._sims:
            sim.close()
        self._sims = []
        for conn, proc in zip(self._conns, self._procs):
            try:
                if proc.is_alive():
                    conn.send(("close", None))
                    if conn.poll(5):
                        conn.recv()
            except (BrokenPipeError, EOFError, OSError):
                pass
            proc.join(timeout=5)
            if proc.is_alive():
                proc.terminate()
        self._conns, self._procs = [], []

    # ---------------------------------------------------------------------------- helpers
    def _worker_of(self, index: int) -> int:
        for w, group in enumerate(self._groups):
            if index in group:
                return w
        raise IndexError(f"env index {index}: expected 0 <= index < {self.num_envs}")

    def _receive(self, w: int) -> Any:
        try:
            status, payload = self._conns[w].recv()
        except EOFError as err:
            raise RuntimeError(
                f"ring simulation worker {w} (pid {self._procs[w].pid}) died; see its stderr above"
            ) from err
        if status == "error":
            raise RuntimeError(f"ring simulation worker {w}: {payload}")
        return payload

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass

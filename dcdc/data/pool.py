"""The worker pool of ``dcdc generate --workers N``: workers that die with their parent.

Why not ``concurrent.futures``: its workers outlive a killed parent (they keep taking the
queued jobs and then idle forever), and Ctrl-C there still runs every queued job. Here:

- **One job at a time.** The parent hands a worker its next job only when the worker
  reports the previous one finished, over that worker's own pipe; nothing is queued
  ahead, so stopping the parent stops the work.
- **Parent death.** Each worker watches its parent: on Linux the kernel sends it SIGKILL
  when the parent dies (``prctl(PR_SET_PDEATHSIG)``), and everywhere a watchdog thread
  exits the worker once ``os.getppid()`` changes (checked every 0.2 s). A killed parent
  therefore leaves no worker behind; an in-flight trajectory dies with its worker, leaving
  at most a hidden temporary file that readers ignore and the next run deletes.
- **Ctrl-C / SIGTERM of the parent.** Workers ignore SIGINT (the terminal sends it to the
  whole process group; the parent decides). The parent stops handing out jobs, sends each
  busy worker SIGTERM (acted on at the end of its current frame, see
  :mod:`dcdc.data.interrupt`), waits, kills any worker still running after
  ``GRACE_S`` and deletes the temporary files of the jobs that were in flight: finished
  trajectories are complete files, in-flight ones are discarded.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
import time
import traceback

GRACE_S = 10.0  # how long stopped workers may take to reach the end of their step
WATCH_S = 0.2  # parent-death poll interval


def _die_with_parent(parent_pid: int) -> None:
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(WATCH_S)
        os._exit(1)
    threading.Thread(target=watch, daemon=True, name="dcdc-parent-watchdog").start()


def worker_main(conn, parent_pid: int, threads: int, out_dir: str, simulator: str,
                version) -> None:
    """A worker process: run the jobs the parent sends until it sends None."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent(parent_pid)
    from ..errors import DcdcError, Interrupted
    from . import interrupt
    from .jobs import run_job, set_threads
    try:
        with interrupt.handling((signal.SIGTERM,)):
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
            set_threads(threads)
            while True:
                try:
                    job = conn.recv()
                except (EOFError, OSError):
                    return
                if job is None:
                    return
                try:
                    rec = run_job(job, out_dir, simulator, lambda n: conn.send(("progress", n)), version)
                    conn.send(("done", rec))
                except Interrupted:
                    return
                except DcdcError as e:
                    conn.send(("user_error", str(e)))
                except (BrokenPipeError, EOFError):  # the parent is gone
                    return
                except BaseException:
                    conn.send(("crash", traceback.format_exc()))
    except (Interrupted, BrokenPipeError):  # SIGTERM from the parent, or the parent is gone
        return


def run_pool(jobs, workers: int, threads: int, out_dir, simulator: str, version,
             on_progress, on_result) -> None:
    """Run ``jobs`` on ``workers`` processes; ``on_progress(frames)`` per frame,
    ``on_result(record)`` per finished job. A DcdcError in a worker is re-raised here (after
    stopping the others); so is Ctrl-C / SIGTERM of this process."""
    import multiprocessing as mp
    from multiprocessing.connection import wait

    from ..errors import DcdcError
    from . import interrupt
    ctx = mp.get_context("spawn")
    todo = list(jobs)
    procs = []  # (process, connection)
    busy = {}  # connection -> (process, job)
    # started with SIGINT/SIGTERM blocked (the mask is inherited across fork and exec), so
    # a Ctrl-C during a worker's start-up cannot print a traceback from inside it
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        for _ in range(workers):
            here, there = ctx.Pipe()
            p = ctx.Process(target=worker_main, daemon=True, name="dcdc-generate-worker",
                            args=(there, os.getpid(), threads, str(out_dir), simulator, version))
            p.start()
            there.close()
            procs.append((p, here))
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)

    def give(p, conn):
        if todo:
            job = todo.pop(0)
            conn.send(job)
            busy[conn] = (p, job)
        else:
            conn.send(None)
    try:
        for p, conn in procs:
            give(p, conn)
        while busy:
            interrupt.check()  # Ctrl-C / SIGTERM of this process: stop handing out jobs
            sentinels = {p.sentinel: conn for conn, (p, _) in busy.items()}
            for r in wait(list(busy) + list(sentinels), timeout=WATCH_S):
                conn = sentinels.get(r, r)
                if conn not in busy:
                    continue
                p, job = busy[conn]
                try:
                    kind, payload = conn.recv() if conn.poll() else ("died", None)
                except (EOFError, OSError):
                    kind, payload = "died", None
                if kind == "progress":
                    on_progress(payload)
                    continue
                del busy[conn]
                if kind == "done":
                    on_result(payload)
                    give(p, conn)
                elif kind == "user_error":
                    raise DcdcError(payload)
                elif kind == "crash":
                    raise RuntimeError(f"worker failed on {job.name}:\n{payload}")
                else:
                    p.join(1.0)
                    raise DcdcError(f"the worker simulating {job.name} died (exit code {p.exitcode}; "
                                    "out of memory?); re-run the same command to resume")
    finally:
        _stop(procs, busy, out_dir)


def _stop(procs, busy, out_dir) -> None:
    """Stop every worker; delete the temporary files of jobs that were in flight."""
    from pathlib import Path

    from ..outputs import TMP_MARK
    for p, conn in procs:  # idle ones exit; one that just finished its job too
        try:
            conn.send(None)
        except (OSError, ValueError):
            pass
    for p, job in busy.values():
        if p.is_alive():
            p.terminate()  # SIGTERM: the worker stops at the end of its current frame
    deadline = time.time() + GRACE_S
    for p, _ in procs:
        p.join(max(0.0, deadline - time.time()))
        if p.is_alive():
            p.kill()
            p.join()
    for p, job in busy.values():
        for tmp in Path(out_dir).glob(f".{job.name}.h5{TMP_MARK}{p.pid}"):
            tmp.unlink(missing_ok=True)
    for _, conn in procs:
        conn.close()

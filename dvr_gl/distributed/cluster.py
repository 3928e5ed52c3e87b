"""Reaching a Dask cluster: ``local:N`` (a LocalCluster of N worker processes, one thread each,
closed afterwards), a scheduler's address, or a :class:`distributed.Client` the caller owns; and
what the workers' transfer logs say was moved between them."""

from __future__ import annotations

import contextlib
import logging
import re
import uuid
import warnings

from ..errors import DvrError, install_hint

EXTRA = "dask"


def _distributed():
    try:
        import distributed
    except ImportError:
        raise DvrError(f"--dask needs Dask's distributed scheduler: {install_hint(EXTRA)}") from None
    return distributed


@contextlib.contextmanager
def connect(dask):
    """A client for ``dask``: ``"local:N"``, an address (``tcp://host:8786``) or a Client (kept open)."""
    distributed = _distributed()
    if isinstance(dask, distributed.Client):
        yield dask
        return
    if not isinstance(dask, str) or not dask:
        raise DvrError(f"dask: give 'local:N' or a scheduler's address (tcp://host:8786) or a Client, got {dask!r}")
    local = re.fullmatch(r"local:(\d+)", dask)
    if dask.startswith("local") and not local:
        raise DvrError(f"--dask {dask}: a local cluster is 'local:N' with N worker processes, e.g. local:2")
    if local:
        n = int(local.group(1))
        if n < 1:
            raise DvrError(f"--dask {dask}: a local cluster needs at least 1 worker")
        check_local_workers(n, dask)
        # processes (one GL context each), one thread each: the renderer holds its process's context;
        # another cluster's HTTP port taken is no news to the user (this one takes another)
        warnings.filterwarnings("ignore", message="Port .* is already in use", category=UserWarning)
        with distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                      silence_logs=logging.ERROR) as cluster, distributed.Client(cluster) as client:
            client.wait_for_workers(n)  # every worker registered: the kd split counts them
            yield client
        return
    address = scheduler_address(dask)
    probe(address)  # a silent server: one line after TIMEOUT, before the client's own handshake (unbounded)
    try:
        client = distributed.Client(address, timeout=f"{TIMEOUT:g}s")
    except (OSError, TimeoutError, ValueError) as e:
        raise DvrError(f"--dask {dask}: cannot reach the scheduler ({e}); start one (dask scheduler) or use "
                       f"local:N") from None
    with client:
        yield client


#: Local workers per core at most, and the memory each takes (a Python process with numpy, Dask and a GL
#: context: 200-300 MB measured), counted against the memory budget.
WORKERS_PER_CORE = 4
WORKER_BYTES = 256 << 20


def check_local_workers(n: int, dask: str) -> None:
    """Refuse, before any process starts, a local cluster of more workers than the machine can hold."""
    import os

    from ..sandbox import check_bytes

    most = WORKERS_PER_CORE * (os.cpu_count() or 1)
    if n > most:
        raise DvrError(f"--dask {dask}: {n} local workers, over {most} ({WORKERS_PER_CORE} per core of this "
                       f"machine); use fewer, or a scheduler's address for a larger cluster")
    check_bytes(n * WORKER_BYTES, f"--dask {dask}: {n} local worker processes", "use fewer workers")


#: Seconds every exchange with a scheduler may take (connecting, its handshake, its identity, and between
#: the liveness checks while results are awaited: :func:`results`).
TIMEOUT = 10.0


def scheduler_address(dask: str) -> str:
    """``dask`` as a TCP address ``tcp://host:port`` (a bare ``host:port`` is TCP, as Dask takes it); other
    transports are refused in one line: ``tls://`` needs certificates this command cannot pass, ``ucx://``
    a package and hardware, ``inproc://`` the same process."""
    scheme, sep, rest = dask.partition("://")
    if not sep:
        scheme, rest = "tcp", dask
    if scheme.lower() != "tcp":
        raise DvrError(f"--dask {dask}: the {scheme}:// transport is not supported (TLS needs certificates, UCX "
                       f"its package); give a TCP address, tcp://host:8786, e.g. through an SSH tunnel, or local:N")
    host, colon, port = rest.rpartition(":")
    if host.startswith("[") and host.endswith("]"):  # an IPv6 address
        host = host[1:-1]
    if not colon or not host or not port.isdigit() or not 0 < int(port) < 65536 or "/" in rest:
        raise DvrError(f"--dask {dask}: not a scheduler address; give tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786, "
                       f"the port in 1..65535) or local:N")
    return f"tcp://{rest}"


def probe(address: str, timeout: float = TIMEOUT) -> None:
    """Connect to the scheduler at ``address``, shake hands and ask its identity, all within ``timeout``
    seconds (Dask's own timeout does not cover a server that accepts and never answers: the client waited
    past 300 s); one line if it does not answer as a scheduler."""
    import asyncio
    import socket

    from distributed.comm import connect as comm_connect

    host, _, port = address.removeprefix("tcp://").rpartition(":")
    try:  # nothing listening, or a name that does not resolve: at once (Dask retries until its timeout)
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
    except OSError as e:
        reason = e.strerror or str(e) or type(e).__name__
        raise DvrError(f"--dask {address}: cannot reach the scheduler ({reason}); start one (dask scheduler) or "
                       f"use local:N") from None

    async def identity():
        comm = await comm_connect(address, timeout=timeout)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:
        answer = asyncio.run(asyncio.wait_for(identity(), timeout))
    except (TimeoutError, asyncio.TimeoutError):
        raise DvrError(f"--dask {address}: the server did not answer as a Dask scheduler within {timeout:g} s; "
                       f"check the address (dask scheduler prints it) or use local:N") from None
    except (OSError, ValueError, TypeError) as e:
        raise DvrError(f"--dask {address}: cannot reach the scheduler ({e}); start one (dask scheduler) or use "
                       f"local:N") from None
    except Exception as e:  # a reply that is no Dask message (another protocol on that port)
        raise DvrError(f"--dask {address}: the server there is not a Dask scheduler ({type(e).__name__}); check "
                       f"the address or use local:N") from None
    if not isinstance(answer, dict) or answer.get("type") != "Scheduler":
        raise DvrError(f"--dask {address}: the server there is not a Dask scheduler; check the address or use "
                       f"local:N")


def results(client, futures: list, timeout: float = TIMEOUT) -> list:
    """The results of ``futures``, waited for as long as the work takes, but with the scheduler asked
    every ``timeout`` seconds whether it still answers (its identity, within ``timeout``): a scheduler
    gone silent is one line, never a wait without end."""
    import asyncio

    distributed = _distributed()
    while True:
        try:
            distributed.wait(futures, timeout=timeout)
            break
        except (TimeoutError, distributed.TimeoutError):
            pass
        try:
            client.sync(lambda: asyncio.wait_for(client.scheduler.identity(), timeout))
        except (TimeoutError, asyncio.TimeoutError, OSError) as e:
            raise DvrError(f"the Dask scheduler stopped answering ({type(e).__name__}) while the frames were "
                           f"rendered; check it and its workers, or use local:N") from None
    return client.gather(futures)


def place(client, value, addresses: list, name: str) -> list:
    """``value`` held on each worker (a future per address, in order): one small task each that
    returns it, pinned.  (Not ``client.scatter(broadcast=True)``, which hung now and then on a
    freshly started local cluster of four workers.)"""
    token = uuid.uuid4().hex[:10]
    return [client.submit(_hold, value, key=f"dvr-{name}-{i}-{token}", workers=[a], allow_other_workers=False,
                          pure=False) for i, a in enumerate(addresses)]


def _hold(value):
    return value


def workers_of(client) -> list[str]:
    """The workers' addresses, sorted (worker i of the kd split is the i-th)."""
    workers = sorted(client.scheduler_info(n_workers=-1)["workers"]) if _takes_n_workers(client) else \
        sorted(client.scheduler_info()["workers"])
    if not workers:
        raise DvrError("the Dask cluster has no workers: start some (dask worker ADDRESS)")
    return workers


def _takes_n_workers(client) -> bool:
    import inspect

    return "n_workers" in inspect.signature(client.scheduler_info).parameters


def _log_of(prefix: str, dask_worker=None):
    """This worker's transfers of keys starting with ``prefix``: received from other workers
    (``incoming``: key, bytes, from whom) and sent (``outgoing``, to other workers or the client)."""
    def entries(log):  # (key, bytes, peer, seconds the whole message took)
        return [(str(key), int(size), str(entry.get("who")), float(entry.get("duration", 0.0))) for entry in log
                for key, size in entry.get("keys", {}).items() if str(key).startswith(prefix)]
    return {"incoming": entries(dask_worker.transfer_incoming_log),
            "outgoing": entries(dask_worker.transfer_outgoing_log)}


def transfers(client, prefix: str) -> dict:
    """Per worker address: the transfers of keys starting with ``prefix`` (see :func:`_log_of`)."""
    return client.run(_log_of, prefix)

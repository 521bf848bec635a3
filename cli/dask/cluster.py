"""``depixel convert --dask``: reaching the cluster and checking it before a batch.

Everything that can make a batch hang or misreport is checked before the first task is
sent, each failure one line naming what to fix: the address (its form at once, then the
host and the port), a worker to run on (waited for at most ``--dask-timeout`` seconds), and,
on every worker, a probe (:func:`depixel_cli.dask.task.probe`) that imports depixel, compares
its version with this machine's, and exchanges files with this machine in the output folder:
the worker reads the batch's *run marker* written here, and writes a file read back here.
A worker that joins during the batch gets the same probe when it is first seen
(:func:`check_joined`): one that fails it is left out, not the batch.
"""
from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import re
import socket
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import depixel
from depixel.errors import DepixelError, display_name

from .task import probe

#: The form of a scheduler address's location: a host name, an IPv4 address or a bracketed
#: IPv6 address, then an optional port.
_LOCATION = re.compile(r"(?P<host>[A-Za-z0-9_](?:[A-Za-z0-9_.-]*[A-Za-z0-9_])?|\[[0-9A-Fa-f:.]+\])"
                       r"(?::(?P<port>[0-9]{1,5}))?")
DEFAULT_PORT = 8786  # the Dask scheduler's
#: Seconds between two looks at the scheduler while waiting for a worker.
POLL_SECONDS = 0.2


class DaskError(DepixelError):
    """The Dask extra is missing, or the cluster cannot run this batch (one line saying why)."""


def checked_address(address: str) -> tuple[str, str, int]:
    """``SCHEME://HOST:PORT`` from ``[SCHEME://]HOST[:PORT]`` (tcp and 8786 by default), with
    its host and port; a malformed address (refused before Dask is imported, ~0.5 s), a
    missing Dask extra or a scheme this machine cannot use is a :class:`DaskError`. Nothing
    is looked up."""
    scheme, sep, location = address.rpartition("://")
    scheme = scheme.lower() if sep else "tcp"
    match = _LOCATION.fullmatch(location)
    if not match or "://" in scheme:
        raise DaskError(f"--dask {address!r}: not a scheduler address; give tcp://HOST:PORT (the address "
                        "'dask scheduler' prints)")
    host, port = match["host"].strip("[]"), int(match["port"] or DEFAULT_PORT)
    if not 0 < port < 65536:
        raise DaskError(f"--dask {address}: port {port} is out of range")
    if scheme not in ("tcp", "tls", "ucx"):
        raise DaskError(f"--dask {address}: unknown scheme {scheme}://; use tcp:// or tls://")
    try:
        from distributed.security import Security  # noqa: PLC0415
    except ImportError:
        raise DaskError("--dask needs the Dask extra, not installed here: pip install '/path/to/depixel[dask]' "
                        "(depixel's source folder, or its wheel, with [dask])") from None
    if scheme == "tls" and Security().get_connection_args("client")["ssl_context"] is None:
        raise DaskError(f"--dask {address}: no TLS certificate is configured for this client: set "
                        "distributed.comm.tls.ca-file, .client.cert and .client.key in the Dask configuration")
    if scheme == "ucx" and importlib.util.find_spec("distributed_ucxx") is None:
        raise DaskError(f"--dask {address}: UCX needs the distributed-ucxx package, not installed here; "
                        "use tcp:// or tls://")
    return f"{scheme}://{match['host']}:{port}", host, port


def reachable(address: str, host: str, port: int, timeout: float) -> None:
    """Whether something listens at ``host:port`` (tcp:// and tls://), at once: an unknown
    host or a refused connection is a :class:`DaskError` (Dask itself retries until its
    timeout)."""
    if not address.startswith(("tcp://", "tls://")):
        return
    try:
        with socket.create_connection((host, port), timeout=timeout) as sock:
            if address.startswith("tls://"):  # a whole handshake: a bare connection would be logged as failed
                from distributed.security import Security  # noqa: PLC0415

                context = Security().get_connection_args("client")["ssl_context"]
                with context.wrap_socket(sock, server_hostname=host):
                    pass
    except socket.gaierror:
        raise DaskError(f"cannot reach the Dask scheduler at {address}: unknown host {host}") from None
    except TimeoutError:
        raise DaskError(f"cannot reach the Dask scheduler at {address}: no answer in {timeout:g} s "
                        "(--dask-timeout)") from None
    except OSError as exc:
        raise DaskError(f"cannot reach the Dask scheduler at {address} ({exc.strerror or exc})") from None


@contextlib.contextmanager
def quiet_dask(debug: bool = False) -> Iterator[None]:
    """Dask's own log lines and warnings off (this command says what happened in one line),
    unless ``debug``; restored after."""
    # Dask's configuration gives some of them their own level; tornado's logs what fails in
    # the client's event loop (a result that cannot be fetched from a scheduler gone)
    names = ["distributed", "tornado"] + [name for name in logging.root.manager.loggerDict
                                          if name.startswith(("distributed.", "tornado."))]
    levels = {name: logging.getLogger(name).level for name in names}
    if not debug:
        for name in names:
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    try:
        with warnings.catch_warnings():
            if not debug:
                warnings.simplefilter("ignore")
            yield
    finally:
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)


def connect(address: str, timeout: float):
    """A :class:`distributed.Client` of the scheduler at ``address`` (checked reachable)."""
    from distributed import Client  # noqa: PLC0415

    try:
        return Client(address, timeout=f"{timeout}s", set_as_default=False)
    except Exception as exc:  # a timeout, a closed connection, a TLS handshake, something not Dask
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DaskError(f"cannot reach the Dask scheduler at {address} ({text})") from None


def close(client) -> None:
    """Close the client without waiting for a scheduler that is gone, and without noise."""
    with contextlib.suppress(Exception):
        client.close(timeout=2)


def workers(client) -> dict[str, int]:
    """{worker address: threads} of the workers alive now (a round trip to the scheduler)."""
    return client.nthreads()


def wait_for_a_worker(client, address: str, timeout: float, stopped) -> bool:
    """Wait for at least one worker, at most ``timeout`` seconds (False when ``stopped()``
    first); none is a :class:`DaskError`."""
    deadline = time.monotonic() + timeout
    while not workers(client):
        if stopped():
            return False
        if time.monotonic() >= deadline:
            raise DaskError(f"no Dask worker joined the scheduler at {address} in {timeout:g} s (--dask-timeout)")
        time.sleep(POLL_SECONDS)
    return True


def check_workers(client, folder: Path, token: str, marker: Path) -> set[str]:
    """Run the probe on every worker; the first worker that cannot convert this batch, or
    whose files this machine would not see, is a :class:`DaskError` naming it. Returns the
    addresses of the workers checked."""
    found = client.run(probe, str(folder.absolute()), token, str(marker), on_error="return")
    for worker, result in sorted(found.items()):
        problem = worker_problem(worker, result, folder)
        if problem is not None:
            raise DaskError(problem)
    return set(found)


def check_joined(client, addresses: list[str], folder: Path, token: str, marker: Path) -> dict[str, str | None]:
    """Run the probe on workers that joined during the batch: {address: why it cannot
    convert this batch, or None}. A worker gone meanwhile is left out."""
    try:
        found = client.run(probe, str(folder.absolute()), token, str(marker), workers=addresses, on_error="return")
    except Exception:  # the scheduler went, or the workers did
        return {}
    return {worker: worker_problem(worker, result, folder) for worker, result in found.items()}


def worker_problem(worker: str, result, folder: Path) -> str | None:
    """Why the worker whose probe gave ``result`` cannot convert this batch (one line), or None."""
    folder = folder.absolute()
    shown, here = display_name(folder), depixel.__version__
    shared = ("the outputs must be on a filesystem that this machine and every worker share, at the same "
              "path (docs/scale.md)")
    if isinstance(result, BaseException):
        text = str(result)
        if "No module named" in text:
            module = re.search(r"No module named '?([\w.]+)", text)
            return (f"Dask worker {worker}: depixel is not installed there (no module "
                    f"{module[1] if module else 'depixel'}); install depixel {here} on every worker")
        return f"Dask worker {worker}: the probe failed there ({text.splitlines()[0] if text else ''})"
    where = f"Dask worker {worker} (host {result['host']})"
    if result["version"] != here:
        return f"{where} has depixel {result['version']}, this machine {here}: install the same version on every worker"
    if not result["sees_marker"]:
        return f"{where} does not see the output folder {shown} as this machine does: {shared}"
    if result["error"] is not None or result["probe"] is None:
        return f"{where} cannot write in the output folder {shown} ({result['error'] or 'read back differently'})"
    name = str(result["probe"])
    try:
        seen = (folder / name).read_text(encoding="ascii") == name
        (folder / name).unlink()
    except OSError:
        seen = False
    return None if seen else f"{where} writes files in {shown} that this machine does not see: {shared}"


def make_marker(folder: Path, token: str) -> Path:
    """Create the batch's run marker in ``folder`` (its content is the token)."""
    marker = (folder / f".depixel-run.{token}").absolute()
    try:
        fd = os.open(marker, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        with os.fdopen(fd, "w", encoding="ascii") as fh:
            fh.write(token)
    except OSError as exc:
        raise DaskError(f"cannot write in the output folder {display_name(folder)} ({exc.strerror or exc})") from None
    return marker

"""A Dask cluster on loopback from the real command lines (`python -m dask scheduler`, `... worker`), as a
user starts one: every socket, dashboards included, on 127.0.0.1; each process in its own session so a
test can kill one worker whole (nanny, worker process and the trial's simulator), as a lost machine.
With `tls`, over TLS as the README's recipe starts one (certificates from `temporary_certificates`)."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Self

import psutil

from pegbt.evaluation.cluster import ClusterTls
from pegbt.sim.process import free_port

REPO = Path(__file__).resolve().parents[1]
START_TIMEOUT_S = 120.0  # a loaded machine imports slowly


def temporary_certificates(folder: Path) -> ClusterTls:
    """A self-signed CA, certificate and key (Dask's `Security.temporary()`) written as PEM files."""
    from distributed.security import Security

    made = Security.temporary()
    files = ClusterTls(folder / "ca.pem", folder / "cert.pem", folder / "key.pem")
    files.ca_file.write_text(made.tls_ca_file)
    files.cert.write_text(made.tls_client_cert)
    files.key.write_text(made.tls_client_key)
    return files


def another_commit(folder: Path) -> Path:
    """A copy of the `pegbt` package committed to a git repository of its own in `folder`: what a worker
    started from another checkout runs."""
    checkout = folder / "checkout"
    shutil.copytree(REPO / "pegbt", checkout / "pegbt", ignore=shutil.ignore_patterns("__pycache__"))
    git = ["git", "-C", str(checkout), "-c", "user.name=t", "-c", "user.email=t@example.org"]
    subprocess.run([*git, "init", "-q"], check=True)
    subprocess.run([*git, "add", "."], check=True)
    subprocess.run([*git, "commit", "-q", "-m", "another commit"], check=True)
    return checkout


def placeholder_certificates(folder: Path) -> ClusterTls:
    """Three files that are there and say they are PEM, for checks made before any connection."""
    files = ClusterTls(folder / "ca.pem", folder / "cert.pem", folder / "key.pem")
    for path in (files.ca_file, files.cert, files.key):
        path.write_text("-----BEGIN CERTIFICATE-----\n")
    return files


def tls_options(tls: ClusterTls) -> list[str]:
    """The command line's `--tls-ca-file`, `--tls-cert` and `--tls-key` for `tls`."""
    return ["--tls-ca-file", str(tls.ca_file), "--tls-cert", str(tls.cert), "--tls-key", str(tls.key)]


class LocalDaskCluster:
    def __init__(self, workers: int, pythonpath: Path = REPO, tls: ClusterTls | None = None) -> None:
        self.port = free_port()
        self.address = f"{'tls' if tls else 'tcp'}://127.0.0.1:{self.port}"
        self.tls = tls
        self.tls_args = (
            []
            if tls is None
            else ["--tls-ca-file", str(tls.ca_file), "--tls-cert", str(tls.cert), "--tls-key", str(tls.key)]
        )
        self.env = {**os.environ, "PYTHONPATH": str(pythonpath)}
        self.cwd = pythonpath  # `python -m` puts the working directory first on the path
        protocol = ["--protocol", "tls"] if tls else []
        self.scheduler = self._start(
            "scheduler", "--host", "127.0.0.1", "--port", str(self.port), "--dashboard-address", "127.0.0.1:0",
            *protocol, *self.tls_args,
        )  # fmt: skip
        self.workers: list[subprocess.Popen] = []
        self._wait_for_port()
        for index in range(workers):
            self.add_worker(f"w{index}")
        self.wait_for_workers(workers)

    def _start(self, *args: str) -> subprocess.Popen:
        return subprocess.Popen(
            [sys.executable, "-m", "dask", *args],
            env=self.env,
            cwd=self.cwd,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )

    def add_worker(self, name: str) -> subprocess.Popen:
        worker = self._start(
            "worker", self.address, "--host", "127.0.0.1", "--nthreads", "1", "--name", name,
            "--dashboard-address", "127.0.0.1:0", *self.tls_args,
        )  # fmt: skip
        self.workers.append(worker)
        return worker

    def _wait_for_port(self) -> None:
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline:
            with socket.socket() as probe:
                if probe.connect_ex(("127.0.0.1", self.port)) == 0:
                    return
            time.sleep(0.2)
        raise TimeoutError(f"no Dask scheduler on {self.address} after {START_TIMEOUT_S:g} s")

    def wait_for_workers(self, count: int) -> None:
        from distributed import Client
        from distributed.security import Security

        security = None
        if self.tls is not None:
            security = Security(
                tls_ca_file=str(self.tls.ca_file),
                tls_client_cert=str(self.tls.cert),
                tls_client_key=str(self.tls.key),
                require_encryption=True,
            )
        with Client(self.address, timeout=START_TIMEOUT_S, set_as_default=False, security=security) as client:
            client.wait_for_workers(count, timeout=START_TIMEOUT_S)

    def kill_worker_mid_trial(self, worker: subprocess.Popen, timeout: float = 120.0) -> None:
        """SIGKILL the worker's whole session once its trial's simulator runs."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if any(_is_simulator(child) for child in psutil.Process(worker.pid).children(recursive=True)):
                os.killpg(worker.pid, signal.SIGKILL)
                worker.wait(timeout=10)
                return
            time.sleep(0.05)
        raise TimeoutError(f"no simulator started under worker {worker.pid} within {timeout:g} s")

    def close(self) -> None:
        for process in [*self.workers, self.scheduler]:
            _signal_session(process, signal.SIGTERM)
        for process in [*self.workers, self.scheduler]:
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                _signal_session(process, signal.SIGKILL)
                process.wait(timeout=10)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _signal_session(process: subprocess.Popen, signum: int) -> None:
    try:
        os.killpg(process.pid, signum)
    except ProcessLookupError:
        pass


def _is_simulator(process: psutil.Process) -> bool:
    try:
        command = process.cmdline()
    except psutil.Error:
        return False
    return "pegbt" in command and "sim" in command

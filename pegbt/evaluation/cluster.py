"""`pegbt eval --cluster`: a campaign's trials as tasks on an existing Dask scheduler.

Each task runs `run_trial` on its worker exactly as a local worker process does: its own simulator on a
free port of the worker's loopback, seeded, so a seed gives the same result wherever it runs. Dask
reschedules the task of a worker that is lost mid-trial (up to the scheduler's `allowed-failures`); a
trial that fails for its own reasons comes back as its error record, as it does locally, and is not
retried. Workers must run the client's pegbt version and commit (they read `trees/` and `skills/` from
their own checkout): any other worker is refused before a trial is sent, and a worker that joins later
refuses its tasks. Tick logs and simulator logs are written straight to `--out` when the workers see it
(a shared file system), else in the worker's scratch space and sent back with the record.

Whoever reaches a Dask scheduler can have its workers run any code. Over `tls://` (`ClusterTls`: a CA and
this client's certificate and key, or Dask's `distributed.comm.tls` configuration) client, scheduler and
workers prove to each other that they hold certificates of the same CA, and everything they send is
encrypted (`distributed.security.Security`); a `tcp://` scheduler off loopback is warned about.

Dask is imported only here, and this module only with `--cluster`.
"""

from __future__ import annotations

import ipaddress
import re
import secrets
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING

import pegbt
from pegbt.errors import PegbtError
from pegbt.evaluation.trial import TrialRecord, TrialSpec, run_trial, truth_path

if TYPE_CHECKING:
    from distributed import Client, Future
    from distributed.security import Security

ADDRESS = re.compile(r"^(tcp|tls)://([^\s/:]+):\d{1,5}$")
TLS_OPTIONS = ("--tls-ca-file", "--tls-cert", "--tls-key")
CONNECT_TIMEOUT_S = 30.0
WORKER_WAIT_S = 60.0  # for the first worker of a scheduler that has none yet
TRIAL_RESOURCE = "trial"  # a worker started with `--resources trial=1` runs one trial at a time


@dataclass(frozen=True)
class Checkout:
    """Which pegbt a process runs: its version and the git commit of the checkout it imports from."""

    version: str
    commit: str | None  # None outside a git checkout
    path: str

    def same_code(self, other: Checkout) -> bool:
        return (self.version, self.commit) == (other.version, other.commit)

    def describe(self) -> str:
        return f"pegbt {self.version} at commit {self.commit or 'unknown'} ({self.path})"


@cache
def this_checkout() -> Checkout:
    """This process's `Checkout` (what `client.run` asks every worker for)."""
    root = Path(pegbt.__file__).resolve().parents[1]
    try:
        commit = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"],
            check=False,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.TimeoutExpired):
        commit = ""
    return Checkout(pegbt.__version__, commit or None, str(root))


class MismatchedWorker(PegbtError):
    """A worker runs other code than the client."""


def mismatch_message(worker: str, theirs: Checkout, ours: Checkout) -> str:
    return (
        f"worker {worker} runs {theirs.describe()}, this client {ours.describe()}: start every worker "
        f"from a checkout of the same commit (git checkout {ours.commit or ours.version})"
    )


@dataclass(frozen=True)
class RemoteTrial:
    """What a task needs: the trial, its fault plan's and world file's texts (the worker may not see the
    client's files), the client's checkout, and the marker file whose token shows the worker sees `--out`
    itself."""

    spec: TrialSpec
    plan: str | None
    client: Checkout
    marker: Path | None
    token: str
    world: str | None = None  # the world file's text, as the plan's


@dataclass
class RemoteResult:
    record: TrialRecord
    files: dict[str, bytes]  # kept logs by file name, when the worker could not write them to `--out`


def run_remote_trial(task: RemoteTrial) -> RemoteResult:
    """On a worker: refuse other code, then run the trial into `--out` if shared, else into scratch space."""
    ours = this_checkout()
    if not ours.same_code(task.client):
        raise MismatchedWorker(mismatch_message(_worker_address(), ours, task.client), field="--cluster")
    if task.marker is not None and _sees(task.marker, task.token):
        return RemoteResult(run_trial(task.spec), {})
    with tempfile.TemporaryDirectory(prefix="pegbt-trial-") as scratch:
        local = Path(scratch)
        plan = world = None
        if task.plan is not None:
            plan = local / "faults.yaml"
            plan.write_text(task.plan)
        if task.world is not None:
            world = local / "world.yaml"
            world.write_text(task.world)
        spec = replace(task.spec, log=local / task.spec.log.name, faults=plan, world_effects=world)
        record = run_trial(spec)
        kept = [spec.log, truth_path(spec.log)] if record.log else []
        return RemoteResult(record, {path.name: path.read_bytes() for path in kept if path.exists()})


def _sees(marker: Path, token: str) -> bool:
    try:
        return marker.read_text() == token
    except OSError:
        return False


def _worker_address() -> str:
    from distributed import get_worker

    return get_worker().address


@dataclass(frozen=True)
class ClusterTls:
    """The files of `--tls-ca-file`, `--tls-cert` and `--tls-key` (PEM), as `dask worker` takes them."""

    ca_file: Path
    cert: Path
    key: Path


def run_trials_on_cluster(
    specs: list[TrialSpec],
    address: str,
    done: Callable[[TrialRecord], None] | None = None,
    one_per_worker: bool = False,
    shared: bool = True,
    tls: ClusterTls | None = None,
) -> tuple[list[TrialRecord], int]:
    """Run every spec as a task on the Dask scheduler at `address`; return the records in spec order and
    how many trials could run at once. `done` is called with each record as it comes back.
    `one_per_worker`: each task takes the workers' `trial` resource (real-time trials must not share a
    worker). `shared=False`: send every log back, even to a worker that sees `--out`. `tls`: the
    certificates for a `tls://` address (else Dask's configuration)."""
    client = connect(address, tls)
    try:
        workers = check_workers(client, one_per_worker)
        records = _run(client, specs, done, one_per_worker, shared)
    finally:
        client.close()
    return records, workers


def check_address(address: str, tls: ClusterTls | None = None) -> None:
    """A `PegbtError` for an address that is not `tcp://HOST:PORT` or `tls://HOST:PORT`, for certificates
    given with a `tcp://` address, or for a certificate file that cannot be read."""
    match = ADDRESS.match(address)
    if match is None:
        raise PegbtError(
            f"expected a scheduler address tls://HOST:PORT or tcp://HOST:PORT, got {address!r}",
            field="--cluster",
        )
    if tls is None:
        return
    if match.group(1) != "tls":
        raise PegbtError(
            f"{', '.join(TLS_OPTIONS)} are for a tls:// scheduler, not {address}", field="--cluster"
        )
    for option, path in zip(TLS_OPTIONS, (tls.ca_file, tls.cert, tls.key), strict=True):
        if not path.is_file():
            raise PegbtError("no such certificate file", file=path, field=option)


def exposure_warning(address: str) -> str | None:
    """What a `tcp://` scheduler off loopback exposes, or None (loopback, or `tls://`)."""
    match = ADDRESS.match(address)
    if match is None or match.group(1) != "tcp" or _is_loopback(match.group(2)):
        return None
    return (
        f"pegbt: warning: {address} is plain TCP: anyone who can reach that port can run any code on the "
        "workers and read the trials; use tls:// with --tls-ca-file, --tls-cert and --tls-key "
        "(dask scheduler --protocol tls ...)"
    )


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:  # a host name: where it leads is not known here
        return False


def connect(address: str, tls: ClusterTls | None = None) -> Client:
    """A client of the scheduler at `address`, or a `PegbtError` saying what is wrong."""
    check_address(address, tls)
    try:
        from distributed import Client
    except ImportError:
        raise PegbtError("needs Dask's distributed: pip install -e '.[cluster]'", field="--cluster") from None
    warning = exposure_warning(address)
    if warning is not None:
        print(warning, file=sys.stderr, flush=True)
    security = _security(address, tls)
    try:
        return Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False, security=security)
    except (OSError, TimeoutError) as error:
        raise PegbtError(
            f"cannot reach the Dask scheduler at {address}: {error}", field="--cluster"
        ) from None


def _security(address: str, tls: ClusterTls | None) -> Security | None:
    """The client's `Security` for a `tls://` address: from `tls`, else from Dask's configuration."""
    if not address.startswith("tls://"):
        return None
    from distributed.security import Security

    if tls is not None:
        return Security(
            tls_ca_file=str(tls.ca_file),
            tls_client_cert=str(tls.cert),
            tls_client_key=str(tls.key),
            require_encryption=True,
        )
    configured = Security(require_encryption=True)
    # its fields are __slots__ set from the configuration by name, which the stubs do not declare
    if (
        getattr(configured, "tls_ca_file", None) is None
        or getattr(configured, "tls_client_cert", None) is None
    ):
        raise PegbtError(
            f"{address} needs {', '.join(TLS_OPTIONS)} (or Dask's distributed.comm.tls configuration: "
            "ca-file, client.cert, client.key)",
            field="--cluster",
        )
    return configured


def check_workers(client: Client, one_per_worker: bool) -> int:
    """Refuse any worker that runs other code than this client (or, for `one_per_worker`, that lacks the
    `trial` resource); return how many trials the workers run at once."""
    assert client.scheduler is not None  # a connected client's
    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT_S)
    except TimeoutError:
        raise PegbtError(
            f"the scheduler has had no worker for {WORKER_WAIT_S:g} s; start some with "
            f"`dask worker {client.scheduler.address}`",
            field="--cluster",
        ) from None
    ours = this_checkout()
    try:
        theirs = client.run(this_checkout)
    except ImportError as error:
        raise MismatchedWorker(f"a worker cannot import pegbt ({error})", field="--cluster") from None
    for worker, checkout in sorted(theirs.items()):
        if not checkout.same_code(ours):
            raise MismatchedWorker(mismatch_message(worker, checkout, ours), field="--cluster")
    info = client.scheduler_info(n_workers=-1)["workers"]
    if not one_per_worker:
        return sum(worker["nthreads"] for worker in info.values())
    slots = sum(int(worker.get("resources", {}).get(TRIAL_RESOURCE, 0)) for worker in info.values())
    if not slots:
        raise PegbtError(
            f"one trial per worker needs workers started with `--resources {TRIAL_RESOURCE}=1`",
            field="--cluster",
        )
    return slots


def _run(
    client: Client,
    specs: list[TrialSpec],
    done: Callable[[TrialRecord], None] | None,
    one_per_worker: bool,
    shared: bool,
) -> list[TrialRecord]:
    from distributed import as_completed

    token = secrets.token_hex(8)
    marker = specs[0].log.parent.resolve() / f".pegbt-cluster-{token}" if shared else None
    if marker is not None:
        marker.write_text(token)
    ours = this_checkout()
    resources = {TRIAL_RESOURCE: 1} if one_per_worker else None
    futures: dict[Future, TrialSpec] = {}
    for spec in specs:
        plan = None if spec.faults is None else Path(spec.faults).read_text()
        faults = None if spec.faults is None else Path(spec.faults).resolve()
        world = None if spec.world_effects is None else Path(spec.world_effects).read_text()
        effects = None if spec.world_effects is None else Path(spec.world_effects).resolve()
        absolute = replace(  # a worker's directory is its own
            spec, log=spec.log.resolve(), faults=faults, world_effects=effects
        )
        task = RemoteTrial(absolute, plan, ours, marker, token, world)
        key = f"pegbt-trial-{spec.seed}-{token}"
        futures[client.submit(run_remote_trial, task, key=key, pure=False, resources=resources)] = spec
    by_seed: dict[int, TrialRecord] = {}
    try:
        for future in as_completed(futures, loop=client.loop):
            spec = futures[future]
            record = _collect(future, spec)
            by_seed[spec.seed] = record
            if done is not None:
                done(record)
    except BaseException:
        client.cancel(list(futures))
        raise
    finally:
        if marker is not None:
            marker.unlink(missing_ok=True)
    return [by_seed[spec.seed] for spec in specs]


def _collect(future: Future, spec: TrialSpec) -> TrialRecord:
    """The future's record, its logs written where the client expects them; a trial whose workers kept
    dying (the scheduler gave up on it) is an error record, as a trial whose simulator died is."""
    from distributed import KilledWorker

    try:
        result: RemoteResult = future.result()
    except KilledWorker as error:
        return TrialRecord(spec.variant, spec.condition, spec.seed, "error", error=f"workers lost: {error}")
    record = result.record
    for name, content in result.files.items():
        (spec.log.parent / name).write_bytes(content)
    if record.log:
        record.log = str(spec.log)
    return record

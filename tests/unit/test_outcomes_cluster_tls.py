"""`pegbt eval --cluster`, `pegbt sim2real outcomes --cluster` and `pegbt bench sim2real-outcomes --cluster`
take the same TLS options, check them the same way before any connection (certificates only with
`tls://`, all three or none, each file there) and hand them to the connection."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.evaluation import cluster
from pegbt.evaluation.cluster import ClusterTls
from tests.cluster_helpers import placeholder_certificates, tls_options

COMMANDS = {
    "eval": ["eval", "--variant", "bilateral", "--condition", "optimized", "--trials", "1"],
    "outcomes": ["sim2real", "outcomes", "--table", "paper", "--fit", "unilateral"],
    "bench": ["bench", "sim2real-outcomes", "--families", "null", "--seeds", "1"],
}


@pytest.mark.parametrize("command", COMMANDS)
def test_certificates_go_with_a_tls_address_only(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv, pem = [*COMMANDS[command], "--out", str(tmp_path / "out")], placeholder_certificates(tmp_path)
    assert main([*argv, "--cluster", "tcp://127.0.0.1:8786", *tls_options(pem)]) == 2
    assert "are for a tls:// scheduler" in capsys.readouterr().err
    assert main([*argv, *tls_options(pem)]) == 2
    assert "the --tls options are for --cluster" in capsys.readouterr().err
    assert main([*argv, "--cluster", "tls://127.0.0.1:8786", *tls_options(pem)[:4]]) == 2
    assert "--tls-key: give all of --tls-ca-file, --tls-cert, --tls-key, or none" in capsys.readouterr().err
    pem.key.unlink()
    assert main([*argv, "--cluster", "tls://127.0.0.1:8786", *tls_options(pem)]) == 2
    err = capsys.readouterr().err
    assert str(pem.key) in err and "--tls-key" in err and err.count("\n") == 1


@pytest.mark.parametrize("command", COMMANDS)
def test_the_certificates_reach_the_connection(
    command: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    pem = placeholder_certificates(tmp_path)
    asked: list[tuple[str, ClusterTls | None]] = []

    def refused(address: str, tls: ClusterTls | None = None) -> None:  # no connection is made in a test
        asked.append((address, tls))
        raise PegbtError("refused here", field="--cluster")

    monkeypatch.setattr(cluster, "connect", refused)
    address = "tls://127.0.0.1:8786"
    assert main([*COMMANDS[command], "--cluster", address, *tls_options(pem)]) == 2
    assert asked == [(address, pem)]
    assert "refused here" in capsys.readouterr().err

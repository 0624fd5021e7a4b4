"""`pegbt eval --cluster`'s address and TLS options, checked before any connection (the options themselves,
shared with `pegbt sim2real outcomes` and the benchmark: `test_outcomes_cluster_tls.py`); `tls://` without
certificates (and without Dask's TLS configuration) named; a plain `tcp://` scheduler off loopback warned about, as Dask's own documentation
warns (anyone who reaches it can run code on the workers)."""

from __future__ import annotations

import pytest

from pegbt.cli import main
from pegbt.evaluation.cluster import exposure_warning

EVAL = ["eval", "--variant", "bilateral", "--condition", "optimized", "--trials", "1"]


@pytest.mark.parametrize(
    "address", ["tcp://10.1.2.3:8786", "tcp://sched.example.org:8786", "tcp://0.0.0.0:8786"]
)
def test_a_plain_tcp_scheduler_off_loopback_is_warned_about(address):
    warning = exposure_warning(address)
    assert warning is not None and address in warning
    assert "anyone who can reach that port can run any code on the workers" in warning and "tls://" in warning


@pytest.mark.parametrize(
    "address", ["tcp://127.0.0.1:8786", "tcp://127.3.4.5:8786", "tcp://localhost:8786", "tls://10.1.2.3:8786"]
)
def test_loopback_and_tls_schedulers_are_not_warned_about(address):
    assert exposure_warning(address) is None


def test_a_tls_address_without_certificates_says_which_options_it_needs(tmp_path, capsys):
    status = main([*EVAL, "--out", str(tmp_path / "out"), "--cluster", "tls://127.0.0.1:8786"])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1
    assert "needs --tls-ca-file, --tls-cert, --tls-key (or Dask's distributed.comm.tls configuration" in err


def test_connecting_to_a_plain_tcp_scheduler_off_loopback_prints_the_warning_first(monkeypatch, capsys):
    import distributed

    from pegbt.errors import PegbtError
    from pegbt.evaluation.cluster import connect

    def unreachable(address, **options):  # no packet leaves this machine in a test
        assert options["security"] is None
        raise OSError("connection refused")

    monkeypatch.setattr(distributed, "Client", unreachable)
    with pytest.raises(PegbtError, match="cannot reach the Dask scheduler at tcp://10.1.2.3:8786"):
        connect("tcp://10.1.2.3:8786")
    assert "anyone who can reach that port can run any code on the workers" in capsys.readouterr().err

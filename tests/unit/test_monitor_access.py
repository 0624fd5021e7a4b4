"""Who may read a run from the monitor: only its own page, holding the token printed in its URL, reached by
127.0.0.1 or localhost on its port; nothing a page sends, or fails to read, reaches the run's memory."""

from __future__ import annotations

import logging
import socket
import time

import pytest

from pegbt.bench.monitor_clients import (
    frame_header,
    http_status,
    open_socket,
    read_frame,
    read_messages,
    upgrade_status,
)
from pegbt.monitor.options import start_server
from pegbt.monitor.server import CLIENT_BUFFER, MAX_CLIENTS, MAX_MESSAGE, start_ephemeral

HEADER = {"type": "header", "tree": "t.yaml", "nodes": [], "blackboard": {}}


@pytest.fixture
def server():
    server = start_ephemeral([{"type": "mode", "mode": "live", "log": "run.jsonl"}, HEADER])
    yield server
    server.stop()


def test_the_page_with_the_token_gets_the_run(server):
    assert server.url == f"http://127.0.0.1:{server.port}/?token={server.token}"
    assert len(server.token) >= 32
    for origin in (f"http://127.0.0.1:{server.port}", f"http://localhost:{server.port}"):
        status, connection = open_socket(server.port, token=server.token, origin=origin)
        with connection:
            assert status == 101
            assert [message["type"] for message in read_messages(connection)] == ["mode", "header"]


@pytest.mark.parametrize(
    "origin",
    ["http://evil.example", "null", "", "http://127.0.0.1:1", "https://127.0.0.1:{port}", "http://127.0.0.1"],
)
def test_an_upgrade_from_another_origin_is_refused(server, origin):
    assert upgrade_status(server.port, token=server.token, origin=origin.format(port=server.port)) == 403


@pytest.mark.parametrize(
    "wrong",
    [
        lambda token: None,
        lambda token: "",
        lambda token: "wrong",
        lambda token: "%C3%A9" * len(token),  # not ASCII once decoded
        lambda token: "%FF%FE",  # not UTF-8
        lambda token: token + "x",
        lambda token: token[:-1],
        lambda token: token.upper(),
    ],
)
def test_an_upgrade_without_the_token_is_refused(server, wrong):
    assert upgrade_status(server.port, token=wrong(server.token)) == 403


@pytest.mark.parametrize(
    "host", ["attacker.example:{port}", "attacker.example", "127.0.0.1", "", "127.0.0.2:{port}"]
)
def test_a_request_for_another_host_is_refused(server, host):
    host = host.format(port=server.port)
    assert upgrade_status(server.port, token=server.token, host=host) in (400, 403)
    if host:
        assert http_status(server.port, "/", host) == 403
        assert http_status(server.port, "/static/dist/monitor.js", host) == 403
    assert http_status(server.port, "/", f"localhost:{server.port}") == 200


@pytest.mark.parametrize(
    "request_bytes",
    [
        b"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\x00\r\n\r\n",
        b"GET / HTTP/1.1\r\nHost: " + b"h" * 9000 + b"\r\n\r\n",
        b"GET / HTTP/9.9\r\nHost: 127.0.0.1:{port}\r\n\r\n",
        b"POST / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n\r\n",
    ],
)
def test_a_malformed_request_is_answered_400_without_a_logged_traceback(server, request_bytes, caplog):
    with socket.create_connection(("127.0.0.1", server.port), timeout=10) as connection:
        connection.sendall(request_bytes.replace(b"{port}", str(server.port).encode()))
        assert connection.recv(12)[8:] == b" 400"
    time.sleep(0.1)
    assert [r for r in caplog.records if r.levelno >= logging.ERROR] == []


def test_without_a_token_the_origin_is_still_checked(capsys):
    server = start_server(0, no_token=True)
    server.publish(HEADER)
    try:
        assert "any program on this machine that connects to port" in capsys.readouterr().err
        assert server.url == f"http://127.0.0.1:{server.port}/"
        assert upgrade_status(server.port, token=None) == 101
        assert upgrade_status(server.port, token=None, origin="http://evil.example") == 403
    finally:
        server.stop()


def test_a_message_past_the_limit_closes_its_socket_at_the_header(server):
    status, connection = open_socket(server.port, token=server.token)
    with connection:
        assert status == 101
        read_messages(connection)
        connection.sendall(frame_header(400 * 1024 * 1024) + b"x" * 65536)  # declares 400 MB
        opcode, payload = read_frame(connection)
        assert opcode == 0x8 and int.from_bytes(payload[:2], "big") == 1009  # close: message too big
    status, small = open_socket(server.port, token=server.token)
    with small:
        read_messages(small)
        small.sendall(frame_header(MAX_MESSAGE - 1) + b"x" * (MAX_MESSAGE - 1))  # under it: taken, ignored
        server.publish({"type": "tick", "n": 1, "t": 0.02, "changes": []})
        assert read_messages(small) == [{"type": "tick", "n": 1, "t": 0.02, "changes": []}]


def test_a_page_that_never_reads_is_dropped_and_the_others_still_get_every_message(server):
    status, stuck = open_socket(server.port, token=server.token)
    stuck.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    status, reader = open_socket(server.port, token=server.token)
    assert status == 101
    read_messages(reader)
    big = "x" * 100_000
    sent = 0
    deadline = time.monotonic() + 60
    while server.dropped == 0 and time.monotonic() < deadline:
        sent += 1
        server.publish({"type": "world", "n": sent, "t": sent * 0.02, "note": big})
        received = 0
        while received < sent:  # the reading page keeps up
            received = max(message["n"] for message in read_messages(reader))
    assert server.dropped == 1 and server.clients == 1
    assert sent * len(big) < 4 * CLIENT_BUFFER + 64 * 1024 * 1024  # dropped once its buffers were full
    stuck.close()
    reader.close()


def test_pages_past_the_limit_are_refused_and_the_others_kept(server):
    pages = [open_socket(server.port, token=server.token) for _ in range(MAX_CLIENTS)]
    try:
        assert {status for status, _ in pages} == {101}
        assert upgrade_status(server.port, token=server.token) == 503
        server.publish({"type": "tick", "n": 1, "t": 0.02, "changes": []})
        for _, connection in pages:
            read_messages(connection)  # the snapshot
            assert read_messages(connection)[0]["n"] == 1
    finally:
        for _, connection in pages:
            connection.close()

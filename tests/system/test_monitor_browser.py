"""The monitor page in a real browser (Debian's chromium driven by Playwright): live, replay, stepping, size.

The page is checked against the project's own readers it must agree with: `pegbt log replay --tick N` for
the statuses after a tick, `pegbt log why` for the first cause.
"""

from __future__ import annotations

import re
import signal
import time
from pathlib import Path

import pytest
from playwright.sync_api import Page, sync_playwright

from pegbt.bench.chromium import headless_chromium
from pegbt.bench.monitor import wide_tree
from pegbt.cli import main
from pegbt.monitor.history import History
from pegbt.monitor.replay import replay_messages
from pegbt.monitor.server import MonitorServer, start_ephemeral
from pegbt.sim.process import free_port

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "trees" / "example.yaml"
MARKS = {"[S]": "SUCCESS", "[F]": "FAILURE", "[R]": "RUNNING", "[ ]": "INVALID"}
FAILING = """\
blackboard: {gripper_ok: false}
tree:
  sequence:
    name: failing
    children:
      - log: {name: start, message: starting}
      - selector:
          name: pick one way or another
          children:
            - scripted: {name: first try, outcomes: [running, failure], message: slipped}
            - check_blackboard: {name: gripper holds, key: gripper_ok, value: true}
      - log: {name: never reached, message: done}
"""


@pytest.fixture(scope="module")
def browser():
    with sync_playwright() as playwright:
        browser = headless_chromium(playwright)
        yield browser
        browser.close()


@pytest.fixture
def page(browser):
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    errors: list[str] = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    yield page
    page.close()
    assert not errors, errors


def serve_replay(log: Path) -> MonitorServer:
    return start_ephemeral(replay_messages(log), history=History.whole())


def run_log(tmp_path: Path, tree_text: str | None, name: str, capsys) -> Path:
    tree = EXAMPLE
    if tree_text is not None:
        tree = tmp_path / f"{name}.yaml"
        tree.write_text(tree_text)
    log = tmp_path / f"{name}.jsonl"
    main(["run", str(tree), "--clock", "manual", "--log", str(log), "--quiet"])
    capsys.readouterr()
    return log


def rendered_statuses(page: Page) -> dict[int, str]:
    """Every row's status, scrolling the virtualised list from top to bottom."""
    statuses: dict[int, str] = {}
    page.evaluate("document.getElementById('tree').scrollTop = 0")
    while True:
        page.wait_for_timeout(50)
        for row in page.query_selector_all("#tree .row"):
            statuses[int(row.get_attribute("data-id"))] = row.get_attribute("data-status")
        at_end = page.evaluate(
            "(() => { const e = document.getElementById('tree'); const end = e.scrollTop + e.clientHeight >= "
            "e.scrollHeight - 1; e.scrollTop += e.clientHeight / 2; return end; })()"
        )
        if at_end:
            return statuses


def replayed_statuses(log: Path, tick: int, capsys) -> list[str]:
    assert main(["log", "replay", str(log), "--tick", str(tick)]) == 0
    lines = capsys.readouterr().out.splitlines()[1:]
    statuses = []
    for line in lines:
        if line == "blackboard:":
            break
        statuses.append(MARKS[line.strip()[:3]])
    return statuses


def test_live_page_shows_the_tick_count_and_the_running_node_change(tmp_path, pegbt_cli, page):
    tree = tmp_path / "waits.yaml"
    # the first wait gives the page time to load on a loaded machine; the page must see two of the six running
    tree.write_text(
        "tree:\n  sequence:\n    name: waits\n    children:\n"
        + "".join(
            f"      - wait: {{name: wait {i}, seconds: {4.0 if i == 1 else 0.6}}}\n" for i in range(1, 7)
        )
    )
    port = free_port()
    process = pegbt_cli.start("run", tree, "--monitor", port, "--log", tmp_path / "waits.jsonl")
    try:
        url = re.fullmatch(r"monitor: (\S+)", process.stdout.readline().strip()).group(1)
        assert re.fullmatch(rf"http://127\.0\.0\.1:{port}/\?token=[\w-]{{43}}", url)
        page.goto(url)
        ticks, running = set(), set()
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and page.text_content("#outcome") != "success":
            ticks.add(int(page.text_content("#tick")))
            running.update(item.text_content() for item in page.query_selector_all("#running li"))
            page.wait_for_timeout(40)
        assert page.text_content("#outcome") == "success"
        assert page.text_content("#mode") == "live"
        assert len(ticks) >= 3, ticks
        assert len(running) >= 2 and all(re.fullmatch(r"/waits/wait \d.*", item) for item in running), running
    finally:
        process.send_signal(signal.SIGINT)  # the page stays up after the run until Ctrl-C
        _, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    assert "Traceback" not in err


def test_replay_of_a_failed_run_shows_its_nodes_and_the_first_cause(tmp_path, page, capsys):
    log = run_log(tmp_path, FAILING, "failing", capsys)
    assert main(["log", "why", str(log)]) == 0
    why = capsys.readouterr().out
    first_cause = re.search(r"first cause: (\S.*?) at t=", why).group(1)
    assert first_cause == "/failing/pick one way or another/first try"  # the check is control flow
    server = serve_replay(log)
    try:
        page.goto(server.url)
        page.wait_for_selector("#cause-banner:not([hidden])")
        names = {row.text_content() for row in page.query_selector_all("#tree .row .name")}
        assert {"failing", "start", "pick one way or another", "first try", "gripper holds"} <= names
        assert page.text_content("#outcome") == "failure"
        assert first_cause in page.text_content("#cause-banner")
        cause_row = page.query_selector("#tree .row.cause")
        assert cause_row.query_selector(".name").text_content() == "first try"
        assert cause_row.query_selector(".badge").text_content() == "first cause"
        cause_row.click()
        assert re.fullmatch(r".*failing\.yaml:\d+:\d+", page.text_content("#details .source"))
        page.click("#first-failure")
        assert page.evaluate("window.pegbtMonitor.shownTick") == 2
        assert page.query_selector("#tree .row.selected .name").text_content() == "first try"
    finally:
        server.stop()


@pytest.mark.parametrize("tick", [0, 1, 2, 3, 5])
def test_stepping_to_a_tick_shows_what_log_replay_prints(tmp_path, page, capsys, tick):
    log = run_log(tmp_path, None, "example", capsys)
    expected = replayed_statuses(log, tick, capsys)
    server = serve_replay(log)
    try:
        page.goto(server.url)
        page.wait_for_function("window.pegbtMonitor.loadedAt !== null")
        page.click("#unfold")
        page.fill("#tick-input", str(tick + 1))
        page.press("#tick-input", "Enter")
        page.click("#step-back")  # one tick back: the stepping path, not only the jump
        assert page.input_value("#tick-input") == str(tick)
        shown = rendered_statuses(page)
        assert [shown[node] for node in range(len(expected))] == expected
    finally:
        server.stop()


def test_folding_subtrees_and_search(tmp_path, page, capsys):
    log = run_log(tmp_path, None, "example", capsys)
    server = serve_replay(log)
    try:
        page.goto(server.url)
        page.wait_for_function("window.pegbtMonitor.loadedAt !== null")
        unfolded = len(rendered_statuses(page))
        page.click("#fold")
        folded = rendered_statuses(page)
        assert len(folded) < unfolded
        assert page.query_selector_all("#tree .row .folded")  # each folded instance says what it hides
        page.fill("#search", "settle")
        page.press("#search", "Enter")
        assert page.text_content("#search-count") == "1 of 3"  # two "let the scene settle" and "settle"
        assert (
            page.query_selector("#tree .row.selected .name").text_content() == "let the scene settle"
        )  # unfolded
    finally:
        server.stop()


def test_a_2000_node_tree_loads_in_under_2_s(tmp_path, page, capsys):
    log = run_log(tmp_path, wide_tree(branches=50, checks=38), "big", capsys)
    server = serve_replay(log)
    try:
        page.goto(server.url)
        page.wait_for_function("window.pegbtMonitor.loadedAt !== null", timeout=30_000)
        nodes = page.evaluate("window.pegbtMonitor.state.nodes.length")
        assert nodes == 1 + 50 * 40
        assert page.evaluate("window.pegbtMonitor.loadedAt") < 2000  # ms from navigation to the tree shown
        assert len(page.query_selector_all("#tree .row")) < 200  # only the rows in view are in the document
    finally:
        server.stop()


def test_bad_input_to_the_monitor_is_one_line_naming_what(tmp_path, capsys):
    assert main(["monitor", str(tmp_path / "missing.jsonl")]) == 2
    assert "tick log not found" in capsys.readouterr().err
    corrupt = tmp_path / "corrupt.jsonl"
    corrupt.write_text('{"type": "header"}\n')
    assert main(["monitor", str(corrupt)]) == 2
    assert f"{corrupt}:1" in capsys.readouterr().err
    busy = MonitorServer(free_port()).start()
    try:
        assert main(["run", str(EXAMPLE), "--clock", "manual", "--monitor", str(busy.port)]) == 2
        assert f"cannot serve the monitor on port {busy.port}" in capsys.readouterr().err
    finally:
        busy.stop()
    assert main(["monitor", str(corrupt), "--port", "0"]) == 2
    assert "--port" in capsys.readouterr().err


def test_jumping_to_a_time_and_playing(tmp_path, page, capsys):
    log = run_log(tmp_path, None, "example", capsys)
    assert main(["log", "replay", str(log), "--time", "0.1"]) == 0
    expected_tick = int(re.match(r"after tick (\d+) of", capsys.readouterr().out).group(1))
    server = serve_replay(log)
    try:
        page.goto(server.url)
        page.wait_for_function("window.pegbtMonitor.loadedAt !== null")
        page.fill("#time-input", "0.1")
        page.press("#time-input", "Enter")
        assert page.evaluate("window.pegbtMonitor.shownTick") == expected_tick
        page.fill("#tick-input", "0")
        page.press("#tick-input", "Enter")
        page.select_option("#speed", "1")
        page.click("#play")
        page.wait_for_function("window.pegbtMonitor.shownTick > 0")
        last = page.evaluate("window.pegbtMonitor.state.lastTick")
        page.wait_for_function(f"window.pegbtMonitor.shownTick === {last}", timeout=30_000)
        assert page.text_content("#play") == "▶"  # stopped at the end
    finally:
        server.stop()


def test_a_page_that_joins_a_long_run_late_shows_what_log_replay_prints_after_its_last_tick(
    tmp_path, page, capsys
):
    log = run_log(tmp_path, FAILING, "failing", capsys)
    messages = replay_messages(log)
    last = max(message["n"] for message in messages if message["type"] in ("tick", "end"))
    expected = replayed_statuses(log, last, capsys)
    live = [{**messages[0], "mode": "live"}, *messages[1:]]
    server = start_ephemeral(live, history=History(window=1, world_window=1))  # all but the end left out
    try:
        page.goto(server.url)
        page.wait_for_function("window.pegbtMonitor.loadedAt !== null")
        assert page.evaluate("window.pegbtMonitor.state.events.length") == 1
        shown = rendered_statuses(page)
        assert [shown[node] for node in range(len(expected))] == expected
        first_failure = page.evaluate("window.pegbtMonitor.state.firstFailure()")
        assert first_failure["n"] == 2 and page.text_content("#outcome") == "failure"
        assert "/failing/pick one way or another/first try" in page.text_content("#cause-banner")
    finally:
        server.stop()


def test_a_page_opened_without_the_token_gets_no_run(tmp_path, page, capsys):
    server = serve_replay(run_log(tmp_path, None, "example", capsys))
    try:
        page.goto(server.url.split("?")[0])
        page.wait_for_function("document.getElementById('mode').textContent.includes('disconnected')")
        assert page.evaluate("window.pegbtMonitor.state.header") is None
    finally:
        server.stop()

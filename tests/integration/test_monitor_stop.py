"""`pegbt run --monitor` keeps its page up after the run until Ctrl-C, even when started where SIGINT is ignored
(a shell script's background job, as a whole-suite run in the background is): the run's own handlers are
gone by then, and the ignored SIGINT it inherited would leave it serving for ever."""

from __future__ import annotations

import signal
import subprocess
import sys

from pegbt.sim.process import free_port


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def test_the_page_kept_after_the_run_stops_at_ctrl_c_the_launcher_ignored(tmp_path, pegbt_cli):
    tree = tmp_path / "once.yaml"
    tree.write_text("tree:\n  scripted: {name: once, outcomes: [success]}\n")
    command = [
        sys.executable,
        "-m",
        "pegbt",
        "run",
        tree,
        "--monitor",
        str(free_port()),
        "--log",
        tmp_path / "once.jsonl",
    ]
    process = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=pegbt_cli.env,
        preexec_fn=_ignore_sigint,
    )
    try:
        assert process.stdout is not None, "piped"
        for line in process.stdout:
            if "has ended" in line:
                break
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 0, err

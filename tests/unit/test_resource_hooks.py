"""A resource's optional hooks (`progress`, `report`, `log_messages`) are the Protocols `pegbt.executive.providers`
declares: a run uses each hook a resource has, and the robot and skills resources follow the ones they offer."""

from __future__ import annotations

import io
from types import SimpleNamespace
from typing import Any

from executive_helpers import Counter

from pegbt.behaviours.resources.robot import Robot
from pegbt.behaviours.resources.skills import Skills
from pegbt.executive import providers
from pegbt.executive.providers import LogsMessages, Reports, ShowsProgress
from pegbt.executive.runoptions import RunOptions
from pegbt.executive.session import run_tree_file


class Hooked(Counter):
    """A stand-in resource with every hook: a failed report, one message, a progress listener."""

    def __init__(self, setup: object) -> None:
        super().__init__(setup)
        self.heard = [{"source": "counter", "level": "warning", "text": "heard once", "stamp": 0.0}]
        self.records: list[dict[str, Any]] = []

    def report(self) -> Any:
        return SimpleNamespace(ok=False)

    def log_messages(self) -> list[dict[str, Any]]:
        heard, self.heard = self.heard, []
        return heard

    def progress(self) -> Any:
        return self.records.append


class Unhooked(Counter):
    """A stand-in resource whose hooks are switched off."""

    report = None
    progress = None


def test_the_robot_and_the_skills_follow_the_hooks_they_offer() -> None:
    assert issubclass(Robot, ShowsProgress) and issubclass(Robot, Reports) and issubclass(Robot, LogsMessages)
    assert issubclass(Skills, Reports) and not issubclass(Skills, ShowsProgress)


def test_a_run_uses_every_hook_a_resource_has_and_none_it_lacks(tmp_path, monkeypatch) -> None:
    tree = tmp_path / "uses.yaml"
    tree.write_text("tree:\n  sequence: [{test_counting: {name: count}}]\nblackboard: {step: 41}\n")
    monkeypatch.setitem(providers.RESOURCE_PROVIDERS, "counter", f"{__name__}:Hooked")
    Counter.instances.clear()
    output = run_tree_file(
        RunOptions(tree, tmp_path / "hooked.jsonl", clock="manual"), quiet=False, out=io.StringIO()
    )
    (hooked,) = Counter.instances
    assert output.result.outcome == "success" and not output.ok  # the report's ok is False
    assert hooked.records and hooked.records[-1]["type"] == "end"  # its progress listener saw the run
    assert "heard once" in (tmp_path / "hooked.jsonl").read_text()
    monkeypatch.setitem(providers.RESOURCE_PROVIDERS, "counter", f"{__name__}:Unhooked")
    output = run_tree_file(
        RunOptions(tree, tmp_path / "unhooked.jsonl", clock="manual"), quiet=False, out=io.StringIO()
    )
    assert output.ok and output.reports == {}

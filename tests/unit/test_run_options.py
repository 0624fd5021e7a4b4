"""A run's options are one `RunOptions`, and the tick log's header records them: a folder of tick logs sorts
itself into cells (variant × condition) from the headers alone; logs written before keep reading."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pegbt.behaviours.resources.skills import Skills
from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.evaluation.trial import TrialSpec, run_options, trial_run_options
from pegbt.executive.logfile import TickLogError, read_tick_log
from pegbt.executive.runoptions import RunOptions
from pegbt.executive.session import run_tree_file
from pegbt.sim2real.outcomes.ticklogs import read_tick_logs

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "trees" / "example.yaml"


def test_pegbt_run_records_its_options_in_the_header(tmp_path, capsys):
    log = tmp_path / "run.jsonl"
    argv = ["run", str(EXAMPLE), "--clock", "manual", "--quiet", "--log", str(log), "--period", "0.05"]
    assert main([*argv, "--condition", "uncalibrated", "--seed", "4", "--timeout", "30"]) == 0
    parsed = read_tick_log(log)
    assert (parsed.variant, parsed.condition) == ("example", "uncalibrated")
    run = parsed.run
    assert run["options"]["seed"] == 4 and run["options"]["interface"] == "pegbt"
    assert (run["clock"], run["period"], run["timeout"]) == ("manual", 0.05, 30.0)
    assert run["world"] == {}  # the example tree meets no robot and no simulator
    assert parsed.header["tree"] == str(EXAMPLE) and parsed.header["pegbt"]
    capsys.readouterr()
    assert main(["log", "summary", str(log)]) == 0
    assert "run:      variant example, condition uncalibrated\n" in capsys.readouterr().out


def test_a_run_from_code_names_its_variant_and_world(tmp_path):
    options = RunOptions(
        EXAMPLE,
        tmp_path / "a.jsonl",
        {"condition": "calibrated"},
        clock="manual",
        variant="bilateral",
        world={"physics": "dvrk-real", "speed": "lockstep"},
    )
    run_tree_file(options)
    parsed = read_tick_log(options.log)
    assert (parsed.variant, parsed.condition) == ("bilateral", "calibrated")


def test_a_trial_records_its_cell_and_the_simulator_it_ran_on(tmp_path):
    spec = TrialSpec("handover", "uncalibrated", 7, tmp_path / "t.jsonl", realtime=True, interface="dvrk")
    options = trial_run_options(spec, run_options(spec, "tcp/127.0.0.1:7447"))
    fields = options.record_fields()
    assert (fields["variant"], fields["condition"]) == ("handover", "uncalibrated")
    assert fields["run"]["tree"].endswith("trees/handover.yaml")
    assert fields["run"]["world"] == {
        "simulator": "pegbt sim",
        "physics": "dvrk-real",
        "speed": "real time",
        "seed": 7,
        "faults": None,
        "world_effects": None,
    }
    world_file = str(tmp_path / "soft.yaml")
    lockstep = trial_run_options(
        TrialSpec("unilateral", "optimized", 3, tmp_path / "u.jsonl", world_effects=Path(world_file)),
        {"endpoint": "auto", "seed": 3, "world-effects": world_file},
    )
    run = lockstep.record_fields()["run"]
    assert (run["world"]["speed"], run["world"]["world_effects"]) == ("lockstep", world_file)
    assert run["options"]["world-effects"] == world_file


def test_bad_options_are_refused_when_built(tmp_path):
    with pytest.raises(PegbtError, match="'sideways' is not one of uncalibrated"):
        RunOptions(EXAMPLE, tmp_path / "x.jsonl", {"condition": "sideways"})
    with pytest.raises(PegbtError, match="unknown run option 'colour'"):
        RunOptions(EXAMPLE, tmp_path / "x.jsonl", {"colour": "red"})
    with pytest.raises(PegbtError) as raised:
        RunOptions(EXAMPLE, tmp_path / "x.jsonl", period=0.0)
    assert raised.value.field == "--period"


def _old_header(tmp_path: Path, **extra: object) -> Path:
    header = {
        "type": "header",
        "format": "pegbt-ticklog",
        "format_version": 1,
        "pegbt": "0.1.0",
        "tree": "trees/unilateral.yaml",
        "start_time": "2026-01-01T00:00:00+00:00",
        "clock": "wall",
        "blackboard": {},
        "nodes": [
            {"id": 0, "parent": None, "path": "/r", "name": "r", "type": "sequence", "source": "t:1:1"}
        ],
        **extra,
    }
    path = tmp_path / "old.jsonl"
    path.write_text(
        json.dumps(header) + "\n" + json.dumps({"type": "end", "n": 1, "t": 0.0, "outcome": "success"}) + "\n"
    )
    return path


def test_a_log_written_before_headers_named_the_run_still_reads(tmp_path):
    parsed = read_tick_log(_old_header(tmp_path))
    assert (parsed.variant, parsed.condition, parsed.run) == ("unilateral", None, {})


def test_a_header_whose_run_is_not_a_mapping_is_refused_with_its_field(tmp_path):
    with pytest.raises(TickLogError, match="expected a mapping, found") as raised:
        read_tick_log(_old_header(tmp_path, run=[1, 2]))
    assert (raised.value.line, raised.value.field) == (1, "run")
    with pytest.raises(TickLogError, match="expected a string or null") as raised:
        read_tick_log(_old_header(tmp_path, condition=3))
    assert raised.value.field == "condition"


def test_the_paper_s_protocol_is_recorded_with_the_policies_it_sets(tmp_path):
    """`--protocol paper`: the header records it among the options, and the blackboard policies it sets
    (no recovery; the look before lowering with the cubic motions only, as the paper's optimised
    trajectory did not stop over the peg), which a trial's tree declares."""
    for condition, looks in (("uncalibrated", True), ("calibrated", True), ("optimized", False)):
        spec = TrialSpec("unilateral", condition, 1, tmp_path / "t.jsonl", protocol="paper")
        fields = trial_run_options(spec, run_options(spec, "tcp/127.0.0.1:7447")).record_fields()
        assert fields["run"]["options"]["protocol"] == "paper"
        assert fields["run"]["blackboard"] == {
            "/policy/recover_lost_blocks": False,
            "/policy/look_before_lowering": looks,
        }
    spec = TrialSpec("unilateral", "uncalibrated", 1, tmp_path / "t.jsonl")
    fields = trial_run_options(spec, run_options(spec, "tcp/127.0.0.1:7447")).record_fields()
    assert fields["run"]["options"]["protocol"] == "pegbt" and fields["run"]["blackboard"] == {}
    assert read_tick_log(_old_header(tmp_path)).protocol == "pegbt"  # a log from before the option


def test_the_paper_s_protocol_looks_at_the_block_held_out_in_a_handover_with_cubic_motions(tmp_path):
    """`/policy/look_at_handover` (trees/shared/handover.yaml): set in a handover under the paper's protocol,
    true where the motions are rest-to-rest cubics; never in another variant, whose trees do not declare
    it, nor under pegbt's protocol."""
    for condition, looks in (("uncalibrated", True), ("calibrated", True), ("optimized", False)):
        spec = TrialSpec("handover", condition, 1, tmp_path / "t.jsonl", protocol="paper")
        fields = trial_run_options(spec, run_options(spec, "tcp/127.0.0.1:7447")).record_fields()
        assert fields["run"]["blackboard"]["/policy/look_at_handover"] is looks
    for variant, protocol in (("bilateral", "paper"), ("handover", "pegbt")):
        spec = TrialSpec(variant, "uncalibrated", 1, tmp_path / "t.jsonl", protocol=protocol)
        fields = trial_run_options(spec, run_options(spec, "tcp/127.0.0.1:7447")).record_fields()
        assert "/policy/look_at_handover" not in fields["run"]["blackboard"]


def test_a_bad_protocol_is_refused_naming_the_option_or_the_tree_file(tmp_path, capsys):
    with pytest.raises(PegbtError, match="'sideways' is not one of pegbt, paper") as raised:
        RunOptions(EXAMPLE, tmp_path / "x.jsonl", {"protocol": "sideways"})
    assert raised.value.field == "--protocol"
    out = ["--out", str(tmp_path / "e")]
    assert main(["eval", "--variant", "unilateral", "--trials", "1", "--protocol", "sideways", *out]) == 2
    assert "--protocol: unknown protocol 'sideways'; known: pegbt, paper" in capsys.readouterr().err
    # a tree that declares none of the policies cannot run under the paper's protocol, which the error names
    with pytest.raises(
        PegbtError, match="--protocol paper sets it, but the tree declares no blackboard key '/policy/"
    ) as raised:
        run_tree_file(RunOptions(EXAMPLE, tmp_path / "x.jsonl", {"protocol": "paper"}, clock="manual"))
    assert raised.value.file == str(EXAMPLE) and str(raised.value.field).startswith("/policy/")
    # a policy the caller set itself is not the protocol's to answer for, whichever protocol runs
    for protocol in ("paper", "pegbt"):
        own = {"/policy/recover_lost_blocks": True, "/policy/look_before_lowering": False}
        with pytest.raises(PegbtError) as raised:
            run_tree_file(
                RunOptions(
                    EXAMPLE, tmp_path / "x.jsonl", {"protocol": protocol}, blackboard=own, clock="manual"
                )
            )
        assert raised.value.message.startswith("the tree declares no blackboard key '/policy/"), protocol
        assert "--protocol" not in raised.value.message and raised.value.file == str(EXAMPLE)
    # a key a command asked for is still refused in its own words
    with pytest.raises(PegbtError) as raised:
        run_tree_file(RunOptions(EXAMPLE, tmp_path / "x.jsonl", blackboard={"/nowhere": 1}, clock="manual"))
    assert raised.value.message.startswith("the tree declares no blackboard key '/nowhere'")
    assert raised.value.field == "/nowhere"
    with pytest.raises(PegbtError, match="has heights for unilateral, bilateral, handover only") as raised:
        Skills("uncalibrated", protocol="paper", variant="example")
    assert raised.value.field == "variant"


@pytest.mark.parametrize("options", [{"protocol": "sideways"}, ["paper"]])
def test_a_tick_log_whose_header_names_no_known_protocol_is_refused_not_counted_as_pegbt_s(tmp_path, options):
    """Its cells would be counted by another protocol's rule (`pegbt sim2real outcomes --tick-logs`)."""
    path = _old_header(tmp_path, variant="unilateral", condition="uncalibrated", run={"options": options})
    with pytest.raises(TickLogError, match="expected one of pegbt, paper") as raised:
        read_tick_logs(tmp_path)
    assert (raised.value.file, raised.value.line, raised.value.field) == (
        str(path),
        1,
        "run.options.protocol",
    )


def test_a_paper_protocol_tick_log_whose_transfer_names_no_pick_peg_is_refused_on_its_node(tmp_path):
    """The paper's count follows each block from its pick peg: a transfer without one cannot be counted."""
    nodes = [
        {"id": 0, "parent": None, "path": "/r", "name": "r", "type": "sequence", "source": "t:1:1"},
        {"id": 1, "parent": 0, "path": "/r/b", "name": "b", "type": "begin_transfer", "source": "t:2:1"},
    ]
    nodes[1]["params"] = {"place": 7}
    run = {"options": {"protocol": "paper"}}
    path = _old_header(tmp_path, variant="unilateral", condition="uncalibrated", run=run, nodes=nodes)
    end = path.read_text().splitlines()[1]
    tick = {"type": "tick", "n": 1, "t": 0.0, "changes": [[1, "INVALID", "SUCCESS", ""]]}
    path.write_text(path.read_text().splitlines()[0] + "\n" + json.dumps(tick) + "\n" + end + "\n")
    with pytest.raises(TickLogError, match="names pick None and place 7, not one of unilateral's") as raised:
        read_tick_logs(tmp_path)
    assert (raised.value.file, raised.value.field) == (str(path), "nodes[1].params")
    nodes[1]["params"] = {"pick": 1, "place": 2}  # two pegs, but no transfer of the paper's order
    path.write_text(
        "\n".join(
            [
                json.dumps({**json.loads(path.read_text().splitlines()[0]), "nodes": nodes}),
                *path.read_text().splitlines()[1:],
            ]
        )
        + "\n"
    )
    with pytest.raises(TickLogError, match="names pick 1 and place 2, not one of unilateral's") as raised:
        read_tick_logs(tmp_path)
    assert (raised.value.file, raised.value.field) == (str(path), "nodes[1].params")

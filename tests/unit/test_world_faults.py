"""Injected faults, determinism per seed, and the event log on disk."""

import json

import pytest

from pegbt.errors import PegbtError
from pegbt.sim.events import read_events
from pegbt.sim.faults import SlipAt, WorldFaults
from pegbt.sim.scripted import Driver, grasp_candidate_facing, transfer_keyframes
from pegbt.sim.world import World
from pegbt.yamlfile import parse_yaml


def _transfer(world, block=1, goal=7):
    return Driver(world).play(
        {"PSM1": transfer_keyframes(world, block, goal, grasp_candidate_facing(world, block, "PSM1"))}
    )


def kinds(events):
    return [event.kind for event in events]


def test_a_scheduled_slip_drops_the_carried_block():
    clean = World(seed=1)
    lift_time = next(event.time for event in _transfer(clean) if event.kind == "lift")
    world = World(seed=1, faults=WorldFaults(slips=(SlipAt(lift_time + 0.2, "PSM1"),)))
    events = _transfer(world)
    assert kinds(events) == ["grasp", "lift", "fault", "slip", "drop"]
    fault = events[2]
    assert (
        fault.arm == "PSM1" and fault.block == 1 and fault.time == pytest.approx(lift_time + 0.2, abs=0.011)
    )
    assert events[4].detail.startswith("onto the board") and world.blocks[1].state == "on_board"


def test_a_slip_with_nothing_held_is_still_logged():
    world = World(seed=1, faults=WorldFaults(slips=(SlipAt(0.05),)))
    events = _transfer(world)
    assert kinds(events)[0] == "fault" and "nothing held" in events[0].detail
    assert kinds(events)[1:] == ["grasp", "lift", "release", "place"]


def test_a_configured_missed_grasp_then_the_retry_holds():
    world = World(seed=1, faults=WorldFaults(miss_attempts=frozenset({0})))
    events = _transfer(world)
    assert kinds(events)[:2] == ["fault", "grasp_miss"] and events[1].detail == "injected fault"
    assert world.blocks[1].peg == 1  # never picked up
    events = _transfer(world)
    assert kinds(events) == ["grasp", "lift", "release", "place"]


def test_random_faults_are_the_same_for_the_same_seed():
    faults = WorldFaults(slip_rate=0.5, miss_probability=0.3)
    logs = []
    for seed in (7, 7, 8):
        world = World(seed=seed, faults=faults)
        for block, goal in ((1, 7), (0, 6), (3, 8)):
            if world.blocks[block].state == "on_peg":
                _transfer(world, block, goal)
        logs.append(world.events.to_dicts())
    assert logs[0] == logs[1]
    assert logs[0] != logs[2]
    assert any(event["kind"] == "fault" for log in logs for event in log)


def _world_faults(text: str) -> WorldFaults:
    return WorldFaults.read(parse_yaml(text, "sim.yaml"))


def test_faults_from_configuration_and_their_errors():
    faults = _world_faults("slips: [{time: 2.5, arm: PSM2}, {time: 1}]\nmiss_probability: 0.1\n")
    assert faults.slips == (SlipAt(1.0, None), SlipAt(2.5, "PSM2")) and faults.miss_probability == 0.1
    with pytest.raises(PegbtError) as caught:
        _world_faults("slips:\n  - {time: 1, arm: PSM3}\n")
    error = caught.value
    assert (error.file, error.line, error.column, error.field) == ("sim.yaml", 2, 20, "slips[0].arm")
    with pytest.raises(PegbtError, match=r"\[0, 1\]"):
        _world_faults("miss_probability: 2")
    with pytest.raises(PegbtError) as caught:
        _world_faults("slip_chance: 0.1")
    assert caught.value.field == "slip_chance" and "unknown field" in caught.value.message


def test_a_slips_entry_that_is_not_a_list_is_located():
    with pytest.raises(PegbtError) as caught:
        _world_faults("slips: 5\n")
    error = caught.value
    assert (error.file, error.line, error.column, error.field) == ("sim.yaml", 1, 8, "slips")
    assert "expected a list" in error.message


def test_the_event_log_round_trips_through_json_lines(tmp_path):
    world = World(seed=1)
    _transfer(world)
    path = tmp_path / "events.jsonl"
    world.events.write(path)
    assert read_events(path) == list(world.events)
    assert json.loads(path.read_text().splitlines()[0])["kind"] == "grasp"
    json.dumps(world.snapshot())  # the state is JSON-ready too
    path.write_text('{"time": 1, "kind": "teleport"}\n')
    with pytest.raises(PegbtError) as caught:
        read_events(path)
    assert (caught.value.line, caught.value.field) == (1, "kind")


def test_a_slip_timed_after_an_event_falls_that_long_after_it_whenever_it_happens():
    clean = World(seed=1)
    lift_time = next(event.time for event in _transfer(clean) if event.kind == "lift")
    world = World(seed=1, faults=_world_faults("slips: [{time: 0.2, after: {event: lift, arm: PSM1}}]\n"))
    world.update(1.5, {})  # time passes before the transfer: the slip moves with the lift
    events = _transfer(world)
    assert kinds(events) == ["grasp", "lift", "fault", "slip", "drop"]
    lift, fault = events[1], events[2]
    assert lift.time == pytest.approx(lift_time + 1.5, abs=0.011)
    assert fault.arm == "PSM1" and fault.time == pytest.approx(lift.time + 0.2, abs=0.011)


def test_a_slip_after_the_nth_event_waits_for_it():
    world = World(seed=1, faults=_world_faults("slips: [{time: 0.1, after: {event: lift, nth: 2}}]\n"))
    assert kinds(_transfer(world)) == ["grasp", "lift", "release", "place"]
    assert kinds(_transfer(world, 0, 6)) == ["grasp", "lift", "fault", "slip", "drop"]


def test_an_unknown_event_to_time_a_slip_after_is_named():
    with pytest.raises(PegbtError) as caught:
        _world_faults("slips:\n  - {time: 1, after: {event: lifted}}\n")
    assert (caught.value.line, caught.value.field) == (2, "slips[0].after.event")

"""`dev/handover_carries.py`, the measurement of the handover givers' carries in docs/internals/motion.md:
every carry is planned by the SQP and takes longer than the bound through its own grasp, meeting and the
channel's clearing height, which is itself above the bound through the lower lift."""

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_each_carry_is_refined_and_above_its_bounds_through_pegbts_own_poses(monkeypatch):
    spec = importlib.util.spec_from_file_location("handover_carries", ROOT / "dev" / "handover_carries.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)  # its dataclass looks itself up there
    spec.loader.exec_module(module)
    found = module.carries(2)
    assert len(found) == 12
    assert [c.giver for c in found] == ["PSM2"] * 6 + ["PSM1"] * 6
    for carry in found:
        assert carry.method == "sqp"
        assert carry.from_ends < carry.with_margin < carry.planned

"""`Skills` where `pegbt.behaviours.handover` imports it from: that module is rewritten on another branch
and joins the grouped leaves when the branches merge; the resource itself is `resources/skills.py`."""

from pegbt.behaviours.resources.skills import Skills

__all__ = ["Skills"]

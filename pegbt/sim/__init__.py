"""The simulator endpoint: two PSMs behind CRTK topics, the pegboard world they act in (blocks,
ground-truth events) and its depth camera. `pegbt sim` runs it in real time or in lockstep with a
client's `SimClock`.

The endpoint (`endpoint.py`) composes parts with one job each: the arm controller (`arm.py`, its
motion profiles in `playback.py`), command dispatch (`commands.py`), publication (`outbox.py`),
lockstep stepping (`lockstep.py`), the judge's query (`truth.py`) and log (`log.py`). The world
(`world.py`, `blocks.py`, `events.py`, `faults.py`) and the camera (`camera.py`, `meshes.py`) are pure
Python and Open3D, without transport, and reach the endpoint through `interfaces.py`.
"""

"""The simulator endpoint: two PSMs behind CRTK topics, the pegboard world they act in (blocks,
ground-truth events) and its depth camera.

`pegbt sim` runs it in real time or in lockstep with a client's `SimClock`; see `endpoint.py`.
"""

"""Leaf behaviours, declared by name with the executive's behaviour registry in one table (`leaves.py`,
from the shared parameters of `params.py`), grouped by kind as Nav2 groups its behaviour-tree plugins:
`actions/` change the world or the blackboard, `conditions/` only look. `resources/` holds what they
share (the robot, the skills); `base.py`, `motion.py` and `poses.py` the leaf bases and the geometry
every motion leaf uses.

`actions/generic.py` and `conditions/blackboard.py` hold the robot-free leaves (wait, blackboard
set/check, log, scripted outcomes) that let trees and their recovery logic be tested without a robot.
"""

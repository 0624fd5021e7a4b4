"""Leaf behaviours, registered by name with the executive's behaviour registry, grouped by task phase.

`generic` holds the robot-free leaves (wait, blackboard set/check, log, scripted outcomes) that let
trees and their recovery logic be tested without a robot.
"""

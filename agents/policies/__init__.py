"""Policies that act on the env's observations: the Rearrange planner and the scripted grasp."""

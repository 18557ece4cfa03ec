"""HERB and the scene inside pybullet: the simulator wrapper, the robot's joint and hand
control, the controllers that turn actions into motor commands, and the task's physical rules
of success and failure. Only `clutter_gym.env` composes these."""
